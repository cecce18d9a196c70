"""The explorer's upload takes the new formats, under the same limits as the others."""

import io
import zipfile

import numpy as np
import pytest
from PIL import Image
from scipy.io import savemat
from spectral.io import envi

from camsim_core.errors import FileFormatError
from camsim_core.io.upload import UploadLimits, load_upload

WLS = [450.0, 500.0, 550.0, 600.0]


def _bytes(writer):
    buf = io.BytesIO()
    writer(buf)
    return buf.getvalue()


def _zip(files):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in files.items():
            z.writestr(name, data)
    return buf.getvalue()


def test_mat_and_photo_uploads(rng):
    cube = rng.uniform(0, 1, (5, 6, 4))
    scene = load_upload("arad.mat", _bytes(lambda f: savemat(f, {"cube": cube, "bands": np.array(WLS)})))
    np.testing.assert_array_equal(scene.data, cube)
    rgb = rng.integers(0, 256, (8, 9, 3), dtype=np.uint8)
    scene = load_upload("holiday.jpg", _bytes(lambda f: Image.fromarray(rgb).save(f, format="JPEG")))
    assert scene.shape == (8, 9, 31) and scene.name == "holiday"


def test_zipped_envi_and_band_folder_uploads(tmp_path, rng):
    cube = rng.uniform(0, 1, (5, 6, 4))
    envi.save_image(str(tmp_path / "cap.hdr"), cube, ext=".img", metadata={"wavelength": WLS})
    up = _zip({"cap/cap.hdr": (tmp_path / "cap.hdr").read_bytes(), "cap/cap.img": (tmp_path / "cap.img").read_bytes()})
    np.testing.assert_allclose(load_upload("cap.zip", up).data, cube)
    bands = {f"toy_ms/toy_ms_{k:02d}.png": _bytes(lambda f: Image.fromarray(
        np.full((4, 5), 1000 * k, np.uint16)).save(f, format="PNG")) for k in range(1, 32)}
    scene = load_upload("toy.zip", _zip(bands))
    assert scene.shape == (4, 5, 31) and scene.data[0, 0, 30] == pytest.approx(31000 / 65535)


def test_new_upload_formats_obey_the_scene_size_limit(rng):
    small = UploadLimits(max_scene_values=50)
    cube = rng.uniform(0, 1, (5, 6, 4))
    with pytest.raises(FileFormatError, match="arad.mat.*more than the 50 allowed"):
        load_upload("arad.mat", _bytes(lambda f: savemat(f, {"cube": cube, "bands": np.array(WLS)})), small)
    png = _bytes(lambda f: Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(f, format="PNG"))
    with pytest.raises(FileFormatError, match="photo.png.*more than the 50 values allowed"):
        load_upload("photo.png", png, small)
    with pytest.raises(FileFormatError, match="notes.zip.*no .Simg header, no ENVI .hdr and no band PNGs"):
        load_upload("notes.zip", _zip({"a.txt": b"hello"}))
