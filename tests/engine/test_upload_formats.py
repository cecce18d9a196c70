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


def test_negative_radiance_in_any_upload_format_is_clipped_and_noted(tmp_path, rng):
    """An upload cannot ask for ``negative='clip'`` as ``load_scene`` can: every format's negatives (a dark
    subtraction's noise) become 0, counted in the scene's notices; the values that were not negative are kept."""
    cube = rng.uniform(0.1, 1, (5, 6, 4))
    cube[1, 2, :] = [-0.02, -0.005, 0.3, -0.001]
    envi.save_image(str(tmp_path / "cap.hdr"), cube, ext=".img", metadata={"wavelength": WLS})
    uploads = {"arad.mat": _bytes(lambda f: savemat(f, {"cube": cube, "bands": np.array(WLS)})),
               "cap.zip": _zip({"cap/cap.hdr": (tmp_path / "cap.hdr").read_bytes(),
                                "cap/cap.img": (tmp_path / "cap.img").read_bytes()}),
               "cube.npz": _bytes(lambda f: np.savez(f, data=cube, wavelengths=np.array(WLS)))}
    for name, content in uploads.items():
        scene = load_upload(name, content)
        np.testing.assert_allclose(scene.data, np.maximum(cube, 0), rtol=1e-6, err_msg=name)
        assert "3 negative radiance values clipped to 0 (the lowest -0.02)" in scene.notices, (name, scene.notices)
    nan = cube.copy()
    nan[0, 0, 0] = np.nan
    with pytest.raises(FileFormatError, match="arad.mat.*NaN"):
        load_upload("arad.mat", _bytes(lambda f: savemat(f, {"cube": nan, "bands": np.array(WLS)})))


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
