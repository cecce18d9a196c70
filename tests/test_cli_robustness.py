"""The command line never shows a traceback: every failure is one line on stderr and status 2,
and outputs are checked before any work (no report written for an output that cannot be)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from camsim_core.calibration.synthetic import raw_captures
from camsim_core.cli import main
from camsim_core.scene import macbeth_scene


def _fails(capsys, argv, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err, (w, err)
    return err


@pytest.mark.parametrize("extra, words", [
    (["--seed", "-1"], ["--seed", ">= 0"]),
    (["--camera", "mixture-abc"], ["mixture-ALPHA"]),
    (["--camera", "mixture-2"], ["mixture-ALPHA"]),
    (["--exposure", "nan"], ["--exposure", "finite"]),
])
def test_simulate_bad_parameters(capsys, tmp_path, extra, words):
    argv = ["simulate", "--scene", "macbeth", "--camera", "kodak-dcs200-ir", "--out", str(tmp_path / "o.png")]
    i = argv.index("--camera")
    if extra[0] == "--camera":
        argv[i + 1] = extra[1]
    else:
        argv += extra
    _fails(capsys, argv, *words)
    assert list(tmp_path.iterdir()) == []


def test_simulate_out_naming_a_folder_or_a_missing_folder(capsys, tmp_path):
    base = ["simulate", "--scene", "macbeth", "--camera", "kodak-dcs200-ir", "--out"]
    (tmp_path / "dir.png").mkdir()
    _fails(capsys, base + [str(tmp_path / "dir.png")], "is a folder")
    _fails(capsys, base + [str(tmp_path / "missing" / "o.png")], "does not exist")


def test_info_on_a_fifo_and_a_bad_file(capsys, tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.Scam")
    _fails(capsys, ["info", str(tmp_path / "pipe.Scam")], "pipe.Scam", "not a regular file")
    (tmp_path / "bad.Smon").write_bytes(b"\xff\xfe#Sim#GammaTable\n-1 -1\n")
    _fails(capsys, ["info", str(tmp_path / "bad.Smon")], "bad.Smon")


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    folder = tmp_path_factory.mktemp("raw")
    scene = macbeth_scene(patch_size=6, border=2)
    raw_captures(scene, folder, fmt="tiff", seed=1, regions={"patches": {"1": [3, 3, 6, 6]}, "reference": [3, 3, 6, 6],
                                                              "white": "mcc"}, reference_box=[3, 3, 6, 6])
    return folder


def _copy(capture, tmp_path):
    import shutil

    dst = tmp_path / "raw"
    shutil.copytree(capture, dst)
    return dst


def test_calibrate_checks_its_outputs_before_writing_the_report(capsys, capture, tmp_path):
    raw = _copy(capture, tmp_path)
    _fails(capsys, ["calibrate", str(raw), "--out", str(tmp_path / "missing" / "x.npz"), "--report", str(tmp_path / "rep")],
           "missing", "does not exist")
    assert not (tmp_path / "rep").exists()


def test_calibrate_non_utf8_manifest(capsys, capture, tmp_path):
    raw = _copy(capture, tmp_path)
    (raw / "manifest.json").write_bytes((raw / "manifest.json").read_bytes().replace(b'"', b'"\xff', 1))
    _fails(capsys, ["calibrate", str(raw), "--out", str(tmp_path / "x.npz")], "manifest.json", "UTF-8")
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize("edit", ["infinity_box", "huge_wavelength"])
def test_calibrate_bad_manifest_values(capsys, capture, tmp_path, edit):
    raw = _copy(capture, tmp_path)
    spec = json.loads((raw / "manifest.json").read_text())
    if edit == "infinity_box":
        regions = json.loads((raw / spec["regions"]).read_text())
        regions["reference"] = [3, 3, float("inf"), 6]
        (raw / spec["regions"]).write_text(json.dumps(regions))  # Python writes the JSON word Infinity
    else:
        spec["planes"][0]["wavelength"] = 1e308
    (raw / "manifest.json").write_text(json.dumps(spec))
    _fails(capsys, ["calibrate", str(raw), "--out", str(tmp_path / "x.npz")])
    assert not (tmp_path / "x.npz").exists()
