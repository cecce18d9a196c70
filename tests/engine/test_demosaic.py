"""Demosaicing (chapter section 4.1): bilinear, Freeman, Bayesian, Malvar 2004, Menon 2007."""

import colour
import colour_demosaicing as cdm
import numpy as np
import pytest
import skimage.data

import camsim_core as cs
from camsim_core.camera import camera_preset
from camsim_core.errors import ParameterError
from camsim_core.io.raw import read_dcs200_raw
from camsim_core.rendering import white_xyz
from camsim_core.scene import stripe_scene
from camsim_core.simulation import FOUR_SENSOR_GRID

METHODS = ("bilinear", "freeman", "bayesian", "bayesian-original", "malvar2004", "menon2007")
ANY_TILE = ("bilinear", "freeman", "bayesian")
BORDER = 8


def psnr(a, b, border=BORDER):
    d = (np.asarray(a) - np.asarray(b))[border:-border, border:-border]
    return float(10 * np.log10(1.0 / np.mean(d**2)))


@pytest.fixture(scope="module")
def natural():
    """256 x 256 crops of scikit-image's astronaut, coffee and chelsea (float, 0-1), RGGB-mosaicked."""
    out = {}
    for name in ("astronaut", "coffee", "chelsea"):
        rgb = getattr(skimage.data, name)()[:256, :256].astype(float) / 255.0
        out[name] = (rgb, cdm.mosaicing_CFA_Bayer(rgb, "RGGB"))
    return out


@pytest.mark.parametrize("pattern", ["RGGB", "GRBG", "BGGR", "GBRG"])
def test_bilinear_equals_standard_bayer_bilinear(pattern):
    rgb = np.random.default_rng(1).random((40, 48, 3))
    cfa = cdm.mosaicing_CFA_Bayer(rgb, pattern)
    ours = cs.demosaic(cs.raw_from_array(cfa, pattern)).data
    ref = cdm.demosaicing_CFA_Bayer_bilinear(cfa, pattern)
    assert np.abs(ours - ref)[1:-1, 1:-1].max() < 1e-9


def test_bilinear_on_four_sensor_grid_is_bilinear_interpolation():
    """Each class of the 2 x 2 grid sits on a lattice of period 2: a linear ramp is recovered exactly."""
    yy, xx = np.mgrid[0:20, 0:24].astype(float)
    planes = np.stack([3 * yy + 2 * xx, 5 * yy - xx + 60, yy + xx, 7 * xx + 1], axis=-1)
    idx = np.tile(FOUR_SENSOR_GRID, (10, 12))
    mosaic = np.take_along_axis(planes, idx[:, :, None], axis=2)[:, :, 0]
    out = cs.demosaic(cs.raw_from_array(mosaic, FOUR_SENSOR_GRID)).data
    assert np.allclose(out[2:-2, 2:-2], planes[2:-2, 2:-2], atol=1e-9)


def test_demosaic_contract():
    raw = cs.simulate(stripe_scene(16, 16), camera_preset("gaussian-4"))
    for method in ANY_TILE:
        out = cs.demosaic(raw, method)
        assert out.space == "sensor" and not out.mosaiced and out.data.shape == (16, 16, 4)
        assert np.array_equal(out.tile, raw.tile) and out.history[-1] == f"demosaic:{method}"


@pytest.mark.parametrize("method", METHODS)
def test_uniform_field_stays_uniform(method):
    """A uniform coloured field (next to textured content, which shapes the Bayesian prior) stays uniform."""
    rgb = skimage.data.astronaut()[:96, :96].astype(float) / 255.0
    rgb[:, 48:] = (0.5, 0.3, 0.2)
    cfa = cdm.mosaicing_CFA_Bayer(rgb, "GRBG")
    out = cs.demosaic(cs.raw_from_array(cfa, "GRBG"), method).data
    field = out[BORDER:-BORDER, 48 + BORDER : -BORDER]
    if method == "bayesian-original":
        # one global mean: the estimate is pulled towards the image's mean by up to ~1.5 %, as documented
        assert 1e-4 < np.abs(field - (0.5, 0.3, 0.2)).max() < 0.02
    else:
        assert np.abs(field - (0.5, 0.3, 0.2)).max() < 1e-5


