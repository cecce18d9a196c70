"""ISETCam's files as ISETCam's own writers lay them out, each read back with its illuminant.

The expected values come from ISETCam's formulas written out here (ISET/isetcam on GitHub):

* ``ieCompressData`` / ``ieUncompressData``: codes = round((2^b - 1) (x - min) / (max - min)), and back
  x = s / (2^b - 1) codes + min with s = max - min (s = max when min = max); ``illuminantGet(il, 'photons')``
  takes b = 32 for uint32 codes and 16 for uint16;
* ``Quanta2Energy`` / ``Energy2Quanta``: E = photons h c / lambda;
* camsim's unit: W/sr/m^2 per band = per nm x the band width.

Layouts: a scene struct (``vcSaveObject``: ``scene`` with ``data.photons``, ``spectrum.wave``, ``wAngular``,
``distance``, ``illuminant``); a basis file (``sceneToFile(f, scene, 0.99)`` -> ``ieSaveMultiSpectralImage``:
``mcCOEF``, ``basis``, ``imgMean``, ``comment``, ``illuminant``, ``fov``, ``dist``, ``name``) with the three
illuminant layouts ISETCam reads; the uncompressed file (``sceneToFile(f, scene, [])``: ``photons``, ``wave``,
``comment``, ``illuminant``, ``fov``, ``dist``, ``name``, ``spectrum``, ``type``, ``magnification``, ``data``).
Each is written as MATLAB v5 (scipy.io, MATLAB's default ``save``) and v7.3 (HDF5, h5py, MATLAB's layout).
"""

import dataclasses
import warnings

import colour
import h5py
import numpy as np
import pytest
import scipy.constants as sc
from scipy.io import savemat

import camsim_core as cs
from camsim_core.errors import FileFormatError
from camsim_core.scene import SceneNotice
from camsim_core.scene.matlab import read_mat
from camsim_core.spectra import Spectrum

WAVE = np.arange(400.0, 701.0, 10.0)
STEP = 10.0
FORMATS = ("v5", "v7.3")


# -- ISETCam's formulas ----------------------------------------------------------------------------------------

def ie_compress(x, bits):
    """ieCompressData with the data's own min and max: (codes, min, max)."""
    lo, hi = float(np.min(x)), float(np.max(x))
    full = 2.0**bits - 1
    codes = np.round(full * (x - lo) / (hi - lo)) if hi > lo else np.zeros_like(x)
    return codes.astype(np.uint32 if bits == 32 else np.uint16), lo, hi


def ie_uncompress(codes, lo, hi, bits):
    """ieUncompressData."""
    s = hi if lo == hi else hi - lo
    return s / (2.0**bits - 1) * codes.astype(float) + lo


def quanta_to_energy(wave, photons):
    """Quanta2Energy: W/sr/m^2/nm of photons/s/sr/m^2/nm."""
    return np.asarray(photons, float) * sc.h * sc.c / (np.asarray(wave) * 1e-9)


def energy_to_quanta(wave, energy):
    """Energy2Quanta."""
    return np.asarray(energy, float) / (sc.h * sc.c) * (np.asarray(wave) * 1e-9)


def per_band(per_nm):
    return np.asarray(per_nm, float) * STEP


def rel_err(got, want):
    return float(np.max(np.abs(np.asarray(got) - want) / np.abs(want)))


def d65_photons():
    """CIE D65 on WAVE as photons/s/sr/m^2/nm of a white surface at about 100 cd/m^2 (the size of ISETCam's)."""
    e = colour.SDS_ILLUMINANTS["D65"].copy().align(colour.SpectralShape(400, 700, 10)).values / 683.0 / 100.0 * 3.0
    return energy_to_quanta(WAVE, e)


# -- writers: MATLAB v5 (scipy) and v7.3 (HDF5 as MATLAB lays it out) -----------------------------------------------

_CLASSES = {np.dtype(np.float64): "double", np.dtype(np.float32): "single", np.dtype(np.uint16): "uint16",
            np.dtype(np.uint32): "uint32", np.dtype(np.uint8): "uint8"}


