"""Writing simulated output: raw 16-bit TIFF or PNG with a JSON sidecar, ``.npy`` for floats.

Every writer goes through :func:`atomic_write`: the data are written to a
temporary file in the target folder and renamed into place, so a failure
never leaves a partial output file.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__ = ["atomic_write", "write_image", "RAW_SUFFIXES"]

RAW_SUFFIXES = (".tif", ".tiff", ".png", ".npy")


def atomic_write(path, writer, *, binary=True):
    """Call ``writer(fileobj)`` on a temporary file, then rename it to ``path``."""
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ParameterError("out", f"folder {folder} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=folder)
    try:
        with os.fdopen(fd, "wb" if binary else "w") as f:
            writer(f)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file ordinary permissions
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return path


def _integer_data(image, path):
    data = np.asarray(image.data)
    if image.quantized and image.bits is not None:
        if image.bits > 16:
            raise ParameterError("out", f"{path.name}: {image.bits}-bit data do not fit a 16-bit file; write .npy")
        dtype = np.uint8 if image.bits <= 8 else np.uint16
        return data.astype(dtype)
    raise ParameterError(
        "out", f"{path.name}: the image is not quantized (bits=None); write floating-point data to a .npy file"
    )


def write_image(image, path):
    """Write a camera image: ``.tif``/``.png`` (8/16-bit integers) or ``.npy``, plus ``PATH.json`` metadata.

    An 8-bit image is written as 8-bit, up to 16 bits as 16-bit. Both files
    appear together or not at all.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in RAW_SUFFIXES:
        raise ParameterError("out", f"{path.name}: unknown output type; expected one of {', '.join(RAW_SUFFIXES)}")
    if suffix == ".npy":
        data = np.asarray(image.data)

        def write(f):
            np.save(f, data, allow_pickle=False)

    else:
        data = _integer_data(image, path)
        if suffix == ".png" and data.ndim == 3 and data.shape[2] not in (1, 3, 4):
            raise ParameterError("out", f"{path.name}: PNG holds 1, 3 or 4 planes, the image has {data.shape[2]}; use .tif or .npy")
        if suffix == ".png":
            from PIL import Image

            def write(f):
                arr = data[..., 0] if data.ndim == 3 and data.shape[2] == 1 else data
                if arr.dtype == np.uint16 and arr.ndim == 2:
                    Image.fromarray(arr.astype(np.uint16)).save(f, format="PNG")
                elif arr.dtype == np.uint16:
                    raise ParameterError("out", f"{path.name}: 16-bit colour PNG is not supported; use .tif")
                else:
                    Image.fromarray(arr).save(f, format="PNG")

        else:
            import tifffile

            def write(f):
                buf = io.BytesIO()
                tifffile.imwrite(buf, data, photometric="minisblack" if data.ndim == 2 else None)
                f.write(buf.getvalue())

    meta = image.metadata()
    meta["file"] = path.name
    sidecar = path.with_name(path.name + ".json")
    text = json.dumps(meta, indent=1)
    atomic_write(path, write)
    try:
        atomic_write(sidecar, lambda f: f.write(text.encode()))
    except BaseException:
        path.unlink(missing_ok=True)
        raise
    return path
