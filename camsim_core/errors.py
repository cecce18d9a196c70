"""Errors that camsim raises on bad input.

Every error names the file, field or parameter at fault and says what was
expected, so that a user never has to read a traceback from inside numpy.
"""

__all__ = ["CamsimError", "FileFormatError", "ParameterError"]


class CamsimError(ValueError):
    """Base class of camsim's input errors (a ``ValueError``)."""


class FileFormatError(CamsimError):
    """A file is missing, truncated, or lacks a required field."""

    def __init__(self, path, message):
        self.path = str(path)
        super().__init__(f"{path}: {message}")


class ParameterError(CamsimError):
    """A parameter is out of its valid range or of the wrong kind."""

    def __init__(self, name, message):
        self.name = name
        super().__init__(f"{name}: {message}")
