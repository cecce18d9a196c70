"""Scene readers of the field's formats: each a round trip through a small file written here, and bad files."""

import json
import warnings

import h5py
import numpy as np
import pytest
import scipy.constants as sc
from PIL import Image
from scipy.io import savemat
from spectral.io import envi

import camsim_core as cs
from camsim_core.errors import FileFormatError
from camsim_core.scene import SceneNotice
from camsim_core.scene import matlab as matlab_reader

WLS = np.array([450.0, 500.0, 550.0, 600.0])


@pytest.fixture
def cube(rng):
    return rng.uniform(0.1, 2.0, size=(6, 5, WLS.size))


def _load_quiet(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SceneNotice)
        return cs.load_scene(path, **kw)


# -- ENVI ---------------------------------------------------------------------------------------

def test_envi_round_trip_converts_per_nm_and_reads_geometry(tmp_path, cube):
    hdr = tmp_path / "capture.hdr"
    envi.save_image(str(hdr), cube.astype(np.float32), interleave="bil", ext=".raw", metadata={
        "wavelength": [f"{w / 1000:g}" for w in WLS], "wavelength units": "Micrometers",
        "data units": "W/(m^2 sr nm)", "distance": "2.5", "angular resolution": ["80", "90"]})
    scene = cs.load_scene(hdr)
    np.testing.assert_allclose(scene.wavelengths, WLS)
    # per nm x 50 nm bands = per band
    np.testing.assert_allclose(scene.data, cube.astype(np.float32) * 50.0, rtol=1e-6)
    assert scene.distance == 2.5 and scene.angular_resolution == (80.0, 90.0)
    assert scene.notices == ()


def test_envi_without_geometry_or_units_warns_and_records_defaults(tmp_path, cube):
    hdr = tmp_path / "bare.hdr"
    envi.save_image(str(hdr), cube, ext=".img", metadata={"wavelength": list(WLS)})
    with pytest.warns(SceneNotice) as record:
        scene = cs.load_scene(hdr)
    np.testing.assert_allclose(scene.data, cube)
    assert scene.distance == 1.0 and scene.angular_resolution == (57.3, 57.3)
    assert len(scene.notices) == 3 and len(record) == 3
    assert any("distance" in n for n in scene.notices) and any("units" in n for n in scene.notices)


def test_envi_writer_round_trip_is_exact(tmp_path):
    from camsim_core.scene.envi import write_envi

    src = cs.load_scene("bfgb128")
    write_envi(src, tmp_path / "bfgb.hdr")
    back = cs.load_scene(tmp_path / "bfgb.hdr")
    np.testing.assert_array_equal(back.data, src.data)
    assert back.distance == src.distance and back.angular_resolution == src.angular_resolution


def test_envi_bad_files(tmp_path, cube):
    bad = tmp_path / "notes.hdr"
    bad.write_text("this is not an ENVI header\n")
    with pytest.raises(FileFormatError, match="notes.hdr.*ENVI"):
        cs.load_scene(bad)
    hdr = tmp_path / "short.hdr"
    envi.save_image(str(hdr), cube, ext=".img", metadata={"wavelength": list(WLS)})
    data = tmp_path / "short.img"
    data.write_bytes(data.read_bytes()[:-100])
    with pytest.raises(FileFormatError, match="truncated"):
        cs.load_scene(hdr)
    huge = tmp_path / "huge.hdr"
    huge.write_text("ENVI\nsamples = 100000\nlines = 100000\nbands = 300\nheader offset = 0\nfile type = ENVI Standard\n"
                    "data type = 4\ninterleave = bsq\nbyte order = 0\n")
    (tmp_path / "huge.img").write_bytes(b"\0" * 16)
    with pytest.raises(FileFormatError, match="more than"):
        cs.load_scene(huge)
    nowl = tmp_path / "nowl.hdr"
    envi.save_image(str(nowl), cube, ext=".img")
    with pytest.raises(FileFormatError, match="wavelength"):
        cs.load_scene(nowl)


