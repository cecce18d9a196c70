"""Opening HDF5 files (MATLAB v7.3) so that they can never reach outside their own bytes.

HDF5 can name other files from inside a file: a dataset's *external
storage* keeps its values in raw files named by path (the password file, a
FIFO that blocks forever, a process's environment in procfs), an *external
link* opens another HDF5 file, a *virtual dataset* maps other files'
datasets, and a *user-defined filter* makes the library load a plugin
library from disk. Soft links can form loops, and user-defined link types
run code. :func:`open_hdf5` refuses all of these, at any depth of the file,
**before any dataset's values are read**, with a
:class:`~camsim_core.errors.FileFormatError` naming the user's file and the
object at fault (never a path of the server):

* every link below the root is visited without being followed
  (``H5Lvisit`` follows hard links only); anything but a hard link is
  refused;
* every dataset's creation properties are read (layout, external files,
  filters), which touches no data; a virtual layout, any external file and
  any filter outside HDF5's built-in set are refused;
* the file is opened from a Python file object (the upload's bytes in
  memory, or a descriptor of a checked regular file), never from a path
  that relative names inside the file could be resolved against; and the
  plugin search path is emptied for the process, so that no filter plugin
  is ever loaded even if a check were missed.

Hand-written: h5py exposes each property (``PropDCID.get_external_count``,
``get_layout``, ``get_filter``) but no function that vets a whole file.

Examples
--------
>>> import io, h5py, numpy as np
>>> buf = io.BytesIO()
>>> with h5py.File(buf, "w") as f:
...     _ = f.create_dataset("rad", data=np.ones((2, 3, 4)))
>>> with open_hdf5(buf.getvalue(), shown="scene.mat") as f:
...     f["rad"].shape
(2, 3, 4)
"""

from __future__ import annotations

import io
from contextlib import contextmanager

from ..errors import FileFormatError
from .files import open_regular

__all__ = ["open_hdf5", "check_dataset", "BUILTIN_FILTERS", "MAX_HDF5_OBJECTS"]

#: Filters built into the HDF5 library (deflate, shuffle, Fletcher-32, SZIP, N-bit, scale-offset):
#: no plugin is loaded for them. Any other filter id names a plugin and is refused.
BUILTIN_FILTERS = {1: "deflate", 2: "shuffle", 3: "fletcher32", 4: "szip", 5: "nbit", 6: "scaleoffset"}
#: Most links a file may hold (a MATLAB scene has a few dozen); more is refused before the walk goes on.
MAX_HDF5_OBJECTS = 100_000

_plugins_off = False


def _no_plugins():
    """Empty HDF5's plugin search path once per process: no filter library is ever loaded from disk."""
    global _plugins_off
    if _plugins_off:
        return
    from h5py import h5pl

    while h5pl.size():
        h5pl.remove(0)
    _plugins_off = True


def check_dataset(dataset, shown):
    """Refuse a dataset whose values would come from outside the file, or through a plugin.

    Parameters
    ----------
    dataset : h5py.Dataset or h5py.h5d.DatasetID
    shown : str
        The user's name of the file, for messages.

    Raises
    ------
    FileFormatError
        For a virtual dataset, external storage, or a filter that is not
        built into HDF5 (see :data:`BUILTIN_FILTERS`).
    """
    import h5py
    from h5py import h5d

    dsid = dataset.id if isinstance(dataset, h5py.Dataset) else dataset
    name = _name(dsid)
    dcpl = dsid.get_create_plist()
    if dcpl.get_layout() == h5d.VIRTUAL:
        raise FileFormatError(shown, f"dataset {name} is a virtual dataset, which reads other files; refused")
    if dcpl.get_external_count() > 0:
        raise FileFormatError(shown, f"dataset {name} keeps its values in external files; refused "
                                     "(save the scene with its data inside the file)")
    for i in range(dcpl.get_nfilters()):
        fid = dcpl.get_filter(i)[0]
        if fid not in BUILTIN_FILTERS:
            raise FileFormatError(shown, f"dataset {name} uses filter {fid}, which is not built into HDF5 "
                                         f"(only {', '.join(BUILTIN_FILTERS.values())}); refused")


def _name(oid):
    from h5py import h5i

    try:
        return h5i.get_name(oid).decode("utf-8", "replace")
    except Exception:  # an anonymous object has no name
        return "(unnamed)"


def _walk(f, shown):
    """Visit every link below the root without following it; check each dataset's properties.

    The callback records the first refusal and stops the visit by returning
    it: an exception raised inside an h5py visit callback reaches the
    caller as a bare SystemError.
    """
    from h5py import h5l, h5o

    count = 0

    def visit(name, info):
        nonlocal count
        count += 1
        text = name.decode("utf-8", "replace") if isinstance(name, bytes) else str(name)
        if count > MAX_HDF5_OBJECTS:
            return FileFormatError(shown, f"holds more than {MAX_HDF5_OBJECTS} objects; refused")
        if info.type != h5l.TYPE_HARD:
            kind = {h5l.TYPE_SOFT: "a soft link", h5l.TYPE_EXTERNAL: "an external link to another file"}.get(
                info.type, f"a user-defined link (type {info.type})")
            return FileFormatError(shown, f"/{text} is {kind}; links other than hard links are refused")
        try:
            if h5o.get_info(f.id, name).type == h5o.TYPE_DATASET:
                check_dataset(h5o.open(f.id, name), shown)
        except FileFormatError as exc:
            return exc
        return None

    refusal = f.id.links.visit(visit, info=True)
    if refusal is not None:
        raise refusal


def _file_object(source, shown):
    """A seekable binary file object over ``source`` (bytes, or the path of a regular file)."""
    if isinstance(source, (bytes, bytearray, memoryview)):
        return io.BytesIO(bytes(source))
    return open_regular(source, shown)


@contextmanager
def open_hdf5(source, *, shown):
    """Open ``source`` read-only as an ``h5py.File`` after the whole file is vetted (a context manager).

    Parameters
    ----------
    source : bytes or path-like
        The file's bytes (an upload: read from memory) or the path of a
        regular file the user named (read through a descriptor, never
        reopened by name).
    shown : str
        The user's name of the file, for messages.

    Yields
    ------
    h5py.File
        Open read-only; it and its file object are closed when the block ends.

    Raises
    ------
    FileFormatError
        Not an HDF5 file, or a file that names other files or a plugin (see
        the module docstring). Messages name ``shown`` only.
    """
    import h5py

    _no_plugins()
    with _file_object(source, shown) as fobj:
        try:
            f = h5py.File(fobj, "r")
        except Exception as exc:
            raise FileFormatError(shown, f"not a readable HDF5 (MATLAB v7.3) file ({type(exc).__name__})") from None
        with f:
            try:
                _walk(f, shown)
            except FileFormatError:
                raise
            except Exception as exc:  # a corrupt object header or link table
                raise FileFormatError(shown, f"corrupt HDF5 structure ({type(exc).__name__})") from None
            yield f
