"""The one place where an unexpected exception from a reader becomes a user's error.

Every reader validates its fields and raises
:class:`~camsim_core.errors.CamsimError` naming the file. A reader added
later, or a library (scipy, h5py, Pillow, numpy) failing on an input no
check foresaw, must still not show a user a traceback or a path of the
server: :func:`reader_errors` wraps every entry point that reads a file a
user handed over (:func:`~camsim_core.scene.load_scene`,
:func:`~camsim_core.io.upload.load_upload`) and turns anything else into a
:class:`~camsim_core.errors.FileFormatError` naming the user's file, with
the exception's type and its message stripped of absolute paths. The
traceback goes to the ``camsim`` logger at debug level only, for a
developer who asks for it.

Examples
--------
>>> from camsim_core.errors import FileFormatError
>>> try:
...     with reader_errors("scene.mat"):
...         raise KeyError("/srv/secret/file")
... except FileFormatError as exc:
...     print(exc)
scene.mat: could not be read (KeyError: '<path>')
"""

from __future__ import annotations

import logging
import re
from contextlib import contextmanager

from ..errors import CamsimError, FileFormatError

__all__ = ["reader_errors", "scrub_paths"]

_LOG = logging.getLogger("camsim")
#: An absolute POSIX path or a Windows drive path inside a message.
_PATH = re.compile(r"(?:[A-Za-z]:[\\/]|(?<![\w.])/)[^\s'\",;:()\[\]]*")


def scrub_paths(text, keep=()):
    """``text`` with every absolute path replaced by ``<path>`` (the ``keep`` names stay).

    Examples
    --------
    >>> scrub_paths("Unable to open file (name = '/tmp/x/secret.h5')")
    "Unable to open file (name = '<path>')"
    """
    text = str(text)
    marks = {f"\x00{i}\x00": k for i, k in enumerate(keep) if k}
    for m, k in marks.items():
        text = text.replace(k, m)
    text = _PATH.sub("<path>", text)
    for m, k in marks.items():
        text = text.replace(m, k)
    return text[:500]


@contextmanager
def reader_errors(shown, what=""):
    """Map any exception but a CamsimError escaping the block to a FileFormatError naming ``shown``.

    Parameters
    ----------
    shown : str
        The user's name of the file (never a server path).
    what : str, optional
        What the file was read as, for the message (e.g. ``"a MATLAB file"``).

    Notes
    -----
    ``MemoryError`` and ``RecursionError`` are mapped too (a file too large
    or too deeply nested for this machine); ``KeyboardInterrupt`` and
    ``SystemExit`` pass.
    """
    try:
        yield
    except CamsimError:
        raise
    except MemoryError:
        raise FileFormatError(shown, "too large to read on this machine") from None
    except Exception as exc:
        _LOG.debug("reader error on %s", shown, exc_info=True)
        detail = scrub_paths(exc, keep=(str(shown),))
        kind = f" as {what}" if what else ""
        raise FileFormatError(shown, f"could not be read{kind} ({type(exc).__name__}: {detail})") from None
