"""Raw hyperspectral capture -> calibrated scene (chapter section 2).

Round trips: raw captures are made from a known scene with known per-plane
motions (translation, rotation, scale), gains, dark frames (level + fixed
pattern) and veiling offsets; calibration must give the scene back within
1 % rms relative error over the interior and each plane's motion within
0.2 px. Bad input: clear errors and no output file.
"""

import json
import shutil

import numpy as np
import pytest
from scipy import ndimage

from camsim_core import load_scene
from camsim_core.calibration import calibrate
from camsim_core.calibration.dark import subtract_darks
from camsim_core.calibration.evaluation import shipped_comparison, slope_through_origin
from camsim_core.calibration.manifest import read_frame
from camsim_core.calibration.radiometric import read_reference_csv
from camsim_core.calibration.registration import Similarity, displacement_error, register_planes, warp_plane
from camsim_core.calibration.scatter import fit_scatter
from camsim_core.calibration.synthetic import _write, random_transforms, raw_captures
from camsim_core.cli import main
from camsim_core.errors import CamsimError, ParameterError
from camsim_core.scene import Scene, macbeth_scene

MARGIN = 6  # px of border not compared: registration cannot fill what the moved planes did not see


def _chart_boxes(patch_size, border, col0=0, inset=3):
    """Interior boxes of the 24 patches of macbeth_scene(patch_size, border), shifted by col0."""
    step = patch_size + border
    boxes = {}
    for i in range(24):
        r, c = divmod(i, 6)
        y0, x0 = border + r * step, col0 + border + c * step
        boxes[str(i + 1)] = [y0 + inset, x0 + inset, y0 + patch_size - inset, x0 + patch_size - inset]
    return boxes


def _motions(n, shape, wavelengths, seed):
    t = random_transforms(n, shape, seed=seed, max_shift=3.0, max_angle_deg=1.0, max_scale=0.015)
    k = int(np.argmin(np.abs(np.asarray(wavelengths) - 550)))
    t[k] = Similarity(center=t[k].center)  # the frame everything is registered to
    return t


def _rms_relative(a, b, m=MARGIN):
    a, b = a[m:-m, m:-m], b[m:-m, m:-m]
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def _make_capture(folder, truth, boxes, seed, fmt, reference_box, extra_regions=None):
    n = truth.data.shape[2]
    rng = np.random.default_rng(seed)
    motions = _motions(n, truth.data.shape, truth.wavelengths, seed)
    veils = rng.uniform(100, 2000, n)
    regions = {"patches": boxes, "reference": reference_box, "white": "mcc", **(extra_regions or {})}
    info = raw_captures(
        truth,
        folder,
        transforms=motions,
        gains=rng.uniform(0.5, 1.0, n) * 30000 / truth.data.reshape(-1, n).max(axis=0),
        dark_levels=rng.uniform(100, 500, n),
        veils=veils,
        dark_pattern=20.0,
        fmt=fmt,
        seed=seed,
        regions=regions,
        reference_box=reference_box,
    )
    return info


# ---------------------------------------------------------------- synthetic Macbeth round trip


@pytest.fixture(scope="module")
def macbeth_trip(tmp_path_factory):
    ps, bd = 10, 4
    chart = macbeth_scene(patch_size=ps, border=bd)
    # the optics make any capture smooth at the pixel scale; the truth is the blurred chart
    truth = Scene(ndimage.gaussian_filter(chart.data, (1, 1, 0)), chart.wavelengths, name="macbeth")
    folder = tmp_path_factory.mktemp("macbeth_raw")
    boxes = _chart_boxes(ps, bd)
    info = _make_capture(folder, truth, boxes, seed=3, fmt="tiff", reference_box=boxes["19"])
    out = folder.parent / "macbeth.npz"
    result = calibrate(folder, out)
    return dict(chart=chart, truth=truth, info=info, result=result, out=out, folder=folder)


def test_macbeth_round_trip_recovers_scene(macbeth_trip):
    err = _rms_relative(macbeth_trip["result"].scene.data, macbeth_trip["truth"].data)
    assert err < 0.01, f"rms relative error {err:.4f}"


def test_macbeth_round_trip_recovers_motions(macbeth_trip):
    res, info = macbeth_trip["result"], macbeth_trip["info"]
    shape = res.scene.data.shape
    errors = [displacement_error(r.transform, t, shape) for r, t in zip(res.registration, info["transforms"])]
    assert max(errors) < 0.2, np.round(errors, 3)
    # the motions were real: most planes moved by more than a pixel somewhere
    moved = [displacement_error(t, Similarity(center=t.center), shape) for t in info["transforms"]]
    assert sum(m > 1.0 for m in moved) > len(moved) // 2