def _h5(group, name, value):
    """One MATLAB variable or field in HDF5: structs as groups, text as uint16 codes, arrays column-major."""
    if isinstance(value, dict):
        sub = group.create_group(name)
        sub.attrs["MATLAB_class"] = np.bytes_("struct")
        for k, v in value.items():
            _h5(sub, k, v)
        return
    if isinstance(value, str):
        ds = group.create_dataset(name, data=np.array([ord(c) for c in value], np.uint16).reshape(-1, 1))  # 1 x N
        ds.attrs["MATLAB_class"] = np.bytes_("char")
        return
    a = np.asarray(value)
    if a.ndim == 0:
        a = a.reshape(1, 1)
    elif a.ndim == 1:
        a = a[:, None]  # ISETCam's column vectors (wave(:)), N x 1
    ds = group.create_dataset(name, data=a.T)  # MATLAB's column-major order: dimensions reversed
    ds.attrs["MATLAB_class"] = np.bytes_(_CLASSES[a.dtype])


def write_mat(path, variables, fmt):
    if fmt == "v5":
        savemat(path, variables, oned_as="column", do_compression=True)
        return path
    with h5py.File(path, "w", userblock_size=512) as f:
        for k, v in variables.items():
            _h5(f, k, v)
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Wed Nov 25 2026 HDF5 schema 1.00 .".ljust(116))
    return path


def load(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SceneNotice)
        scene = cs.load_scene(path)
    return scene, [str(w.message) for w in caught if issubclass(w.category, SceneNotice)]


@pytest.fixture
def photons(rng):
    """A scene's photons (5 x 8 x 31): D65 on reflectances 0.05-0.9, mixtures of three smooth spectra."""
    x = (WAVE - 400.0) / 300.0
    smooth = np.stack([x, 1 - x, np.sin(np.pi * x) ** 2])  # each within [0, 1]
    weights = rng.dirichlet(np.ones(3), size=(5, 8))
    return (0.05 + 0.85 * weights @ smooth) * d65_photons()


# -- the scene struct ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("bits", [32, 16])
def test_scene_struct_with_a_compressed_illuminant(tmp_path, photons, fmt, bits):
    """An older ISET scene: 16-bit data with dmin/dmax/bitDepth, the illuminant as uint32 (or uint16) codes."""
    ill = d65_photons()
    codes, lo, hi = ie_compress(ill, bits)
    data_codes, dmin, dmax = ie_compress(photons, 16)
    scene_struct = {"name": "old scene", "type": "scene", "spectrum": {"wave": WAVE}, "wAngular": 8.0, "distance": 2.0,
                    "data": {"photons": data_codes, "dmin": dmin, "dmax": dmax, "bitDepth": 16.0},
                    "illuminant": {"name": "D65", "type": "illuminant", "spectrum": {"wave": WAVE},
                                   "data": {"photons": codes, "min": lo, "max": hi}}}
    scene, notices = load(write_mat(tmp_path / "old.mat", {"scene": scene_struct}, fmt))
    assert notices == []
    want = per_band(quanta_to_energy(WAVE, ie_uncompress(codes, lo, hi, bits)))
    assert rel_err(scene.illuminant.values, want) < 1e-6
    # the codes taken as photons were ~4e6 (uint32) too small with a first band of 0: the decompressed light is D65's
    assert rel_err(scene.illuminant.values, per_band(quanta_to_energy(WAVE, ill))) < (1e-8 if bits == 32 else 1e-4)
    assert scene.illuminant.values.min() > 0
    np.testing.assert_allclose(scene.data, per_band(quanta_to_energy(WAVE, ie_uncompress(data_codes, dmin, dmax, 16))),
                               rtol=1e-12)
    assert scene.angular_resolution == (1.0, 1.0) and scene.distance == 2.0 and scene.name == "old scene"


@pytest.mark.parametrize("fmt", FORMATS)
def test_scene_struct_with_an_uncompressed_illuminant(tmp_path, photons, fmt):
    """A current ISETCam scene: single-precision photons (illuminantSet stores single)."""
    ill = d65_photons().astype(np.float32)
    scene_struct = {"name": "now", "type": "scene", "spectrum": {"wave": WAVE}, "wAngular": 4.0, "distance": 1.5,
                    "data": {"photons": photons.astype(np.float32)},
                    "illuminant": {"name": "D65", "type": "illuminant", "spectrum": {"wave": WAVE},
                                   "data": {"photons": ill}}}
    scene, notices = load(write_mat(tmp_path / "now.mat", {"scene": scene_struct}, fmt))
    assert notices == []
    assert rel_err(scene.illuminant.values, per_band(quanta_to_energy(WAVE, ill))) < 1e-6
    assert scene.angular_resolution == (2.0, 2.0) and scene.distance == 1.5