@pytest.mark.parametrize("method", ANY_TILE)
def test_uniform_field_four_sensor_grid(method):
    out = cs.demosaic(cs.raw_from_array(np.tile([[10.0, 20.0], [30.0, 40.0]], (12, 12)), FOUR_SENSOR_GRID), method).data
    assert np.abs(out - (10, 20, 30, 40)).max() < 1e-4


def test_natural_images_psnr(natural):
    """Our bilinear matches colour-demosaicing's within 0.1 dB; Freeman and Bayesian beat bilinear."""
    for name, (rgb, cfa) in natural.items():
        raw = cs.raw_from_array(cfa, "RGGB")
        p = {m: psnr(cs.demosaic(raw, m).data, rgb) for m in ANY_TILE}
        ref = psnr(cdm.demosaicing_CFA_Bayer_bilinear(cfa, "RGGB"), rgb)
        assert abs(p["bilinear"] - ref) < 0.1, name
        assert p["freeman"] > p["bilinear"] + 1.0, name
        assert p["bayesian"] > p["bilinear"] + 1.0, name


def test_bayer_methods_match_colour_demosaicing(natural):
    rgb, cfa = natural["coffee"]
    raw = cs.raw_from_array(cfa, "RGGB")
    assert np.allclose(cs.demosaic(raw, "malvar2004").data, cdm.demosaicing_CFA_Bayer_Malvar2004(cfa, "RGGB"))
    assert np.allclose(cs.demosaic(raw, "menon2007").data, cdm.demosaicing_CFA_Bayer_Menon2007(cfa, "RGGB"))


def test_bayesian_uses_noise_variance():
    """With noise in the likelihood the estimate smooths: lower error on a noisy natural image than without."""
    rgb = skimage.data.chelsea()[:128, :128].astype(float)
    cfa = cdm.mosaicing_CFA_Bayer(rgb, "GRBG") + np.random.default_rng(3).normal(0, 12.0, (128, 128))
    raw = cs.raw_from_array(cfa, "GRBG", noise_sigma=12.0)
    err = {s: np.mean((cs.demosaic(raw, "bayesian", noise_sigma=s).data - rgb)[8:-8, 8:-8] ** 2) for s in (0.0, 12.0)}
    assert err[12.0] < 0.8 * err[0.0]


def _lab(xyz, monitor):
    wp = white_xyz(monitor)
    return colour.XYZ_to_Lab(xyz / wp[1], colour.XYZ_to_xy(wp))


def test_stripe_scene_yellow_artifact():
    """Figure 1.10: one-pixel green stripes on white through a GR/BG Bayer camera.

    Bilinear turns them into a near-uniform yellow field (high b*, little column-to-column
    structure); Freeman and Bayesian carry the G structure into R and B and lower the
    dE to the ideal image.
    """
    monitor = cs.load_monitor("simtoolbox-test")
    scene = stripe_scene(32, 32)  # 102.6 px/deg at the scene distance: the camera's geometry
    cam = camera_preset("kodak-dcs200", noise_sigma=0.0)
    ex = cs.auto_exposure(scene, cam)
    raw = cs.simulate(scene, cam, exposure=ex)
    assert raw.data.shape == (32, 32)  # no resampling
    ideal = _lab(cs.to_xyz(cs.ideal_image(scene, cam, monitor, exposure=ex), monitor), monitor)[4:-4, 4:-4]
    de, lab = {}, {}
    for method in ("bilinear", "freeman", "bayesian"):
        lab[method] = _lab(cs.to_xyz(cs.render(cs.demosaic(raw, method), monitor), monitor), monitor)[4:-4, 4:-4]
        de[method] = float(colour.delta_E(lab[method], ideal, method="CIE 1976").mean())
    bil = lab["bilinear"]
    hue = np.degrees(np.arctan2(bil[..., 2].mean(), bil[..., 1].mean()))
    assert 75 < hue < 110 and bil[..., 2].mean() > 70  # yellow
    assert bil[..., 2].mean() > ideal[..., 2].mean() + 30  # far yellower than the scene's mean colour
    # the true image alternates green / white every column; bilinear's b* barely does
    assert np.abs(np.diff(bil[..., 2].mean(axis=0))).mean() < 0.2 * np.abs(np.diff(ideal[..., 2].mean(axis=0))).mean()
    assert de["freeman"] < de["bilinear"] - 5
    assert de["bayesian"] < de["bilinear"] - 2


