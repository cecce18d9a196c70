"""Photos as they are displayed: EXIF orientation applied, and 16-bit colour read with its 65536 levels.

EXIF 2.3 (CIPA DC-008), tag 274 Orientation: 6 = "the 0th row is the visual right-hand side, the 0th column the
visual top" (the stored image turns 90 degrees clockwise for display: a phone held upright, its sensor sideways);
8 = the 0th row is the visual left-hand side (90 degrees anticlockwise). The expected upright arrays below follow
that definition with numpy (np.rot90), not Pillow.
"""

import struct
import zlib

import numpy as np
import pytest
import tifffile
from PIL import Image

from camsim_core.errors import FileFormatError
from camsim_core.scene import scene_from_rgb
from camsim_core.scene.photo import read_photo

WLS = np.array([450.0, 550.0, 650.0])
#: EXIF orientation -> the numpy turn of the stored array that shows it upright.
UPRIGHT = {1: lambda a: a, 3: lambda a: np.rot90(a, 2), 6: lambda a: np.rot90(a, -1), 8: lambda a: np.rot90(a, 1)}


def _exif(orientation):
    exif = Image.Exif()
    exif[0x0112] = orientation
    return exif.tobytes()


@pytest.fixture
def sideways():
    """A landscape-stored 8-bit photo (30 rows x 40 columns) with a red block in its stored top-left corner."""
    a = np.full((30, 40, 3), 60, np.uint8)
    a[:10, :12] = (220, 30, 30)
    a[-6:, -6:] = (30, 30, 220)
    return a


def _png(chunks):
    out = b"\x89PNG\r\n\x1a\n"
    for kind, body in chunks:
        out += struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    return out


def _png16_rgb(a, exif=None):
    """A 16-bit RGB PNG of ``a`` (H, W, 3) uint16, written by hand (PNG 1.2: IHDR depth 16, colour type 2, filter 0)."""
    h, w, _ = a.shape
    rows = b"".join(b"\0" + a[i].astype(">u2").tobytes() for i in range(h))
    chunks = [(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 2, 0, 0, 0))]
    if exif is not None:  # eXIf holds the TIFF structure without JPEG's "Exif\0\0" prefix
        chunks.append((b"eXIf", exif.removeprefix(b"Exif\x00\x00")))
    return _png(chunks + [(b"IDAT", zlib.compress(rows)), (b"IEND", b"")])


@pytest.mark.parametrize("orientation", [6, 8, 3, 1])
def test_png_with_exif_orientation_is_upright(tmp_path, sideways, orientation):
    Image.fromarray(sideways).save(tmp_path / "phone.png", exif=_exif(orientation))
    scene = read_photo(tmp_path / "phone.png", wavelengths=WLS)
    upright = UPRIGHT[orientation](sideways)
    np.testing.assert_allclose(scene.data, scene_from_rgb(upright / 255.0, wavelengths=WLS).data, rtol=1e-12)


@pytest.mark.parametrize("orientation", [6, 8])
def test_portrait_phone_jpeg_is_upright(tmp_path, sideways, orientation):
    Image.fromarray(sideways).save(tmp_path / "phone.jpg", exif=_exif(orientation), quality=95)
    scene = read_photo(tmp_path / "phone.jpg", wavelengths=WLS)
    assert scene.shape == (40, 30, 3)  # portrait, as the phone showed it
    red = scene.data[..., 2] / scene.data[..., 0]  # 650 nm over 450 nm: high in the red block only
    block = UPRIGHT[orientation](np.pad(np.ones((10, 12)), ((0, 20), (0, 28)))) > 0
    assert red[block].min() > 3 * red[~block].max() / 2 and red[block].mean() > 5 * np.median(red[~block])


def test_photo_without_orientation_keeps_its_layout(tmp_path, sideways):
    Image.fromarray(sideways).save(tmp_path / "plain.jpg", quality=95)
    assert read_photo(tmp_path / "plain.jpg", wavelengths=WLS).shape == (30, 40, 3)


def _ramp16():
    """Every 16-bit level once: R the ramp 0..65535 over 256 x 256 pixels, G its reverse, B 0."""
    r = np.arange(65536, dtype=np.uint16).reshape(256, 256)
    return np.stack([r, r[::-1, ::-1], np.zeros_like(r)], axis=2)


@pytest.mark.parametrize("kind", ["png", "tif", "tif-deflate"])
def test_sixteen_bit_rgb_ramp_keeps_all_its_levels(tmp_path, kind):
    ramp = _ramp16()
    path = tmp_path / f"ramp.{kind[:3]}"
    if kind == "png":
        path.write_bytes(_png16_rgb(ramp))
    else:
        tifffile.imwrite(path, ramp, photometric="rgb", compression="zlib" if kind == "tif-deflate" else None)
    scene = read_photo(path, wavelengths=WLS)
    np.testing.assert_allclose(scene.data, scene_from_rgb(ramp / 65535.0, wavelengths=WLS).data, rtol=1e-12)
    # 650 nm follows R (and G): 65536 R levels give 65536 radiances (8-bit reading gave 256)
    assert np.unique(scene.data[..., 2]).size == 65536


def test_sixteen_bit_rgb_png_with_orientation_is_upright(tmp_path):
    a = _ramp16()[:40:, :30] * np.uint16(1)
    (tmp_path / "turned.png").write_bytes(_png16_rgb(a, _exif(6)))
    scene = read_photo(tmp_path / "turned.png", wavelengths=WLS)
    np.testing.assert_allclose(scene.data, scene_from_rgb(np.rot90(a, -1) / 65535.0, wavelengths=WLS).data, rtol=1e-12)


def test_broken_sixteen_bit_png_is_refused_naming_the_file(tmp_path):
    data = _png16_rgb(_ramp16()[:16, :16])
    at = data.index(b"IDAT") + 20
    (tmp_path / "cut.png").write_bytes(data[:at] + bytes(64) + data[at + 64:])  # pixels overwritten, CRC now wrong
    with pytest.raises(FileFormatError, match=r"^holiday\.png: "):
        read_photo(tmp_path / "cut.png", shown="holiday.png")