@pytest.mark.parametrize("fmt", FORMATS)
def test_scene_struct_without_geometry_gets_isetcams_defaults(tmp_path, photons, fmt):
    scene_struct = {"spectrum": {"wave": WAVE}, "data": {"photons": photons},
                    "illuminant": {"data": {"photons": d65_photons()}}}  # the illuminant on the scene's wavelengths
    scene, notices = load(write_mat(tmp_path / "bare.mat", {"scene": scene_struct}, fmt))
    assert scene.angular_resolution == (0.8, 0.8)  # 8 px over ISETCam's 10 degrees, not 57.3 px/deg
    assert scene.distance == 1.2
    assert any("10 degrees" in n and "ISETCam" in n for n in notices)
    assert any("1.2 m" in n and "ISETCam" in n for n in notices)
    assert rel_err(scene.illuminant.values, per_band(quanta_to_energy(WAVE, d65_photons()))) < 1e-6


# -- the basis file ---------------------------------------------------------------------------------------------

def _basis_file(photons):
    """mcCOEF, basis and imgMean as sceneToFile's 'mean svd' builds them (hcBasis: the mean, then the SVD)."""
    xw = photons.reshape(-1, WAVE.size)
    mean = xw.mean(axis=0)
    _, _, vt = np.linalg.svd(xw - mean, full_matrices=False)
    basis = vt[:4].T  # N x 4
    coef = ((xw - mean) @ basis).reshape(photons.shape[0], photons.shape[1], 4)
    return {"mcCOEF": coef, "basis": {"basis": basis, "wave": WAVE}, "imgMean": mean, "comment": "Scene: test"}, \
        np.clip((coef.reshape(-1, 4) @ basis.T + mean).reshape(photons.shape), 0, None)


def _illuminant_layout(layout):
    """(illuminant variable, expected W/sr/m^2 per band) for each layout ISETCam reads."""
    e = quanta_to_energy(WAVE, d65_photons())
    if layout == "sceneToFile":  # sceneGet(scene, 'illuminant'): photons, single
        p = d65_photons().astype(np.float32)
        return {"name": "D65", "type": "illuminant", "spectrum": {"wave": WAVE}, "data": {"photons": p},
                "comment": ""}, per_band(quanta_to_energy(WAVE, p))
    if layout == "illuminantModernize":  # the older layout: data (energy) with wavelength
        return {"wavelength": WAVE, "data": e}, per_band(e)
    return {"wave": WAVE, "data": e}, per_band(e)  # ieSaveMultiSpectralImage's documented .wave / .data (energy)


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("layout", ["sceneToFile", "illuminantModernize", "ieSaveMultiSpectralImage"])
def test_basis_file_with_each_illuminant_layout(tmp_path, photons, fmt, layout):
    variables, spectra = _basis_file(photons)
    illuminant, want = _illuminant_layout(layout)
    variables.update(illuminant=illuminant, fov=16.0, dist=3.0, name="stuffed animals")
    scene, notices = load(write_mat(tmp_path / "basis.mat", variables, fmt))
    assert notices == []
    assert rel_err(scene.illuminant.values, want) < 1e-6
    np.testing.assert_allclose(scene.data, per_band(quanta_to_energy(WAVE, spectra)), rtol=1e-9)
    assert scene.angular_resolution == (0.5, 0.5) and scene.distance == 3.0 and scene.name == "stuffed animals"
    # a white reflector under the illuminant is brighter than every pixel of a scene of reflectances below 0.9:
    # the display scale it sets does not clip the scene (the per-nm illuminant was 10x too dark)
    assert np.all(scene.data < scene.illuminant.values)


