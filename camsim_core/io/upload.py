"""Scenes uploaded as bytes (the explorer's upload): bounded, and confined to their own folder.

An upload is an ``.npz`` scene, a MATLAB ``.mat`` or a photo (read by
:mod:`camsim_core.scene.matlab` / :mod:`~camsim_core.scene.photo`), or a
``.zip`` holding a ``.Simg`` header with its plane files (and, optionally,
its hyperspectral camera's ``.Scam``), an ENVI ``.hdr`` with its data file,
or a folder of band PNGs. It is unpacked into a fresh temporary folder and read from
there only:

* its size is checked first (:attr:`UploadLimits.max_upload_bytes`);
* a zip is checked from its central directory (member count, each member's
  and the total uncompressed size, member names) before anything is
  written, and extracted with those limits enforced on the bytes actually
  decompressed, never on the sizes the zip declares;
* every name in the header (``#SimImageRoot``, ``#SimCameraFile``) must name
  a member of the upload; a camera file not in the upload is taken from the
  shipped cameras by name; nothing else of the server is opened;
* the scene's size (pixels x planes) is checked from the ``.Simg`` header or
  the ``.npz`` array headers before anything is allocated.

Every error names the user's file (and the member at fault), never a path
of the server.
"""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from ..errors import CamsimError, FileFormatError
from ..scene.scene import RadianceClipped
from .guard import reader_errors

__all__ = ["UploadLimits", "load_upload", "upload_name", "DEFAULT_LIMITS", "UPLOAD_KINDS", "UPLOAD_NEGATIVE"]

#: What an upload's negative radiances become (``negative=`` of the readers): set to 0, with a notice.
UPLOAD_NEGATIVE = "clip"