def test_macbeth_round_trip_scatter_and_illuminant(macbeth_trip):
    res, info, chart = macbeth_trip["result"], macbeth_trip["info"], macbeth_trip["chart"]
    # the regression intercept is the veiling offset that was added (the chart has none of its own)
    np.testing.assert_allclose(res.intercept, info["veils"], rtol=0.01)
    # the white patch's radiance over its known reflectance is the chart's illuminant
    np.testing.assert_allclose(res.scene.illuminant.values, chart.illuminant.values, rtol=0.01)


def test_without_registration_the_round_trip_fails(macbeth_trip):
    """The round-trip test can fail: skipping registration leaves errors far above 1 %."""
    res = calibrate(macbeth_trip["folder"], register=False)
    assert _rms_relative(res.scene.data, macbeth_trip["truth"].data) > 0.05


def test_written_scene_loads_and_matches(macbeth_trip):
    loaded = load_scene(macbeth_trip["out"])
    res = macbeth_trip["result"]
    np.testing.assert_allclose(loaded.data, res.scene.data, rtol=1e-12)
    np.testing.assert_array_equal(loaded.wavelengths, res.scene.wavelengths)
    np.testing.assert_allclose(loaded.illuminant.values, res.scene.illuminant.values)


# ---------------------------------------------------------------- shipped scene round trip


@pytest.fixture(scope="module")
def cacaphony_trip(tmp_path_factory):
    """A crop of the shipped Cacaphony290 with a synthetic chart beside it (the lab always put one in the scene).

    The shipped planes are themselves misregistered by up to ~0.5 px (this
    registration finds translations of -0.3 to +0.45 px between them), so
    the crop's planes are first aligned to its 550 nm plane to make a
    self-consistent ground truth; 11 planes (400:30:700 nm) keep it fast.
    """
    sc = load_scene("cacaphony290")
    sel = slice(0, 31, 3)
    wls = sc.wavelengths[sel]
    crop = np.moveaxis(sc.data[40:136, 40:168, sel], -1, 0)
    pre = register_planes(crop, wls)
    crop = np.clip(np.moveaxis(np.stack([warp_plane(p, r.transform) for p, r in zip(crop, pre)]), 0, -1), 0, None)
    ps, bd = 10, 3
    chart = macbeth_scene(sc.illuminant, patch_size=ps, border=bd, wavelengths=wls)
    k = crop.max() / chart.data.max()
    data = np.zeros((96, 128 + chart.data.shape[1], wls.size))
    data[:, :128] = crop
    data[: chart.data.shape[0], 128:] = chart.data * k
    truth = Scene(ndimage.gaussian_filter(data, (1, 1, 0)), wls, name="cacaphony-crop")
    folder = tmp_path_factory.mktemp("cacaphony_raw")
    boxes = _chart_boxes(ps, bd, col0=128)
    mid_box = [70, 75, 85, 110]
    mid = truth.data[70:85, 75:110].mean(axis=(0, 1)) / 30.0  # per nm: 30 nm planes
    (folder / "mid.csv").write_text("wavelength,radiance\n" + "\n".join(f"{a:g},{b:.10g}" for a, b in zip(wls, mid)))
    extra = {"measured": [{"name": "middle patch", "box": mid_box, "spectrum": "mid.csv"}]}
    info = _make_capture(folder, truth, boxes, seed=5, fmt="raw-be16", reference_box=[70, 10, 85, 40], extra_regions=extra)
    report = folder.parent / "cacaphony_report"
    result = calibrate(folder, folder.parent / "cacaphony.npz", report=report)
    return dict(truth=truth, info=info, result=result, report=report, illuminant=chart.illuminant.values * k)


def test_cacaphony_round_trip(cacaphony_trip):
    res, info, truth = cacaphony_trip["result"], cacaphony_trip["info"], cacaphony_trip["truth"]
    err = _rms_relative(res.scene.data, truth.data)
    assert err < 0.01, f"rms relative error {err:.4f}"
    errors = [displacement_error(r.transform, t, truth.data.shape) for r, t in zip(res.registration, info["transforms"])]
    assert max(errors) < 0.2, np.round(errors, 3)
    np.testing.assert_allclose(res.intercept, info["veils"], rtol=0.01)
    np.testing.assert_allclose(res.scene.illuminant.values, cacaphony_trip["illuminant"], rtol=0.01)


def test_cacaphony_report(cacaphony_trip):
    rep = cacaphony_trip["report"]
    for name in ("figure-1-3.png", "figure-1-4.png", "figure-1-5.png", "calibration.json"):
        assert (rep / name).stat().st_size > 1000, name
    summary = json.loads((rep / "calibration.json").read_text())
    assert len(summary["planes"]) == 11
    assert summary["regions_compared"] == ["reference region", "middle patch"]
    # the independent measured region agrees with the image: Figure 1.5's slope is 1
    assert abs(summary["figure_1_5_slope"] - 1.0) < 0.01
    assert all(p["edge_residual_px"] < 0.5 for p in summary["planes"])