@pytest.mark.parametrize("fmt", FORMATS)
def test_basis_file_without_illuminant_or_geometry_says_so(tmp_path, photons, fmt):
    variables, _ = _basis_file(photons)
    scene, notices = load(write_mat(tmp_path / "basis.mat", variables, fmt))
    assert scene.illuminant is None and any("no illuminant" in n for n in notices)
    assert scene.distance == 1.2 and scene.angular_resolution == (0.8, 0.8)
    assert sum("ISETCam's default" in n for n in notices) == 2


# -- the uncompressed file ----------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", FORMATS)
def test_uncompressed_photons_file(tmp_path, photons, fmt):
    p = photons.astype(np.float32)
    ill = d65_photons().astype(np.float32)
    illuminant = {"name": "D65", "type": "illuminant", "spectrum": {"wave": WAVE}, "data": {"photons": ill}}
    variables = {"photons": p, "wave": WAVE, "comment": "Scene: test", "illuminant": illuminant, "fov": 4.0,
                 "dist": 0.8, "name": "bars", "spectrum": {"wave": WAVE}, "type": "scene", "magnification": 1.0,
                 "data": {"photons": p, "luminance": np.ones(p.shape[:2])}}
    scene, notices = load(write_mat(tmp_path / "bars.mat", variables, fmt))
    assert notices == []
    np.testing.assert_allclose(scene.data, per_band(quanta_to_energy(WAVE, p)), rtol=1e-6)
    assert rel_err(scene.illuminant.values, per_band(quanta_to_energy(WAVE, ill))) < 1e-6
    assert scene.angular_resolution == (2.0, 2.0) and scene.distance == 0.8 and scene.name == "bars"


# -- what is not an illuminant is named -------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("illuminant, message", [
    ({"spectrum": {"wave": WAVE}, "data": {"photons": np.arange(31, dtype=np.uint32)}}, "without its minimum and maximum"),
    ({"spectrum": {"wave": WAVE}, "data": {"photons": np.ones(30)}}, "photons has 30 values for 31 wavelengths"),
    ({"wave": WAVE, "data": -np.ones(31)}, "illuminant.data must be non-negative"),
    ({"wave": WAVE[::-1], "data": np.ones(31)}, "increasing order"),
    ({"spectrum": {"wave": WAVE}}, "has no data"),
    ({"data": np.ones(31)}, "has no wavelengths"),
    ("D65", "holds text, expected an ISETCam illuminant struct"),
])
def test_a_bad_illuminant_is_refused_by_name(tmp_path, photons, fmt, illuminant, message):
    variables, _ = _basis_file(photons)
    variables["illuminant"] = illuminant
    if fmt == "v7.3" and isinstance(illuminant, str):
        message = "holds uint16 values"
    with pytest.raises(FileFormatError, match=rf"^bad\.mat: .*{message}"):
        read_mat(write_mat(tmp_path / "bad.mat", variables, fmt), shown="bad.mat")


def test_a_spatial_spectral_illuminant_is_not_kept_and_the_notice_says_so(tmp_path, photons):
    ill = np.broadcast_to(d65_photons(), photons.shape).copy()
    scene_struct = {"spectrum": {"wave": WAVE}, "data": {"photons": photons}, "wAngular": 8.0, "distance": 1.0,
                    "illuminant": {"spectrum": {"wave": WAVE}, "data": {"photons": ill}}}
    scene, notices = load(write_mat(tmp_path / "space.mat", {"scene": scene_struct}, "v5"))
    assert scene.illuminant is None and any("spatial-spectral" in n for n in notices)


def test_mutated_isetcam_layouts_load_or_are_refused_by_name(tmp_path, photons):
    """The new layouts through the fuzz's upload and path readers: every case loads or is refused naming the file."""
    from fuzz_uploads import mutate_leaf, run_case

    rng = np.random.default_rng(39)
    outcomes = []
    for case in range(40):
        kind = case % 4
        if kind == 0:
            codes, lo, hi = ie_compress(d65_photons(), 32)
            v = {"scene": {"spectrum": {"wave": WAVE}, "data": {"photons": photons[:2, :3]}, "wAngular": 1.0,
                           "illuminant": {"spectrum": {"wave": WAVE}, "data": {"photons": codes, "min": lo, "max": hi}}}}
        elif kind == 3:
            v = {"photons": photons[:2, :3], "wave": WAVE, "illuminant": _illuminant_layout("sceneToFile")[0],
                 "fov": 2.0, "dist": 1.0}
        else:
            v, _ = _basis_file(photons[:2, :3])
            v["illuminant"] = _illuminant_layout(["illuminantModernize", "ieSaveMultiSpectralImage"][kind - 1])[0]
        mutate_leaf(rng, v)
        buf = tmp_path / "m.mat"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            savemat(buf, v)
        outcome, signature = run_case("mat5", buf.read_bytes(), tmp_path)
        assert outcome in ("loaded", "error"), (case, signature)
        outcomes.append(outcome)
    assert "loaded" in outcomes and "error" in outcomes