def test_dcs200_raw_demosaics():
    raw = read_dcs200_raw(cs.datasets.SIMTOOLBOX / "DCS200TestIR" / "DCS200TestIR.tif")
    assert raw.data.shape == (162, 252) and raw.mosaiced and raw.bits == 8
    for method in METHODS:
        out = cs.demosaic(raw, method)
        assert out.data.shape == (162, 252, 3)
        g = out.data[:, :, 1]
        assert np.array_equal(g[0::2, 0::2], raw.data[0::2, 0::2]) or method.startswith("bayesian")


# -- bad input ---------------------------------------------------------------------------------

def test_unknown_method_lists_valid():
    raw = cs.raw_from_array(np.zeros((8, 8)), "GRBG")
    with pytest.raises(ParameterError, match="bilinear, freeman, bayesian, bayesian-original, malvar2004, menon2007"):
        cs.demosaic(raw, "nearest")


def test_non_mosaiced_image_is_refused():
    img = cs.simulate(stripe_scene(8, 8), camera_preset("human-cones"))
    with pytest.raises(ParameterError, match="not mosaiced"):
        cs.demosaic(img)


def test_bayer_only_methods_refuse_other_tiles():
    raw = cs.raw_from_array(np.zeros((8, 8)), FOUR_SENSOR_GRID)
    for method in ("malvar2004", "menon2007"):
        with pytest.raises(ParameterError, match="Bayer tile"):
            cs.demosaic(raw, method)


def test_raw_from_array_bad_input(tmp_path):
    with pytest.raises(ParameterError, match="array"):
        cs.raw_from_array(np.zeros((2, 3, 4, 5)), "GRBG")
    with pytest.raises(ParameterError, match="phase"):
        cs.raw_from_array(np.zeros((4, 4)), "RRGB")
    with pytest.raises(ParameterError, match="metadata"):
        cs.raw_from_array(np.zeros((4, 4)), "GRBG", colour="red")
    bad = tmp_path / "bad.tif"
    bad.write_bytes(b"not a tiff")
    with pytest.raises(cs.FileFormatError, match="bad.tif"):
        read_dcs200_raw(bad)


def test_raw_black_level_and_bits():
    raw = cs.raw_from_array(np.array([[20, 30], [40, 10]], np.uint8), "GRBG", black_level=15)
    assert raw.bits == 8 and raw.quantized
    assert raw.black_level == 15.0 and np.array_equal(raw.data, [[20, 30], [40, 10]])
    with pytest.raises(ParameterError, match="black_level"):
        cs.raw_from_array(np.zeros((2, 2)), "GRBG", black_level=-1)


def test_bayesian_beats_bilinear_on_noisy_simulated_mosaics():
    """Section 5's use: 3-sensor Bayer and 4-sensor grid cameras with noise (sigma = 5 DU) on the Macbeth rows."""
    scene = cs.load_scene("cacaphony290")
    for name in ("gaussian-3", "gaussian-4"):
        cam = camera_preset(name, noise_sigma=5.0)
        ex = cs.auto_exposure(scene, cam)
        truth = cs.simulate(scene, cam.replace(mosaic=None, noise_sigma=0.0, bits=None), exposure=ex).data
        raw = cs.simulate(scene, cam, exposure=ex)
        methods = ("bilinear", "bayesian", "bayesian-original")
        rms = {m: np.sqrt(np.mean((cs.demosaic(raw, m).data - truth)[8:-8, 8:-8] ** 2)) for m in methods}
        assert rms["bayesian"] < 0.8 * rms["bilinear"], name
        # Brainard's original form (5 x 5, global mean, no detail term, noise fraction) also beats bilinear,
        # and camsim's extensions improve on it
        assert rms["bayesian-original"] < 0.8 * rms["bilinear"], name
        assert rms["bayesian"] < rms["bayesian-original"], name