# ---------------------------------------------------------------- pieces


def test_similarity_matches_skimage():
    """The transform convention agrees with scikit-image's SimilarityTransform (x = col, y = row)."""
    from skimage.transform import SimilarityTransform

    t = Similarity(1.5, -2.0, np.radians(3.0), 1.02, (10.0, 20.0))
    pts = np.array([[0.0, 0.0], [5.0, 7.0], [30.0, -4.0]])
    c = np.array([20.0, 10.0])  # (x, y) of the centre
    ref = SimilarityTransform(scale=1.02, rotation=np.radians(-3.0), translation=(-2.0, 1.5))
    xy = ref(pts[:, ::-1] - c) + c
    np.testing.assert_allclose(t.apply(pts), xy[:, ::-1], atol=1e-12)
    np.testing.assert_allclose(t.inverse().apply(t.apply(pts)), pts, atol=1e-12)


def test_slope_through_origin_known_slope():
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, 500)
    assert slope_through_origin(x, 0.96 * x) == pytest.approx(0.96, abs=1e-12)
    y = 0.96 * x + rng.normal(0, 0.01, x.size)
    expected = np.linalg.lstsq(x[:, None], y, rcond=None)[0][0]
    assert slope_through_origin(x, y) == pytest.approx(expected, rel=1e-12)
    assert slope_through_origin(x, y) == pytest.approx(0.96, abs=0.003)


def test_shipped_spectra_per_nm():
    """Means x image factors against refSpectra, compared per nm (the README's factor 2 is the bin width)."""
    bfgb = shipped_comparison("BFGB_128")
    assert bfgb["names"][0] == "white panel"
    # the white panel is the region the factors came from: slope 1 once both are per nm (2.0 per band)
    assert bfgb["slopes"][0] == pytest.approx(1.0, abs=1e-3)
    assert all(c > 0.998 for c in bfgb["correlations"])
    assert 0.98 < bfgb["slope"] < 1.03
    caca = shipped_comparison("Cacaphony290")
    assert caca["slope"] == pytest.approx(1.0, abs=1e-3)


def test_fit_scatter_recovers_line():
    rng = np.random.default_rng(1)
    r = rng.uniform(0.03, 0.9, (24, 5))
    m, b = np.array([100.0, 2e3, 5e4, 7.0, 1.0]), np.array([3.0, -20.0, 500.0, 0.0, 0.1])
    m_hat, b_hat = fit_scatter(r * m + b, r)
    np.testing.assert_allclose(m_hat, m, rtol=1e-10)
    np.testing.assert_allclose(b_hat, b, atol=1e-8 * np.abs(m).max())


def test_dark_of_the_same_exposure_is_subtracted():
    planes = np.stack([np.full((2, 3), 100.0), np.full((2, 3), 200.0)])
    darks = {0.5: np.array([[1.0, 2, 3], [4, 5, 6]]), 2.0: np.full((2, 3), 50.0)}
    out = subtract_darks(planes, [2.0, 0.5], darks)
    np.testing.assert_array_equal(out[0], 50.0)
    np.testing.assert_array_equal(out[1], 200.0 - darks[0.5])


def test_reference_csv_units(tmp_path):
    per_nm = tmp_path / "a.csv"
    per_nm.write_text("wavelength,radiance\n400,0.1\n405,0.2\n")
    per_band = tmp_path / "b.csv"
    per_band.write_text("# unit: W/sr/m^2 per band\nwavelength,radiance\n400,0.5\n405,1.0\n")
    np.testing.assert_allclose(read_reference_csv(per_nm)[1], [0.1, 0.2])
    np.testing.assert_allclose(read_reference_csv(per_band)[1], [0.1, 0.2])  # 5 nm bands


@pytest.mark.parametrize("fmt", ["tiff", "png", "raw-be16"])
def test_frame_formats(tmp_path, fmt):
    a = np.arange(12, dtype=float).reshape(3, 4) * 5000
    path = tmp_path / ("f" + {"tiff": ".tif", "png": ".png", "raw-be16": ""}[fmt])
    _write(path, a, fmt)
    np.testing.assert_array_equal(read_frame(path, fmt, 3, 4), a)


# ---------------------------------------------------------------- CLI and bad input


@pytest.fixture(scope="module")
def small_capture(tmp_path_factory):
    """Five planes (490-610 nm) of a small chart: enough for the error paths."""
    ps, bd = 8, 3
    chart = macbeth_scene(patch_size=ps, border=bd, wavelengths=np.arange(490.0, 611.0, 30.0))
    truth = Scene(ndimage.gaussian_filter(chart.data, (1, 1, 0)), chart.wavelengths, name="small")
    folder = tmp_path_factory.mktemp("small_raw")
    boxes = _chart_boxes(ps, bd, inset=2)
    _make_capture(folder, truth, boxes, seed=7, fmt="tiff", reference_box=boxes["19"])
    return folder


