"""``camsim compare-real`` on the shipped real DCS-200 raw (issue 4, chapter Figure 1.13)."""

import contextlib
import io
import math
import re

import numpy as np
import pytest
import tifffile
from PIL import Image

from camsim_core.cli import main
from camsim_core.errors import FileFormatError
from camsim_core.metrics.real import read_raw_tiff


@pytest.fixture(scope="module")
def run_default(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare_real") / "hist.png"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        status = main(["compare-real", "--out", str(out)])
    return status, buf.getvalue(), out


def test_compare_real_median_and_histogram(run_default, capsys):
    status, text, out = run_default
    assert status == 0, text
    m = re.search(r"median block dE\*ab = ([0-9.]+)", text)
    assert m, text
    median = float(m.group(1))
    blocks = re.search(r"(\d+) blocks of (\d+) x \d+ pixels", text)
    with capsys.disabled():
        print(f"\ncompare-real median block dE*ab = {median:.2f} ({blocks.group(1)} blocks of {blocks.group(2)} px; chapter: 6.0)")
    assert math.isfinite(median) and 0 < median < 100
    # the PNG exists and decodes to a real picture
    assert out.is_file() and out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with Image.open(out) as im:
        assert im.size[0] > 200 and im.size[1] > 150


def test_compare_real_reports_phase_gain_and_registration(run_default):
    _, text, _ = run_default
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