def _smooth(a, sigma=2.0):
    import scipy.ndimage as ndi

    return ndi.gaussian_filter(a, (sigma, sigma, 0))


def _mosaic_of(rgb, pattern):
    return cdm.mosaicing_CFA_Bayer(rgb, pattern)


def test_bayesian_original_mode_is_brainards_form():
    from camsim_core.demosaicing.bayesian import ORIGINAL_NOISE_FRACTION

    rng = np.random.default_rng(2)
    truth = _smooth(rng.normal(100, 30, (40, 48, 3)))
    raw = cs.raw_from_array(_mosaic_of(truth, "GRBG"), "GRBG", noise_sigma=5.0)
    a = cs.demosaic(raw, "bayesian-original").data
    # the noise it assumes is a fraction of the prior, not the image's sigma: the metadata change nothing
    np.testing.assert_array_equal(a, cs.demosaic(raw.replace(noise_sigma=0.0), "bayesian-original").data)
    assert not np.array_equal(cs.demosaic(raw, "bayesian").data, cs.demosaic(raw.replace(noise_sigma=0.0), "bayesian").data)
    # a 5 x 5 neighbourhood and the documented fraction by default
    np.testing.assert_array_equal(a, cs.demosaic(raw, "bayesian-original", window=5, noise_fraction=ORIGINAL_NOISE_FRACTION).data)
    assert not np.array_equal(a, cs.demosaic(raw, "bayesian-original", window=7).data)
    # a larger assumed noise smooths more: the estimate moves towards the global mean
    smooth = cs.demosaic(raw, "bayesian-original", noise_fraction=1.0).data
    assert smooth.std() < a.std()
    # measured samples are kept when the assumed noise is ~0 (interpolation, not smoothing)
    exact = cs.demosaic(raw, "bayesian-original", noise_fraction=0.0).data
    g = exact[..., 1]
    np.testing.assert_allclose(g[0::2, 0::2], raw.data[0::2, 0::2], atol=1e-2)
    with pytest.raises(ParameterError, match="noise_fraction"):
        cs.demosaic(raw, "bayesian-original", noise_fraction=-1)
    with pytest.raises(ParameterError, match="noise_fraction"):
        cs.demosaic(raw, "bayesian", noise_fraction=0.1)
    with pytest.raises(ParameterError, match="noise_sigma"):
        cs.demosaic(raw, "bayesian-original", noise_sigma=3.0)


@pytest.mark.parametrize("method", ["bilinear", "freeman", "bayesian", "malvar2004", "menon2007"])
@pytest.mark.parametrize("shape", [(1, 2), (3, 5), (2, 9), (1, 1)])
def test_a_mosaic_under_two_tiles_a_side_is_refused_by_every_method(method, shape):
    """A far camera with large pixels can see a scene on a few pixels: a clear refusal, never an IndexError."""
    cfa = np.full(shape, 100.0)
    with pytest.raises(cs.ParameterError, match=rf"is {shape[0]} x {shape[1]} pixels, fewer than two mosaic tiles \(4 x 4\)"):
        cs.demosaic(cs.raw_from_array(cfa, "GRBG"), method)


def test_two_tiles_a_side_demosaic():
    out = cs.demosaic(cs.raw_from_array(np.full((4, 4), 100.0), "GRBG"))
    assert out.data.shape == (4, 4, 3) and np.allclose(out.data, 100.0)
