"""Errors that camsim raises on bad input.

Every error names the file, field or parameter at fault and says what was
expected, so that a user never has to read a traceback from inside numpy.
"""

__all__ = ["CamsimError", "FileFormatError", "ParameterError"]


class CamsimError(ValueError):
    """Base class of camsim's input errors (a ``ValueError``).

    Examples
    --------
    >>> issubclass(ParameterError, CamsimError) and issubclass(CamsimError, ValueError)
    True
    """


class FileFormatError(CamsimError):
    """A file is missing, truncated, or lacks a required field.

    Examples
    --------
    >>> err = FileFormatError("scene.hdr", "no 'bands' field")
    >>> str(err), err.path
    ("scene.hdr: no 'bands' field", 'scene.hdr')
    """

    def __init__(self, path, message):
        self.path = str(path)
        super().__init__(f"{path}: {message}")


class ParameterError(CamsimError):
    """A parameter is out of its valid range or of the wrong kind.

    Examples
    --------
    >>> err = ParameterError("f_stop", "must be positive, got -2")
    >>> str(err), err.name
    ('f_stop: must be positive, got -2', 'f_stop')
    """

    def __init__(self, name, message):
        self.name = name
        super().__init__(f"{name}: {message}")
