"""``camsim compare-real`` on the shipped real DCS-200 raw (chapter Figure 1.13), three ways."""

import contextlib
import io
import json
import math
import re

import numpy as np
import pytest
import tifffile
from PIL import Image

import camsim_core as cs
from camsim_core.cli import main
from camsim_core.errors import FileFormatError, ParameterError
from camsim_core.metrics.real import estimate_black_level, read_raw_tiff


@pytest.fixture(scope="module")
def run_default(tmp_path_factory):
    """One run of ``compare-real --json``: the JSON on stdout, the report on stderr."""
    out = tmp_path_factory.mktemp("compare_real") / "hist.png"
    buf, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
        status = main(["compare-real", "--json", "--out", str(out)])
    return status, err.getvalue(), out, buf.getvalue()


def test_compare_real_three_medians(run_default, capsys):
    status, text, out, stdout = run_default
    assert status == 0, text
    j = json.loads(stdout)  # one JSON object and nothing else on stdout
    medians = {k: j[k]["median"] for k in ("chapter", "black_level", "cross_validated")}
    with capsys.disabled():
        print("\ncompare-real median block dE*ab at 16 px: "
              + ", ".join(f"{k} {v:.2f}" for k, v in medians.items()) + " (chapter: 6.0)")
    for k in medians:
        assert j[k]["block"] == 16 and math.isfinite(medians[k]) and 0 < medians[k] < 100
        assert set(j[k]["median_by_block"]) == {"16", "50"}
        assert j[k]["median"] == j[k]["median_by_block"]["16"]
    # the pedestal estimated from the raw's own darkest pixels brings the median below 12 (chapter: 6.0)
    assert medians["black_level"] < 12
    assert medians["chapter"] > 2 * medians["black_level"]
    est = j["black_level"]["estimate"]
    assert len(est) == 3 and all(10 <= v <= 20 for v in est)  # the gaps between patches read 15-19 DU
    assert j["black_level"]["per_class_percentile"][2] == min(j["black_level"]["per_class_percentile"])
    # the report names the three variants, each with its median
    for label in ("(1) chapter protocol", "(2) black level", "(3) black level + per-channel gains"):
        assert label in text
    assert "1.46" in j["registration"]["explanation"] or "1.4" in j["registration"]["explanation"]
    assert j["sizes"]["simulated"] == [233, 372] and j["sizes"]["real"] == [162, 252]
    # the PNG exists and decodes to a real picture
    assert out.is_file() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(out) as im:
        assert im.size[0] > 200 and im.size[1] > 150


def test_compare_real_reports_phase_gain_and_registration(run_default):
    _, text, out, _ = run_default
    assert out.is_file() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(out) as im:  # three labelled panels stacked
        assert im.size[0] > 200 and im.size[1] > 500
    # the real raw is laid out as the camera file says, [[G,R],[B,G]]: that phase fits far better
    assert "Bayer phase of the real raw (best fit): R at (0,1)" in text
    res = [float(x) for x in re.findall(r"relative residual ([0-9.]+)", text)]
    assert len(res) == 2 and res[0] < 0.5 * res[1]
    gain = float(re.search(r"fitted gain \(real / simulated raw\): ([0-9.]+)", text).group(1))
    assert 0.2 < gain < 5
    reg = re.search(r"simulated ([0-9.]+) \* \(r, c\) \+ \(([-0-9.]+), ([-0-9.]+)\) \(NCC ([0-9.]+)\)", text)
    assert reg, text
    assert float(reg.group(4)) > 0.95  # the two images do register


def test_missing_raw_is_a_clear_error(tmp_path, capsys):
    status = main(["compare-real", "--raw", str(tmp_path / "nope.tif"), "--out", str(tmp_path / "h.png")])
    err = capsys.readouterr().err
    assert status == 2 and "nope.tif" in err and "no such file" in err
    assert not (tmp_path / "h.png").exists()


def test_non_png_output_is_a_clear_error(tmp_path, capsys):
    status = main(["compare-real", "--out", str(tmp_path / "h.jpg")])
    assert status == 2 and ".png" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_bad_raw_files(tmp_path):
    rgb = tmp_path / "rgb.tif"
    tifffile.imwrite(rgb, np.zeros((40, 50, 3), np.uint8))
    with pytest.raises(FileFormatError, match="one plane"):
        read_raw_tiff(rgb)
    deep = tmp_path / "deep.tif"
    tifffile.imwrite(deep, np.zeros((40, 50), np.uint16))
    with pytest.raises(FileFormatError, match="8-bit"):
        read_raw_tiff(deep)
    junk = tmp_path / "junk.tif"
    junk.write_bytes(b"not a tiff at all")
    with pytest.raises(FileFormatError, match="junk.tif"):
        read_raw_tiff(junk)


def test_black_level_estimate_is_a_low_percentile_per_sensor_class():
    rng = np.random.default_rng(0)
    tile = np.array([[1, 0], [2, 1]])
    raw = np.empty((100, 100))
    from camsim_core.simulation import tile_index_map

    idx = tile_index_map(tile, raw.shape)
    for k, (pedestal, light) in enumerate([(15, 40), (15, 80), (15, 20)]):
        n = int(np.sum(idx == k))
        # pedestal + a dark region with no light (a tenth of the pixels) + lit pixels
        vals = pedestal + np.where(np.arange(n) < n // 10, 0.0, light) + rng.normal(0, 0.5, n)
        raw[idx == k] = vals
    est = estimate_black_level(raw, tile, 0.1)
    assert est == pytest.approx((15, 15, 15), abs=1.6)
    assert estimate_black_level(raw, tile, 0.0) == pytest.approx(tuple(raw[idx == k].min() for k in range(3)))
    with pytest.raises(ParameterError, match="black_percentile"):
        estimate_black_level(raw, tile, 60)


def test_per_class_black_level_is_subtracted_at_each_class_sites():
    raw = cs.raw_from_array(np.tile(np.array([[30, 25], [40, 30]], np.uint8), (4, 4)), [[1, 0], [2, 1]],
                            black_level=(5, 10, 20))
    dm = cs.demosaic(raw)
    np.testing.assert_array_equal(dm.data[..., 0], 20)  # R 25 - 5
    np.testing.assert_array_equal(dm.data[..., 1], 20)  # G 30 - 10
    np.testing.assert_array_equal(dm.data[..., 2], 20)  # B 40 - 20
    with pytest.raises(ParameterError, match="black_level"):
        cs.raw_from_array(np.zeros((4, 4)), "GRBG", black_level=(1, 2))


def test_bad_render_and_block_options(tmp_path, capsys):
    assert main(["compare-real", "--block", "0", "--out", str(tmp_path / "h.png")]) == 2
    assert "--block" in capsys.readouterr().err
    with pytest.raises(ParameterError, match="render"):
        from camsim_core.metrics.real import compare_real

        compare_real(render="fancy")
    assert list(tmp_path.iterdir()) == []