# -- MATLAB v5 and v7.3 ---------------------------------------------------------------------------

@pytest.mark.parametrize("var", ["rad", "cube"])
def test_mat_v5_icvl_and_arad_round_trip(tmp_path, cube, var):
    path = tmp_path / f"{var}.mat"
    savemat(path, {var: cube, "bands": WLS[None, :]}, do_compression=True)
    scene = _load_quiet(path)
    np.testing.assert_array_equal(scene.data, cube)
    np.testing.assert_array_equal(scene.wavelengths, WLS)
    assert any("no absolute unit" in n for n in scene.notices)


def test_mat_v5_harvard_and_arad_without_bands_get_their_wavelengths(tmp_path, rng):
    ref = rng.uniform(0, 1, size=(4, 3, 31))
    savemat(tmp_path / "img1.mat", {"ref": ref, "lbl": np.ones((4, 3))})
    scene = _load_quiet(tmp_path / "img1.mat")
    np.testing.assert_array_equal(scene.data, ref)
    np.testing.assert_array_equal(scene.wavelengths, 420 + 10 * np.arange(31))
    savemat(tmp_path / "arad.mat", {"cube": ref})
    scene = _load_quiet(tmp_path / "arad.mat")
    np.testing.assert_array_equal(scene.wavelengths, 400 + 10 * np.arange(31))
    assert any("400-700 nm" in n for n in scene.notices)


def _matlab73(path):
    """An HDF5 file with MATLAB 7.3's 512-byte header, as MATLAB writes them."""
    f = h5py.File(path, "w", userblock_size=512)
    f.close()
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sun Nov 22 2026 HDF5 schema 1.00 .".ljust(116))
    return h5py.File(path, "a")


def test_mat_v73_arad_column_major_round_trip(tmp_path, cube):
    path = tmp_path / "ARAD_1K_0001.mat"
    with _matlab73(path) as f:
        f["cube"] = cube.T.astype(np.float32)  # MATLAB's H x W x N is stored N x W x H
        f["bands"] = WLS[:, None]
    scene = _load_quiet(path)
    np.testing.assert_array_equal(scene.data, cube.astype(np.float32))
    np.testing.assert_array_equal(scene.wavelengths, WLS)


def test_mat_v73_written_from_python_keeps_its_order(tmp_path, cube):
    path = tmp_path / "icvl.mat"
    with h5py.File(path, "w") as f:
        f["rad"] = cube
        f["bands"] = WLS
    np.testing.assert_array_equal(_load_quiet(path).data, cube)


def _photons_to_watts_per_band(photons, wls, band):
    return photons * (sc.h * sc.c / (wls * 1e-9)) * band


def test_mat_isetcam_scene_struct_photons_to_radiance(tmp_path, rng):
    wls = np.arange(400.0, 701.0, 10.0)
    photons = rng.uniform(1e15, 1e16, size=(5, 8, wls.size))
    ill = np.full(wls.size, 2e16)
    scene_struct = {"name": "bars", "data": {"photons": photons}, "spectrum": {"wave": wls}, "wAngular": 4.0,
                    "distance": 3.0, "illuminant": {"data": {"photons": ill}, "spectrum": {"wave": wls}}}
    savemat(tmp_path / "iset.mat", {"scene": scene_struct})
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneNotice)  # nothing missing: no notice
        scene = cs.load_scene(tmp_path / "iset.mat")
    np.testing.assert_allclose(scene.data, _photons_to_watts_per_band(photons, wls, 10.0), rtol=1e-12)
    assert scene.distance == 3.0
    assert scene.angular_resolution == (2.0, 2.0)  # 8 px over 4 degrees
    np.testing.assert_allclose(scene.illuminant.values, _photons_to_watts_per_band(ill, wls, 10.0))