# -- rendering: a compressed illuminant sets the display scale -----------------------------------------------------

def _xyz_camera(scene):
    h, w = scene.shape[:2]
    return cs.load_camera("cie1931").replace(mosaic=None, noise_sigma=0.0, bits=None, height=h, width=w,
                                             angular_resolution=scene.angular_resolution, distance=None)


def _rendered_lab(scene, monitor):
    """Lab of the baseline rendering of ``scene`` through the CIE 1931 camera, seen on ``monitor``, and its frame buffer.

    The monitor's light (its primaries at the frame buffer's linear intensities) to XYZ by colour-science's
    CIE 1931 functions; the white is the rendering of the scene's top row, a perfect white reflector.
    """
    fb = cs.render(cs.simulate(scene, _xyz_camera(scene)), monitor, method="baseline").data
    linear = monitor.frame_buffer_to_linear(fb)
    cmf = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(400, 700, 10)).values
    xyz = linear @ (cmf.T @ monitor.primaries_on(WAVE)).T  # primaries (N, 3) -> their XYZ (3, 3)
    white = xyz[0].mean(axis=0)
    return colour.XYZ_to_Lab(xyz / white[1], colour.XYZ_to_xy(white)), fb


def test_scene_struct_with_a_compressed_illuminant_renders_like_its_scene(tmp_path):
    from skimage import data as skdata
    from skimage.transform import resize

    from camsim_core.scene import scene_from_rgb

    srgb = np.clip(resize(skdata.coffee(), (40, 60), anti_aliasing=True), 0, 1)
    srgb[0] = 1.0  # a perfect white reflector along the top row: the rendered white
    made = scene_from_rgb(srgb)  # the photo's colours under D65 (Mallett 2019 spectra), W/sr/m^2 per band
    radiance_photons = energy_to_quanta(WAVE, made.data / STEP)
    codes, lo, hi = ie_compress(energy_to_quanta(WAVE, made.illuminant.values / STEP), 32)
    data_codes, dmin, dmax = ie_compress(radiance_photons, 16)
    scene_struct = {"name": "coffee", "spectrum": {"wave": WAVE}, "wAngular": 10.0, "distance": 1.2,
                    "data": {"photons": data_codes, "dmin": dmin, "dmax": dmax, "bitDepth": 16.0},
                    "illuminant": {"name": "D65", "type": "illuminant", "spectrum": {"wave": WAVE},
                                   "data": {"photons": codes, "min": lo, "max": hi}}}
    scene, _ = load(write_mat(tmp_path / "coffee.mat", {"scene": scene_struct}, "v5"))
    monitor = cs.load_monitor("simtoolbox-test")
    lab, fb = _rendered_lab(scene, monitor)
    white_fraction = float(np.mean(np.all(fb >= 255, axis=-1)))
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    expected = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(srgb), d65)
    de = colour.delta_E(lab[1:], expected[1:], method="CIE 2000")
    print(f"\ncompressed-illuminant render: white pixels {white_fraction:.2%}, mean dE2000 {de.mean():.2f}")
    assert white_fraction < 0.05
    assert de.mean() < 10.0
    # the codes taken as photons (the reader's old reading) make a white frame: the check can fail
    wrong = dataclasses.replace(scene, illuminant=Spectrum(WAVE, per_band(quanta_to_energy(WAVE, codes.astype(float)))))
    _, fb_wrong = _rendered_lab(wrong, monitor)
    assert np.mean(np.all(fb_wrong >= 255, axis=-1)) > 0.9