@dataclass(frozen=True)
class UploadLimits:
    """Bounds on one uploaded scene (settable with ``camsim serve`` flags).

    Attributes
    ----------
    max_upload_bytes : int
        Largest upload, bytes (default 16 MiB: the explorer sends uploads in
        1 MiB pieces, and this stays below Bokeh's 20 MiB websocket message
        limit that ``camsim serve`` sets explicitly).
    max_members : int
        Most members a zip may hold (default 512: a ``.Simg`` with a few
        hundred planes).
    max_member_bytes : int
        Largest uncompressed member of a zip, bytes (default 32 MiB).
    max_total_bytes : int
        Largest total uncompressed size of a zip, bytes (default 128 MiB).
    max_scene_values : int
        Most radiance values (height x width x planes) of an uploaded scene
        (default 8,000,000, 64 MB as float64: e.g. 512 x 500 pixels x 31 planes).
    worker_memory_bytes : int
        Memory a read in its worker process may add to the worker's own
        (default 1 GiB; :mod:`camsim_core.io.isolated`).
    worker_cpu_seconds : int
        CPU time a read may take (default 20 s).
    worker_wall_seconds : int
        Wall time a read may take before its worker is killed (default 30 s).
    """

    max_upload_bytes: int = 16 * 2**20
    max_members: int = 512
    max_member_bytes: int = 32 * 2**20
    max_total_bytes: int = 128 * 2**20
    max_scene_values: int = 8_000_000
    worker_memory_bytes: int = 2**30
    worker_cpu_seconds: int = 20
    worker_wall_seconds: int = 30

    def __post_init__(self):
        for name in ("max_upload_bytes", "max_members", "max_member_bytes", "max_total_bytes", "max_scene_values",
                     "worker_memory_bytes", "worker_cpu_seconds", "worker_wall_seconds"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                from ..errors import ParameterError

                raise ParameterError(name, f"must be a whole number >= 1, got {v!r}")


DEFAULT_LIMITS = UploadLimits()

_SUFFIXES = (".npz", ".zip", ".mat", ".png", ".jpg", ".jpeg")
#: What an upload may be, for messages and the explorer's file picker.
UPLOAD_KINDS = (".npz, a MATLAB .mat (ICVL, ARAD, Harvard, ISETCam), a photo (.png, .jpg), or a .zip of a .Simg "
                "with its planes, of an ENVI .hdr with its data file, or of a folder of band PNGs")


def _mb(n):
    return f"{n / 2**20:.3g} MiB"


def upload_name(filename):
    """The last component of an upload's name, refusing control characters and names over 255 characters."""
    text = str(filename or "upload")
    if any(ord(c) < 32 or ord(c) == 127 for c in text):
        raise FileFormatError("upload", "the file name holds a NUL or control character; rename the file")
    if len(text) > 255:
        raise FileFormatError("upload", f"the file name is {len(text)} characters long, more than the 255 allowed")
    return PurePosixPath(text.replace("\\", "/")).name or "upload"


def load_upload(filename, content, limits=DEFAULT_LIMITS):
    """A :class:`~camsim_core.scene.Scene` from an uploaded file's name and bytes.

    ``filename`` is only used for its last component (for messages and the
    type); ``content`` is the file's bytes. Raises
    :class:`~camsim_core.errors.FileFormatError` naming the user's file when
    the upload is not a scene or exceeds ``limits``.

    Negative radiances (the noise a dark subtraction or a scatter correction
    leaves around zero) are set to 0, and the scene's ``notices`` say how many
    and the lowest: an upload has no ``negative=`` to choose, as
    :func:`~camsim_core.load_scene` has. NaN and infinities are refused.

    Examples
    --------
    >>> import io, numpy as np
    >>> cube = np.full((4, 4, 31), 0.1); cube[0, 0, :3] = -0.002
    >>> buf = io.BytesIO(); np.savez(buf, data=cube, wavelengths=np.arange(400, 701, 10.0))
    >>> scene = load_upload("dark-subtracted.npz", buf.getvalue())
    >>> float(scene.data.min()), [n for n in scene.notices if "negative" in n]
    (0.0, ['3 negative radiance values clipped to 0 (the lowest -0.002)'])
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RadianceClipped)
        scene = _read_upload(filename, content, limits)
    for w in caught:
        if not issubclass(w.category, RadianceClipped):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)  # as if not caught
    notes = [w.message.note for w in caught if issubclass(w.category, RadianceClipped)]
    if notes:
        scene = dataclasses.replace(scene, notices=tuple(scene.notices) + tuple(notes))
    return scene


def _read_upload(filename, content, limits):
    name = upload_name(filename)
    suffix = PurePosixPath(name).suffix.lower()
    if suffix not in _SUFFIXES:
        raise FileFormatError(name, f"upload a scene as {UPLOAD_KINDS}")
    size = len(content)
    if size > limits.max_upload_bytes:
        raise FileFormatError(name, f"is {_mb(size)}, more than the {_mb(limits.max_upload_bytes)} an upload may be")
    if suffix == ".mat":  # read from memory: nothing written, no path for names inside the file to resolve against
        from ..scene.matlab import read_mat

        with reader_errors(name, "a MATLAB file"):
            return read_mat(name, content=content, shown=name, max_values=limits.max_scene_values,
                            negative=UPLOAD_NEGATIVE)
    tmp = Path(tempfile.mkdtemp(prefix="camsim-upload-"))
    try:
        with reader_errors(name):
            if suffix == ".npz":
                return _load_npz(tmp, name, content, limits)
            if suffix != ".zip":
                return _load_single(tmp, name, suffix, content, limits)
            return _load_zip(tmp, name, content, limits)
    except CamsimError as exc:
        raise _scrubbed(exc, tmp, name) from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _scrubbed(exc, tmp, name):
    """The error with the temporary folder's path removed (the user sees their own names only)."""
    text = str(exc)
    for folder in {str(tmp), str(tmp.resolve())}:
        text = text.replace(folder + "/", "").replace(folder, "")
    if not text.startswith(name):
        text = f"{name}: {text}"
    head, _, rest = text.partition(": ")
    return FileFormatError(head, rest)


def _load_npz(tmp, name, content, limits):
    from ..scene.load import read_npz_scene

    path = tmp / "scene.npz"
    path.write_bytes(content)
    _check_directory(path, name, limits)
    return read_npz_scene(path, name=PurePosixPath(name).stem, shown=name, max_values=limits.max_scene_values,
                          negative=UPLOAD_NEGATIVE)


def _load_single(tmp, name, suffix, content, limits):
    """A photo: written under the user's file name, read with the scene-size limit."""
    path = tmp / name
    path.write_bytes(content)
    from ..scene.photo import read_photo

    return read_photo(path, max_values=limits.max_scene_values, shown=name)


def _declared_members(data):
    """Member count from the zip's end-of-central-directory record (22 bytes at the end), or None.

    Read by hand so that a zip of millions of members is refused before its
    directory is parsed; a zip64 count (0xFFFF) is left to :mod:`zipfile`.
    """
    import struct

    tail = data[-(22 + 65535):]
    pos = tail.rfind(b"PK\x05\x06")
    if pos < 0 or pos + 22 > len(tail):
        return None
    total = struct.unpack_from("<H", tail, pos + 10)[0]
    return None if total == 0xFFFF else total


def _check_directory(path_or_file, name, limits):
    """The zip's members (from its central directory), refused when over ``limits``."""
    data = path_or_file.getvalue() if hasattr(path_or_file, "getvalue") else Path(path_or_file).read_bytes()
    declared = _declared_members(data)
    if declared is not None and declared > limits.max_members:
        raise FileFormatError(name, f"holds {declared} members, more than the {limits.max_members} allowed")
    try:
        with zipfile.ZipFile(path_or_file) as z:
            infos = z.infolist()
    except (zipfile.BadZipFile, EOFError, ValueError):
        raise FileFormatError(name, "not a readable zip file") from None
    if len(infos) > limits.max_members:
        raise FileFormatError(name, f"holds {len(infos)} members, more than the {limits.max_members} allowed")
    total = 0
    for info in infos:
        if info.file_size > limits.max_member_bytes:
            raise FileFormatError(name, f"member {info.filename!r} is {_mb(info.file_size)} uncompressed, "
                                        f"more than the {_mb(limits.max_member_bytes)} allowed")
        total += info.file_size
    if total > limits.max_total_bytes:
        raise FileFormatError(name, f"holds {_mb(total)} uncompressed, more than the {_mb(limits.max_total_bytes)} allowed")
    return infos


def _safe_member_name(name, member):
    """The member's relative path, or an error for absolute names, '..', or odd characters."""
    text = member.replace("\\", "/")
    p = PurePosixPath(text)
    if p.is_absolute() or ".." in p.parts or ":" in text or "\x00" in text:
        raise FileFormatError(name, f"unsafe path in zip: {member!r} (members must be relative, without '..')")
    return p


def _extract(z, info, target, name, limits, budget):
    """Copy one member to ``target``, counting the bytes actually decompressed."""
    written = 0
    with z.open(info) as src, open(target, "wb") as dst:
        while True:
            chunk = src.read(1 << 20)
            if not chunk:
                break
            written += len(chunk)
            if written > limits.max_member_bytes:
                raise FileFormatError(name, f"member {info.filename!r} decompresses to more than "
                                            f"{_mb(limits.max_member_bytes)}")
            if written > budget:
                raise FileFormatError(name, f"decompresses to more than {_mb(limits.max_total_bytes)} in all")
            dst.write(chunk)
    return written


def _load_zip(tmp, name, content, limits):
    import io

    from ..scene.load import read_simg, simg_shape

    buf = io.BytesIO(content)
    infos = _check_directory(buf, name, limits)
    members = [(info, _safe_member_name(name, info.filename)) for info in infos]
    headers = sorted(p for info, p in members if not info.is_dir() and p.suffix.lower() == ".simg")
    if not headers:
        return _load_other_zip(tmp, name, buf, members, limits)
    root = tmp / "upload"
    root.mkdir()
    budget = limits.max_total_bytes
    try:
        with zipfile.ZipFile(buf) as z:
            # the header first: its declared scene size is checked before any plane is written
            header_info = next(info for info, p in members if p == headers[0])
            header = root / headers[0]
            header.parent.mkdir(parents=True, exist_ok=True)
            budget -= _extract(z, header_info, header, name, limits, budget)
            shown = f"{name}:{headers[0]}"
            h, w, n = simg_shape(header, shown=shown)
            if h * w * n > limits.max_scene_values:
                raise FileFormatError(shown, f"declares {h} x {w} pixels x {n} planes = {h * w * n} values, "
                                             f"more than the {limits.max_scene_values} allowed")
            for info, p in members:
                if info.is_dir() or p == headers[0]:
                    continue
                target = root / p
                target.parent.mkdir(parents=True, exist_ok=True)
                budget -= _extract(z, info, target, name, limits, budget)
    except (zipfile.BadZipFile, EOFError, NotImplementedError, RuntimeError) as exc:
        raise FileFormatError(name, f"not a readable zip file ({exc})") from None
    scene = read_simg(header, shown=shown, max_values=limits.max_scene_values, negative=UPLOAD_NEGATIVE)
    return scene


def _load_other_zip(tmp, name, buf, members, limits):
    """A zip of an ENVI ``.hdr`` with its data file, or of a folder of band PNGs (CAVE's layout).

    Extracted with the same bounds as a ``.Simg`` upload; the reader checks
    the scene's size from the header (ENVI) or the PNG headers before
    allocating.
    """
    files = [p for info, p in members if not info.is_dir()]
    hdrs = sorted(p for p in files if p.suffix.lower() == ".hdr")
    pngs = sorted(p for p in files if p.suffix.lower() == ".png")
    if not hdrs and not pngs:
        raise FileFormatError(name, "the zip holds no .Simg header, no ENVI .hdr and no band PNGs")
    root = tmp / "upload"
    root.mkdir()
    budget = limits.max_total_bytes
    try:
        with zipfile.ZipFile(buf) as z:
            for info, p in members:
                if info.is_dir():
                    continue
                target = root / p
                target.parent.mkdir(parents=True, exist_ok=True)
                budget -= _extract(z, info, target, name, limits, budget)
    except (zipfile.BadZipFile, EOFError, NotImplementedError, RuntimeError) as exc:
        raise FileFormatError(name, f"not a readable zip file ({exc})") from None
    if hdrs:
        from ..scene.envi import read_envi

        return read_envi(root / hdrs[0], max_values=limits.max_scene_values, shown=f"{name}:{hdrs[0]}",
                         negative=UPLOAD_NEGATIVE)
    from ..scene.cave import read_band_folder

    return read_band_folder(root / pngs[0].parent, max_values=limits.max_scene_values, shown=f"{name}:{pngs[0].parent}")