@pytest.fixture
def capture(small_capture, tmp_path):
    folder = tmp_path / "raw"
    shutil.copytree(small_capture, folder)
    return folder


def _manifest(folder):
    return json.loads((folder / "manifest.json").read_text())


def _save_manifest(folder, spec):
    (folder / "manifest.json").write_text(json.dumps(spec))


def _fails(folder, capsys, *words, extra=()):
    out = folder.parent / "scene.npz"
    status = main(["calibrate", str(folder), "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert status == 2
    assert err.startswith("camsim calibrate: error:") and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert not out.exists()
    assert not list(folder.parent.glob(".scene.npz*"))  # no temporary left behind
    return err


def test_cli_writes_scene_and_report(capture, capsys):
    out, rep = capture.parent / "scene.npz", capture.parent / "report"
    status = main(["calibrate", str(capture), "--out", str(out), "--mcc", str(capture / "regions.json"),
                   "--reference", str(capture / "reference.csv"), "--report", str(rep)])
    assert status == 0, capsys.readouterr().err
    scene = load_scene(out)
    assert scene.data.shape == (3 + 4 * 11, 3 + 6 * 11, 5)
    assert (rep / "figure-1-3.png").exists() and (rep / "calibration.json").exists()


def test_plane_not_listed_in_manifest(capture, capsys):
    spec = _manifest(capture)
    spec["planes"] = [p for p in spec["planes"] if p["wavelength"] != 520]
    _save_manifest(capture, spec)
    _fails(capture, capsys, "520.tif", "missing from the manifest")


def test_wavelength_gap_in_manifest(capture, capsys):
    spec = _manifest(capture)
    spec["planes"] = [p for p in spec["planes"] if p["wavelength"] != 580]
    _save_manifest(capture, spec)
    (capture / "580.tif").unlink()
    _fails(capture, capsys, "no plane for 580 nm", "missing from the manifest")


def test_planes_of_different_sizes(capture, capsys):
    _write(capture / "580.tif", np.full((20, 30), 1000.0), "tiff")
    _fails(capture, capsys, "580.tif", "20 x 30", "same size")


def test_wavelength_without_dark_frame(capture, capsys):
    spec = _manifest(capture)
    plane = next(p for p in spec["planes"] if p["wavelength"] == 610)
    spec["darks"] = [d for d in spec["darks"] if d["exposure"] != plane["exposure"]]
    (capture / "unused").mkdir()
    for f in {d["file"] for d in _manifest(capture)["darks"]} - {d["file"] for d in spec["darks"]}:
        (capture / f).rename(capture / "unused" / f)
    _save_manifest(capture, spec)
    _fails(capture, capsys, "610 nm", f"no dark frame for {plane['exposure']:g} s")


def test_patch_region_outside_image(capture, capsys):
    regions = json.loads((capture / "regions.json").read_text())
    regions["patches"]["7"] = [40, 60, 52, 75]  # the image is 47 x 69
    (capture / "regions.json").write_text(json.dumps(regions))
    _fails(capture, capsys, "patch 'orange' (7)", "outside the 47 x 69 image")


def test_missing_plane_file(capture, capsys):
    (capture / "550.tif").unlink()
    _fails(capture, capsys, "550.tif", "not found")


def test_calibrate_api_error_leaves_no_file(capture):
    regions = json.loads((capture / "regions.json").read_text())
    regions["reference"] = [-1, 0, 5, 5]
    (capture / "regions.json").write_text(json.dumps(regions))
    out = capture.parent / "x.npz"
    with pytest.raises(CamsimError, match="'reference'"):
        calibrate(capture, out)
    assert not out.exists()


def test_a_dark_frame_brighter_than_its_plane_is_refused_naming_the_plane():
    rng = np.random.default_rng(3)
    dark = 100.0 + rng.normal(0, 2, (8, 8))
    unlit = 100.0 + rng.normal(0, 2, (2, 8, 8))  # no light: below the dark frame at about half the pixels
    out = subtract_darks(unlit, [1.0, 1.0], {1.0: dark}, wavelengths=[400.0, 410.0])
    assert 0.2 < np.mean(out < 0) < 0.8
    swapped = np.stack([dark - 60.0, dark + 40.0])  # the first plane is far below its dark frame
    with pytest.raises(ParameterError, match=r"400 nm plane.*brighter than the plane at 100 %.*swapped"):
        subtract_darks(swapped, [1.0, 1.0], {1.0: dark}, wavelengths=[400.0, 410.0])