def test_mat_isetcam_multispectral_basis_file(tmp_path, rng):
    wls = np.arange(400.0, 701.0, 5.0)
    basis = np.stack([np.ones(wls.size), np.linspace(-1, 1, wls.size)], axis=1)  # N x 2
    coef = np.stack([rng.uniform(2e15, 3e15, (4, 6)), rng.uniform(-1e14, 1e14, (4, 6))], axis=2)
    mean = np.full(wls.size, 1e14)
    savemat(tmp_path / "ms.mat", {"mcCOEF": coef, "basis": {"basis": basis, "wave": wls}, "imgMean": mean,
                                  "illuminant": {"wave": wls, "data": np.ones(wls.size)}, "fov": 3.0, "dist": 1.5})
    scene = cs.load_scene(tmp_path / "ms.mat")
    photons = np.einsum("hwk,nk->hwn", coef, basis) + mean
    np.testing.assert_allclose(scene.data, _photons_to_watts_per_band(photons, wls, 5.0), rtol=1e-12)
    assert scene.angular_resolution == (2.0, 2.0) and scene.distance == 1.5


def test_mat_bad_files(tmp_path, cube, monkeypatch):
    junk = tmp_path / "junk.mat"
    junk.write_bytes(b"not a mat file at all" * 10)
    with pytest.raises(FileFormatError, match="junk.mat"):
        cs.load_scene(junk)
    savemat(tmp_path / "other.mat", {"x": np.ones(3)})
    with pytest.raises(FileFormatError, match="no hyperspectral variable.*x"):
        cs.load_scene(tmp_path / "other.mat")
    savemat(tmp_path / "badbands.mat", {"cube": cube, "bands": np.arange(7.0)})
    with pytest.raises(FileFormatError, match="7 wavelengths for 4 bands"):
        cs.load_scene(tmp_path / "badbands.mat")
    # a compressed variable that would expand past the limit is refused before loading
    savemat(tmp_path / "zeros.mat", {"rad": np.zeros((64, 64, 31)), "bands": np.arange(31.0)}, do_compression=True)
    monkeypatch.setattr(matlab_reader, "MAX_V5_BYTES", 100_000)
    with pytest.raises(FileFormatError, match="expand to more than"):
        cs.load_scene(tmp_path / "zeros.mat")


def test_mat_v73_huge_dataset_refused_before_reading(tmp_path):
    path = tmp_path / "huge.mat"
    with _matlab73(path) as f:
        f.create_dataset("cube", shape=(31, 100_000, 100_000), dtype="f4", chunks=(1, 64, 64))  # nothing written
        f["bands"] = np.arange(31.0)[:, None]
    with pytest.raises(FileFormatError, match="more than"):
        cs.load_scene(path)


# -- CAVE band PNG folder ----------------------------------------------------------------------------

def test_cave_folder_round_trip_by_naming(tmp_path, rng):
    bands = rng.integers(0, 65536, size=(31, 7, 9), dtype=np.uint16)
    inner = tmp_path / "balloons_ms" / "balloons_ms"
    inner.mkdir(parents=True)
    for k, b in enumerate(bands):
        Image.fromarray(b).save(inner / f"balloons_ms_{k + 1:02d}.png")
    scene = _load_quiet(tmp_path / "balloons_ms")
    np.testing.assert_array_equal(scene.wavelengths, 400 + 10 * np.arange(31))
    np.testing.assert_allclose(scene.data, np.moveaxis(bands, 0, 2) / 65535.0)
    assert scene.name == "balloons" and any("scale" in n for n in scene.notices)


def test_band_folder_with_json_and_writer_round_trip(tmp_path):
    from camsim_core.scene.cave import write_band_folder

    src = cs.load_scene("bfgb128")
    write_band_folder(src, tmp_path / "bfgb")
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneNotice)
        back = cs.load_scene(tmp_path / "bfgb")
    np.testing.assert_allclose(back.data, src.data, atol=src.data.max() / 65535 * 0.51)
    assert back.distance == src.distance and back.angular_resolution == src.angular_resolution


