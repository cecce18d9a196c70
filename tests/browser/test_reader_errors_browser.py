"""Malformed files and links in a real browser: a message in the page, never a traceback in the page or the log.

One upload of each malformed format (an ``.npz`` that is not a zip, the
MATLAB v5 file that crashed scipy, a v7.3 file reading another file, a
truncated PNG, a PNG declaring a decompression bomb, a JPEG of noise, a
zip of a ``.Simg`` with a broken header, of an ENVI header with NaN
wavelengths and of band PNGs one of which is a bomb), then a link with a
malformed chart option.
"""

from __future__ import annotations

import io
import struct
import zipfile
import zlib

import h5py
import numpy as np
import pytest
import scipy.io
from PIL import Image

from app_helpers import Page, server_log

pytestmark = pytest.mark.browser


def _png_declaring(width, height):
    """A small PNG whose header declares ``width`` x ``height`` (a decompression bomb's header)."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b"")


def _zip(members):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buf.getvalue()


def malformed_files(folder):
    """``{file name: bytes}`` of one malformed file per format the upload accepts."""
    out = {"garbage.npz": b"not a zip at all" * 10}
    buf = io.BytesIO()
    scipy.io.savemat(buf, {"rad": np.ones((2, 3, 31)), "bands": np.arange(400.0, 701.0, 10.0)})
    data = bytearray(buf.getvalue())
    flags = [i + 8 for i in range(128, len(data) - 16, 8) if data[i:i + 8] == struct.pack("<II", 6, 8)]
    data[flags[1]] = 196
    out["crash.mat"] = bytes(data)
    h5 = io.BytesIO()
    with h5py.File(h5, "w") as f:
        f["rad"] = h5py.ExternalLink("/etc/passwd", "/x")
    out["link.mat"] = h5.getvalue()
    png = io.BytesIO()
    Image.fromarray(np.zeros((40, 40, 3), np.uint8)).save(png, format="PNG")
    out["truncated.png"] = png.getvalue()[:60]
    out["bomb.png"] = _png_declaring(100_000, 100_000)
    out["noise.jpg"] = bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8))
    out["simg.zip"] = _zip({"scene.Simg": "#SimHeight\nabc\n#SimEnd\n"})
    out["envi.zip"] = _zip({"c.hdr": "ENVI\nsamples = 2\nlines = 2\nbands = 2\ndata type = 4\ninterleave = bsq\n"
                                     "byte order = 0\nwavelength = {nan, 500}\n", "c.img": bytes(32)})
    band = io.BytesIO()
    Image.fromarray(np.zeros((4, 4), np.uint16)).save(band, format="PNG")
    out["bands.zip"] = _zip({"s/s_01.png": band.getvalue(), "s/s_02.png": _png_declaring(60_000, 60_000)})
    for name, data in out.items():
        (folder / name).write_bytes(data)
    return out


def test_malformed_uploads_and_chart_links_give_a_message_and_no_traceback(browser, server, tmp_path):
    """On the worker's shared server (a server of its own cost ~8 CPU-s to start): its log holds no traceback
    from any test, these included."""
    files = malformed_files(tmp_path)
    page = Page(browser, server)
    try:
        upload = page.page.locator(".w-upload input[type=file]").first
        for name in files:
            upload.set_input_files(str(tmp_path / name))
            text = page.wait_for_alert(f"Upload refused: {name}")
            body = page.page.inner_text("body")
            assert "Traceback" not in text and "Traceback" not in body, name
            assert "/tmp/" not in text and "/etc/" not in text, text
        page.shot("malformed-uploads")
    finally:
        page.close()
    link = Page(browser, server + "?scene=slanted-edge:angle=abc")
    try:
        text = link.wait_for_alert("angle: expected a number")
        assert "'abc'" in text and "Traceback" not in link.page.inner_text("body")
        link.shot("malformed-chart-link")
        assert link.errors() == []
    finally:
        link.close()
    log = server_log(server)
    assert "Traceback" not in log, log[-3000:]
