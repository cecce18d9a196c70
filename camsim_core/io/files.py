"""Opening input files safely: regular files only, bounded reads, names confined to a folder.

Every reader of camsim goes through :func:`read_regular` (or checks with
:func:`check_regular` before handing a path to a library), so that a FIFO
never hangs a reader, a device such as ``/dev/zero`` is never read until
memory runs out, and a file is never read past the size its format allows.
:func:`member_path` resolves a name written inside a file (a ``.Simg``
header's image root or camera file) against the folder of that file and
refuses, before touching the file system, any name that could leave it.

Hand-written: the standard library has the pieces (``os.stat``,
``stat.S_ISREG``, ``os.open`` with ``O_NONBLOCK``) but no function doing
all of them.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path, PurePosixPath, PureWindowsPath

from ..errors import FileFormatError

__all__ = ["check_regular", "read_regular", "open_regular", "member_path", "MAX_TEXT_BYTES"]

#: Largest text file (``.Simg``, ``.Scam``, ``.Smon``, ``.dat``) a reader accepts, bytes.
MAX_TEXT_BYTES = 16 * 2**20


def check_regular(path, shown=None):
    """``os.stat`` of ``path`` if it is a regular file; else a FileFormatError naming ``shown``.

    ``shown`` is the name the user knows the file by (default: ``path``).
    """
    shown = path if shown is None else shown
    try:
        st = os.stat(path)
    except OSError as exc:
        raise FileFormatError(shown, f"cannot read: {exc.strerror or 'not found'}") from None
    if not stat.S_ISREG(st.st_mode):
        raise FileFormatError(shown, "not a regular file (a folder, FIFO or device is never read)")
    return st


def read_regular(path, *, max_bytes=MAX_TEXT_BYTES, shown=None):
    """The bytes of the regular file ``path``, refusing special files and files over ``max_bytes``.

    The file is opened non-blocking (a FIFO swapped in after the check
    cannot hang the reader) and checked again on its descriptor; at most
    ``max_bytes + 1`` bytes are ever read, whatever the file claims.
    """
    shown = path if shown is None else shown
    check_regular(path, shown)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise FileFormatError(shown, f"cannot read: {exc.strerror or exc}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise FileFormatError(shown, "not a regular file (a folder, FIFO or device is never read)")
        if max_bytes is not None and st.st_size > max_bytes:
            raise FileFormatError(shown, f"is {st.st_size} bytes, more than the {max_bytes} allowed for this kind of file")
        chunks, total = [], 0
        limit = None if max_bytes is None else max_bytes + 1
        while True:
            want = 1 << 20 if limit is None else min(1 << 20, limit - total)
            if want <= 0:
                break
            chunk = os.read(fd, want)
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if max_bytes is not None and total > max_bytes:
            raise FileFormatError(shown, f"is more than the {max_bytes} bytes allowed for this kind of file")
        return b"".join(chunks)
    except OSError as exc:
        raise FileFormatError(shown, f"cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def open_regular(path, shown=None):
    """A binary file object of the regular file ``path``, opened non-blocking and checked on its descriptor.

    For readers that hand a file object to a library (h5py, scipy.io): the
    library then never opens anything by name, so a FIFO or device swapped
    in after a check is refused, not read.
    """
    shown = path if shown is None else shown
    check_regular(path, shown)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise FileFormatError(shown, f"cannot read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise FileFormatError(shown, "not a regular file (a folder, FIFO or device is never read)")
    return os.fdopen(fd, "rb")


def member_path(folder, name, *, shown, field):
    """``folder / name`` for a relative ``name`` that stays inside ``folder``.

    ``name`` comes from inside a file (``shown``, the user's name for it)
    and ``field`` is where (e.g. ``#SimImageRoot``). Absolute names, drive
    letters and ``..`` are refused by their text alone, before any file is
    looked at, and the message never says whether anything exists outside.
    """
    text = str(name).strip()
    if "\x00" in text:
        raise FileFormatError(shown, f"{field} holds a NUL character")
    if not text:
        return Path(folder)
    posix, win = PurePosixPath(text.replace("\\", "/")), PureWindowsPath(text)
    if posix.is_absolute() or win.drive or win.root or text.startswith("~"):
        raise FileFormatError(shown, f"{field} must name a file beside the header, not an absolute path")
    if ".." in posix.parts:
        raise FileFormatError(shown, f"{field} must name a file beside the header; '..' is not allowed")
    base = Path(folder).resolve()
    target = (base / posix).resolve()
    if target != base and base not in target.parents:  # a symbolic link pointing out
        raise FileFormatError(shown, f"{field} must name a file beside the header")
    return base / posix