def test_band_folder_bad_files(tmp_path, rng):
    folder = tmp_path / "bad"
    folder.mkdir()
    (folder / "x_01.png").write_bytes(b"not a png")
    with pytest.raises(FileFormatError, match="x_01.png.*PNG"):
        cs.load_scene(folder)
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    Image.fromarray(np.zeros((4, 4), np.uint16)).save(mixed / "m_01.png")
    Image.fromarray(np.zeros((5, 4), np.uint16)).save(mixed / "m_02.png")
    with pytest.raises(FileFormatError, match="m_02.png.*the others"):
        cs.load_scene(mixed)
    (mixed / "scene.json").write_text(json.dumps({"wavelengths": [500]}))
    with pytest.raises(FileFormatError, match="1 wavelengths for 2 band PNGs"):
        cs.load_scene(mixed)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(FileFormatError, match="no band PNGs"):
        cs.load_scene(empty)


def test_readers_refuse_special_files(tmp_path):
    import os

    for name in ("pipe.hdr", "pipe.mat", "pipe.png"):
        fifo = tmp_path / name
        os.mkfifo(fifo)
        with pytest.raises(FileFormatError, match="not a regular file"):
            cs.load_scene(fifo)  # never hangs on a FIFO


def test_readers_honour_a_tighter_size_limit(tmp_path, cube):
    from camsim_core.scene.envi import read_envi
    from camsim_core.scene.matlab import read_mat

    envi.save_image(str(tmp_path / "c.hdr"), cube, ext=".img", metadata={"wavelength": list(WLS)})
    savemat(tmp_path / "c.mat", {"cube": cube, "bands": WLS})
    with pytest.raises(FileFormatError, match="more than the 100 allowed"):
        read_envi(tmp_path / "c.hdr", max_values=100)
    with pytest.raises(FileFormatError, match="more than the 100 allowed"):
        read_mat(tmp_path / "c.mat", max_values=100)


def test_band_folder_json_of_any_name_and_envi_micrometers_without_units(tmp_path, cube):
    folder = tmp_path / "bands"
    folder.mkdir()
    many = np.concatenate([cube] * 3, axis=2)  # 12 bands: b2.png must come before b10.png
    wls = np.arange(400.0, 520.0, 10.0)
    for k in range(wls.size):
        Image.fromarray((many[:, :, k] * 10000).astype(np.uint16)).save(folder / f"b{k}.png")
    (folder / "meta.json").write_text(json.dumps({"bands": list(wls)}))
    scene = _load_quiet(folder)
    np.testing.assert_array_equal(scene.wavelengths, wls)
    np.testing.assert_allclose(scene.data, (many * 10000).astype(np.uint16) / 65535.0)
    hdr = tmp_path / "um.hdr"
    envi.save_image(str(hdr), cube, ext=".img", metadata={"wavelength": list(WLS / 1000)})
    scene = _load_quiet(hdr)
    np.testing.assert_allclose(scene.wavelengths, WLS)
    assert any("micrometers" in n for n in scene.notices)


def test_mat_v73_isetcam_scene_struct(tmp_path, rng):
    wls = np.arange(400.0, 701.0, 10.0)
    photons = rng.uniform(1e15, 1e16, size=(5, 8, wls.size))
    path = tmp_path / "iset73.mat"
    with _matlab73(path) as f:
        s = f.create_group("scene")
        s.create_group("data")["photons"] = photons.T  # MATLAB's column-major storage
        s.create_group("spectrum")["wave"] = wls[:, None]
        s["wAngular"] = np.array([[8.0]])
        s["distance"] = np.array([[0.5]])
    scene = cs.load_scene(path)
    np.testing.assert_allclose(scene.data, _photons_to_watts_per_band(photons, wls, 10.0), rtol=1e-12)
    assert scene.angular_resolution == (1.0, 1.0) and scene.distance == 0.5
