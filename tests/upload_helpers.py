"""Building uploads for the security tests: tiny ``.Simg`` zips, zip bombs, npz headers."""

from __future__ import annotations

import io
import zipfile

import numpy as np
from numpy.lib import format as npy


def simg_header(height=1, width=6, planes=1, image_root="", camera_file="hypercam_50mm.Scam", start=400, step=10):
    """A minimal ``.Simg`` header text (one calibration factor of 1 per plane)."""
    factors = "\n".join("1" for _ in range(planes))
    return (
        "#SimImageType\nhyperspectral\n#SimEnd\n"
        f"#SimCameraFile\n{camera_file}\n#SimEnd\n"
        f"#SimHeight\n{height}\n#SimEnd\n#SimWidth\n{width}\n#SimEnd\n"
        f"##SimWavelengthSampling\n##SimStart\n{start}\n##SimStep\n{step}\n##SimNumberSamples\n{planes}\n##SimEnd\n"
        f"#SimImageRoot\n{image_root}\n#SimEnd\n"
        f"#Sim#ImageFactors\n{planes} 1\n{factors}\n"
        "#SimInputCameraDistance\n3.6\n#SimEnd\n"
    )


def plane_bytes(height=1, width=6, value=1000):
    return np.full((height, width), value, dtype=">u2").tobytes()


def zip_bytes(members, compression=zipfile.ZIP_STORED):
    """A zip (bytes) of ``{name: bytes or str}``."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buf.getvalue()


def simg_zip(header, planes=None, extra=None):
    """A zip with ``scene.Simg`` and plane files ``{name: bytes}``."""
    members = {"scene.Simg": header}
    members.update(planes or {})
    members.update(extra or {})
    return zip_bytes(members)


def zip_bomb(member_bytes, members=1):
    """A deflated zip of ``members`` members of ``member_bytes`` zeros each (a few hundred KB per GB)."""
    buf = io.BytesIO()
    chunk = bytes(1 << 20)
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z:
        for m in range(members):
            with z.open(f"planes/{m}", "w", force_zip64=True) as f:
                left = member_bytes
                while left > 0:
                    f.write(chunk[: min(len(chunk), left)])
                    left -= len(chunk)
    return buf.getvalue()


def npz_declaring(shape, dtype="<f8", payload=b"\0" * 64, wavelengths=None):
    """An ``.npz`` whose ``data.npy`` header declares ``shape`` but holds only ``payload``."""
    head = io.BytesIO()
    npy.write_array_header_1_0(head, {"descr": dtype, "fortran_order": False, "shape": tuple(shape)})
    wl = io.BytesIO()
    np.save(wl, np.arange(400.0, 400.0 + 10 * shape[-1], 10.0) if wavelengths is None else wavelengths)
    return zip_bytes({"data.npy": head.getvalue() + payload, "wavelengths.npy": wl.getvalue()}, zipfile.ZIP_DEFLATED)
