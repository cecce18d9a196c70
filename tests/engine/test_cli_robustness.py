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


# -- one test per signature the command-line fuzz found ----------------------------------------------
def _usage_error(capsys, argv):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "usage:" not in err and "Traceback" not in err, err
    return err


@pytest.mark.parametrize("argv, words", [
    (["simulate", "--scene", "macbeth", "--camera", "kodak-dcs200-ir", "--out", "o.png", "--size", "x5"], ["--size", "ROWSxCOLS"]),
    (["bogus"], ["invalid choice: 'bogus'"]),
    (["report"], ["required: DESIGN.json, --out"]),
    (["measure", "--f-stop", "abc"], ["--f-stop", "invalid float value: 'abc'"]),
    (["experiment", "mosaic", "--viewing", "camera", "--samples-per-degree", "3"], ["not allowed with"]),
])
def test_usage_errors_are_one_line_without_the_usage_block(capsys, argv, words):
    err = _usage_error(capsys, argv)
    for w in words:
        assert w in err, (w, err)


def test_no_command_is_one_line_on_stderr(capsys):
    assert main([]) == 2
    err = capsys.readouterr().err
    assert err.startswith("camsim: error: a COMMAND is required (calibrate, ") and err.count("\n") == 1, err


def test_a_warning_before_an_error_is_not_printed(capsys, monkeypatch):
    import sys
    import warnings

    from camsim_core.cli import info
    from camsim_core.errors import FileFormatError

    def run(args):  # as Pillow warns about corrupt EXIF data before the image is found unreadable
        warnings.warn("Corrupt EXIF data.  Expecting to read 12 bytes but only got 9.", UserWarning)
        raise FileFormatError("x.tif", "not a readable image")

    def show(message, category, filename, lineno, file=None, line=None):  # Python's own, not pytest's recorder
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))

    monkeypatch.setattr(warnings, "showwarning", show)
    monkeypatch.setattr(info, "run", run)
    assert main(["info", "x.tif"]) == 2
    assert capsys.readouterr().err == "camsim info: error: x.tif: not a readable image\n"


def test_a_warning_of_a_successful_command_is_one_line(capsys, monkeypatch):
    import warnings

    from camsim_core.cli import info

    def run(args):
        for _ in range(3):
            warnings.warn("the same thing, three times", UserWarning)
        return 0

    monkeypatch.setattr(info, "run", run)
    assert main(["info", "x"]) == 0
    assert capsys.readouterr().err == "camsim info: warning: UserWarning: the same thing, three times\n"


def test_an_unexpected_exception_is_one_line_with_its_type(capsys, monkeypatch):
    from camsim_core.cli import info

    def run(args):
        raise KeyError("planes")

    monkeypatch.setattr(info, "run", run)
    assert main(["info", "x"]) == 2
    assert capsys.readouterr().err == "camsim info: error: KeyError: 'planes'\n"
    monkeypatch.setenv("CAMSIM_DEBUG", "1")  # the traceback when asked for
    with pytest.raises(KeyError):
        main(["info", "x"])


@pytest.mark.parametrize("extra, flag", [(["--f-stop", "1e308"], "--f-stop"), (["--f-stop", "nan"], "--f-stop"),
                                         (["--black-percentile", "101"], "--black-percentile"),
                                         (["--black-percentile", "nan"], "--black-percentile"),
                                         (["--seed", "-1"], "--seed"), (["--distance", "inf"], "--distance"),
                                         (["--exposure", "0"], "--exposure")])
def test_compare_real_checks_its_numbers_before_simulating(capsys, tmp_path, extra, flag):
    # f/1e308 simulated a black image, the registration warned and the gain came out NaN; a percentile of 101
    # and a seed of -1 ran to the end
    out = tmp_path / "h.png"
    _fails(capsys, ["compare-real", "--out", str(out)] + extra, flag)
    assert not out.exists()


def test_compare_real_output_in_a_missing_folder_is_refused_before_the_report(capsys, tmp_path):
    # with --json the report goes to stderr: it was printed (15 lines) before the PNG failed to be written
    assert main(["compare-real", "--json", "--out", str(tmp_path / "missing" / "h.png")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "--out" in err and "does not exist" in err, err


@pytest.mark.parametrize("levels", ["1e308", "nan", "0", "-5,10", "1e11"])
def test_snr_vs_light_luminances_are_bounded(capsys, levels):
    # 1e308 cd/m^2 ended in numpy's "ValueError: lam value too large"
    _fails(capsys, ["measure", f"--snr-vs-light={levels}", "--camera", "phone-1.4um"], "--snr-vs-light", "1e+10 cd/m^2")


def test_measure_negative_seed_is_a_camera_parameter_error(capsys):
    # was numpy's "ValueError: expected non-negative integer" from the noise generator
    _fails(capsys, ["measure", "--scene", "uniform", "--what", "snr", "--noise-sigma", "2", "--seed", "-1"],
           "seed: must be a whole number >= 0")


@pytest.mark.parametrize("name", ["--mcc", "--reference"])
def test_calibrate_binary_regions_or_reference_file(capsys, capture, tmp_path, name):
    # a PNG given as the regions JSON ended in "UnicodeDecodeError: 'utf-8' codec can't decode byte 0x89"
    binary = tmp_path / "image.png"
    binary.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    _fails(capsys, ["calibrate", str(capture), "--out", str(tmp_path / "x.npz"), name, str(binary)],
           name, "image.png", "not a UTF-8 text file")
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.parametrize("extra, flag", [(["--alphas", "0:1:inf"], "--alphas"), (["--alphas", "0:1:100000"], "--alphas"),
                                         (["--alphas", ",".join(["0.5"] * 1001)], "--alphas"),
                                         (["--sigmas", "0:5:1e9"], "--sigmas"), (["--seeds", "100000"], "--seeds")])
def test_experiment_sweeps_are_bounded(capsys, tmp_path, extra, flag):
    # 0:1:inf ended in "OverflowError: cannot convert float infinity to integer"; 0:1:100000 started
    # 100000 tasks (hours), 0:5:1e9 would allocate a billion values
    out = tmp_path / "e"
    _fails(capsys, ["experiment", "sensors", "--scenes", "macbeth", "--workers", "0", "--out", str(out)] + extra, flag)
    assert not out.exists()


def test_simulate_size_beyond_the_camera_limit(capsys, tmp_path):
    # 200000x200000 was accepted
    base = ["simulate", "--scene", "macbeth", "--camera", "kodak-dcs200-ir", "--out", str(tmp_path / "o.png"), "--size"]
    assert "from 1 to 65536, got 200000" in _usage_error(capsys, base + ["200000x200000"])
    assert "60000 x 60000 = 3600000000 pixels" in _usage_error(capsys, base + ["60000x60000"])
    assert list(tmp_path.iterdir()) == []


def test_camera_file_with_negative_sensitivity_or_huge_height(capsys, tmp_path):
    from camsim_core.datasets import SIMTOOLBOX as ST

    text = (ST / "cameras" / "kodakdcs200_50mm_256.Scam").read_bytes().decode("latin-1").replace("\r", "\n")
    lines = text.split("\n")
    i = lines.index("#Sim#SpectralSensitivity")
    lines[i + 2] = "-1 " + lines[i + 2].split(None, 1)[1]
    (tmp_path / "neg.Scam").write_text("\n".join(lines), encoding="latin-1")
    _fails(capsys, ["simulate", "--scene", "macbeth", "--camera", str(tmp_path / "neg.Scam"), "--out", str(tmp_path / "o.png")],
           "neg.Scam", "#Sim#SpectralSensitivity", ">= 0")
    lines = text.split("\n")
    lines[lines.index("#SimHeight") + 1] = "1e40"
    (tmp_path / "huge.Scam").write_text("\n".join(lines), encoding="latin-1")
    _fails(capsys, ["info", str(tmp_path / "huge.Scam")], "huge.Scam", "#SimHeight", "at most 65536")

# -- seeded random fuzz of the whole command line ------------------------------------------------
# Random argument lists built from the real sub-commands and options: good values, bad numbers
# (NaN, infinities, negatives, zero, fractions, huge values, words), missing and unknown options,
# and files that are shipped, mutated, truncated, of the wrong kind or missing. Every run must end
# with status 0 (success, or --help) or 2 with exactly one line on stderr and no traceback. A
# default run is part of ``make test``; ``CAMSIM_FULL_FUZZ=1`` runs 600 and prints the outcomes.
import contextlib
import io
import os
import re
import shutil
from collections import Counter

from camsim_core.datasets import SIMTOOLBOX

CLI_FULL = os.environ.get("CAMSIM_FULL_FUZZ") == "1"
CLI_RUNS = 600 if CLI_FULL else 60
BAD_NUMBERS = ["nan", "inf", "-inf", "-1", "0", "-0", "1e308", "-1e308", "2.5", "0.5", "1e9", "1e-308", "abc", "",
               "1e400", "0x10", "--", "-5e-324", "1,2"]
_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])")


def _mutated_text(text, rng):
    """``text`` with one number replaced by a bad one, a line deleted, duplicated or emptied, or cut short."""
    lines = text.split("\n")
    kind = rng.integers(6)
    if kind <= 2:
        spots = [(i, m) for i, line in enumerate(lines) for m in _NUMBER.finditer(line)]
        i, m = spots[rng.integers(len(spots))]
        lines[i] = lines[i][: m.start()] + BAD_NUMBERS[rng.integers(len(BAD_NUMBERS))] + lines[i][m.end():]
    elif kind == 3:
        del lines[rng.integers(len(lines))]
    elif kind == 4:
        lines[rng.integers(len(lines))] = ""
    else:
        return text[: rng.integers(len(text) + 1)]
    return "\n".join(lines)


_ODD_JSON = [None, [], {}, "x", -1, 0, 1e308, float("nan"), True, [1, 2, 3], "1e400", [[0]], {"a": 1}, 2.5, -1e308]


def _mutated_json(text, rng):
    """A JSON text with one value (at any depth) replaced by one of another type or range, or a key dropped."""
    value = json.loads(text)
    spots = []

    def walk(v):
        if isinstance(v, dict):
            spots.extend((v, k) for k in v)
            for x in v.values():
                walk(x)
        elif isinstance(v, list):
            spots.extend((v, i) for i in range(len(v)))
            for x in v:
                walk(x)

    walk(value)
    if spots:
        holder, key = spots[rng.integers(len(spots))]
        if isinstance(holder, dict) and rng.random() < 0.2:
            del holder[key]
        else:
            holder[key] = _ODD_JSON[rng.integers(len(_ODD_JSON))]
    return json.dumps(value)


def _mutated_bytes(data, rng):
    if rng.random() < 0.5:
        return data[: rng.integers(len(data) + 1)]
    b = bytearray(data)
    for _ in range(rng.integers(1, 6)):
        b[rng.integers(len(b))] = rng.integers(256)
    return bytes(b)


@pytest.fixture(scope="module")
def cli_files(tmp_path_factory, capture):
    """Shipped-like inputs the fuzz draws from (and mutates): camera, monitor, scene, image and design files."""
    from PIL import Image

    from camsim_core.scene import save_npz_scene

    root = tmp_path_factory.mktemp("cli-fuzz")
    text = lambda p: p.read_bytes().decode("latin-1").replace("\r", "\n")  # noqa: E731
    simg = root / "simg"
    simg.mkdir()
    for f in (SIMTOOLBOX / "BFGB_128").iterdir():
        if f.name == "BFGB_128.Simg" or f.name.isdigit():
            shutil.copy(f, simg / f.name)
    save_npz_scene(macbeth_scene(patch_size=4, border=1), root / "scene.npz")
    rgb = (np.arange(32 * 48 * 3).reshape(32, 48, 3) % 251).astype(np.uint8)
    Image.fromarray(rgb).save(root / "image.png")
    Image.fromarray(rgb[:, :, 1]).save(root / "image.tif")
    odd = root / "odd"
    odd.mkdir()  # images of other modes and shapes
    Image.fromarray(rgb[:1, :1]).save(odd / "one-pixel.png")
    Image.fromarray(rgb[:2, :3]).save(odd / "two-by-three.png")
    Image.fromarray(np.dstack([rgb, rgb[:, :, :1]])).save(odd / "rgba.png")
    Image.fromarray((rgb[:, :, 0].astype(np.uint16) * 200)).save(odd / "gray16.png")
    Image.fromarray(rgb).convert("P").save(odd / "palette.png")
    Image.fromarray(rgb[:, :, 0] > 100).save(odd / "bilevel.png")
    Image.fromarray(rgb[:, :, 0].astype(np.float32) / 255).save(odd / "float.tif")
    Image.fromarray(rgb).convert("CMYK").save(odd / "cmyk.tif")
    Image.fromarray(np.zeros((32, 48, 3), np.uint8)).save(odd / "black.png")
    Image.fromarray(rgb).save(odd / "photo.jpg")
    (odd / "empty.png").write_bytes(b"")
    (odd / "text.png").write_text("not an image")
    (root / "design.json").write_text(json.dumps({"scene": "macbeth", "camera": "gaussian-3", "distance": 3.0,
                                                  "exposure": 0.5, "noise_sigma": 1.0}))
    (root / "folder").mkdir()
    return {
        "root": root,
        "scam": text(SIMTOOLBOX / "cameras" / "kodakdcs200_50mm_256.Scam"),
        "smon": text(SIMTOOLBOX / "monitors" / "SimToolboxTest.Smon"),
        "simg": text(simg / "BFGB_128.Simg"),
        "simg_dir": simg,
        "npz": (root / "scene.npz").read_bytes(),
        "png": (root / "image.png").read_bytes(),
        "tif": (root / "image.tif").read_bytes(),
        "design": (root / "design.json").read_text(),
        "capture": capture,
        "odd_images": sorted(str(p) for p in odd.iterdir()),
    }


_SHARED_CHART = {"size": ["32", "24x40", "8", "1", "0", "1e9", "5x", "100000x100000"], "illuminant": ["D65", "A", "F2", "Z"],
                 "luminance": ["100", "1e4", "0", "-5", "1e12"], "distance": ["1", "0.5", "0", "1e-9"],
                 "wavelengths": ["400:10:31", "1:2:3"], "bogus": ["1"]}
_CHART_OPTIONS = [
    ("slanted-edge", {**_SHARED_CHART, "angle": ["5", "45", "90", "-30", "1e308"], "contrast": ["4", "1", "0.5", "1e308"],
                      "light": ["0.8", "1", "1.5"]}),
    ("zone-plate", {**_SHARED_CHART, "max_frequency": ["0.5", "0.1", "1", "-1"], "mean": ["0.5", "2"],
                    "amplitude": ["0.4", "0.9"]}),
    ("uniform", dict(_SHARED_CHART)),
    ("munsell", {**_SHARED_CHART, "rows": ["2", "0", "100000"], "cols": ["3", "-1"], "patch_size": ["4", "0", "1e6"],
                 "border": ["1", "-1"], "chips": ["1", "5000"]}),
]


class _Gen:
    """Random argument values: mostly good ones, now and then a bad number, a word or a bad file."""

    def __init__(self, rng, files, work):
        self.rng, self.files, self.work, self.n = rng, files, work, 0

    def pick(self, seq):
        return seq[self.rng.integers(len(seq))]

    def chance(self, p):
        return self.rng.random() < p

    def number(self, good):
        return self.pick(BAD_NUMBERS) if self.chance(0.15) else str(self.pick(good))

    def _new(self, suffix):
        self.n += 1
        return self.work / f"f{self.n}{suffix}"

    def text_file(self, key, suffix):
        p = self._new(suffix)
        p.write_text(_mutated_text(self.files[key], self.rng) if self.chance(0.7) else self.files[key], encoding="latin-1")
        return str(p)

    def json_file(self, key, suffix=".json"):
        p = self._new(suffix)
        p.write_text(_mutated_json(self.files[key], self.rng) if self.chance(0.7) else self.files[key])
        return str(p)

    def image(self):
        r = self.rng.random()
        if r < 0.4:
            return self.pick(self.files["odd_images"])
        if r < 0.8:
            return self.pick([self.bytes_file("png", ".png"), self.bytes_file("tif", ".tif"), self.bytes_file("png", ".dng"),
                              self.bytes_file("tif", ".dng")])
        return self.pick([self.odd_path(".png"), str(SIMTOOLBOX / "DCS200TestIR" / "DCS200TestIR.tif"),
                          str(SIMTOOLBOX / "BFGB_128" / "400")])

    def bytes_file(self, key, suffix):
        p = self._new(suffix)
        p.write_bytes(_mutated_bytes(self.files[key], self.rng) if self.chance(0.7) else self.files[key])
        return str(p)

    def odd_path(self, suffix):
        root = self.files["root"]
        return str(self.pick([root / f"missing{suffix}", root / "folder", root / "folder" / "sub" / f"x{suffix}",
                              root / "image.png", root / "scene.npz", root / f"folder{suffix}", "", "-"]))

    def simg(self):
        folder = self._new("")
        shutil.copytree(self.files["simg_dir"], folder)
        (folder / "BFGB_128.Simg").write_text(_mutated_text(self.files["simg"], self.rng), encoding="latin-1")
        if self.chance(0.2):
            plane = folder / "400"
            plane.write_bytes(plane.read_bytes()[: self.rng.integers(0, 32768)])
        return str(folder / "BFGB_128.Simg")

    def scene(self):
        r = self.rng.random()
        if r < 0.45:
            return self.pick(["macbeth", "bfgb128", "uniform", "stripes", "slanted-edge", "zone-plate", "MACBETH"])
        if r < 0.55:  # a chart with options, one of them odd now and then
            name, opts = self.pick(_CHART_OPTIONS)
            keys = [k for k in opts if self.chance(0.5)] or [self.pick(list(opts))]
            return name + ":" + ",".join(f"{k}={self.pick(opts[k]) if self.chance(0.7) else self.pick(BAD_NUMBERS)}"
                                         for k in keys)
        if r < 0.7:
            return self.bytes_file("npz", ".npz")
        if r < 0.8:
            return self.simg()
        if r < 0.87:
            return self.pick(["moon", "photo-nothing", "macbeth.npz", "1e308"])
        if r < 0.94:
            return self.pick(self.files["odd_images"])
        return self.odd_path(self.pick([".npz", ".Simg", ".mat", ".png"]))

    def camera(self):
        r = self.rng.random()
        if r < 0.5:
            return self.pick(["kodak-dcs200-ir", "kodak-dcs200", "gaussian-3", "gaussian-4", "human-cones", "cie1931",
                              "phone-1.4um", "imx174", "mixture-0.3", "stockman-sharpe"])
        if r < 0.8:
            return self.text_file("scam", ".Scam")
        if r < 0.9:
            return self.pick(["mixture-nan", "mixture-inf", "mixture--1", "mixture-", "pinhole", "mixture-1e308"])
        return self.odd_path(".Scam")

    def monitor(self):
        r = self.rng.random()
        if r < 0.5:
            return self.pick(["simtoolbox-test", "brainard-crt"])
        if r < 0.85:
            return self.text_file("smon", ".Smon")
        return self.pick(["crt", self.odd_path(".Smon")])

    def out(self, suffixes):
        if self.chance(0.85):
            return str(self._new(self.pick(suffixes)))
        return self.pick([self.odd_path(self.pick(suffixes)), str(self._new(".txt")), str(self._new(""))])

    def size(self):
        if self.chance(0.5):
            return self.pick(["16x16", "32x48", "1x1", "64x24", "2x3", "1x7", "3x1", "2x2", "5x5", "128x96"])
        return self.pick(["0x5", "5x0", "-4x4", "abc", "5x", "x5", "200000x200000", "100000x1", "1e3x4", "4x4x4",
                          "65537x1", "70000x70000", "99999999999999999999x1", "16X16", " 8x8 "])


def _options(g, spec):
    """Each (option, value-maker) of ``spec`` with probability 0.4 (value None: a flag)."""
    argv = []
    for opt, make in spec:
        if g.chance(0.4):
            argv.append(opt)
            if make is not None:
                argv.append(make())
    return argv


def _simulate(g):
    argv = ["simulate"]
    for opt, make, p in (("--scene", g.scene, 0.95), ("--camera", g.camera, 0.95),
                         ("--out", lambda: g.out([".png", ".tif", ".npy", ".dng"]), 0.95)):
        if g.chance(p):
            argv += [opt, make()]
    if g.chance(0.8):  # the camera's own array is large for some; the scene's extent bounds the image anyway
        argv += ["--size", g.size()]
    argv += _options(g, [
        ("--distance", lambda: g.number([0.5, 1, 3.32, 10])), ("--exposure", lambda: g.number([0.01, 0.1, 1])),
        ("--f-stop", lambda: g.number([2.8, 5.6, 11])), ("--noise-sigma", lambda: g.number([0, 1, 5])),
        ("--black-level", lambda: g.number([0, 15])), ("--bits", lambda: g.number([8, 12, 16, 1, 32, 33])),
        ("--seed", lambda: g.number([0, 7, 2**40, 2**64])), ("--auto-exposure", None), ("--unquantized", None),
        ("--no-mosaic", None), ("--no-progress", None),
        ("--demosaic", lambda: g.pick(["bilinear", "freeman", "malvar2004", "menon2007", "bayesian", "bayesian-original",
                                       "nearest", ""])),
        ("--render", lambda: g.pick(["baseline", "illuminant", "fancy"])),
        ("--illuminant", lambda: g.pick(["gray-world", "max-rgb", "d65", ""])), ("--monitor", g.monitor),
    ])
    return argv


def _info(g):
    r = g.rng.random()
    if r < 0.3:
        return ["info", g.pick(["macbeth", "bfgb128", "kodak-dcs200-ir", "imx174", "simtoolbox-test", "brainard-crt",
                                "mixture-0.5", "nothing"])]
    if r < 0.55:
        return ["info", g.text_file("scam", ".Scam")]
    if r < 0.8:
        return ["info", g.text_file("smon", ".Smon")]
    if r < 0.9:
        return ["info", g.pick([g.bytes_file("npz", ".npz"), g.simg()])]
    return ["info"] + g.pick([[], [g.odd_path(".Scam")], [g.odd_path(".Smon")], ["a", "b"]])


def _measure(g):
    argv = ["measure"]
    r = g.rng.random()
    if r < 0.25:
        argv += ["--image", g.image()]
        argv += _options(g, [("--roi", lambda: g.pick(["0,16,0,16", "0,1,0,1", "5,2,0,4", "a,b,c,d", "0,99999,0,4", "0,16",
                                                       "0,2,0,2", "-1,4,0,4", "0,1e9,0,4"])),
                             ("--what", lambda: g.pick(["mtf", "snr", "mtf,snr", "color", "x"]))])
    elif r < 0.35:
        argv += ["--snr-vs-light", g.pick(["10,100", "1", "nan", "-1,2", "0", "1e308", "a,b", ",", "1e-308"])]
        argv += _options(g, [("--camera", g.camera)])
    else:
        argv += _options(g, [("--scene", lambda: g.pick(["macbeth", "uniform", "slanted-edge", g.scene()])),
                             ("--camera", g.camera),
                             ("--what", lambda: g.pick(["mtf", "snr", "color", "similarity", "snr,color", "bogus", ","])),
                             ("--patches", lambda: g.pick(["layout", "detect", "guess"]))])
    argv += _options(g, [
        ("--distance", lambda: g.number([1, 3.32])), ("--exposure", lambda: g.number([0.01, 0.1])),
        ("--f-stop", lambda: g.number([5.6, 8])), ("--noise-sigma", lambda: g.number([0, 2])),
        ("--bits", lambda: g.number([8, 10])), ("--black-level", lambda: g.number([0, 10])),
        ("--seed", lambda: g.number([0, 3])), ("--demosaic", lambda: g.pick(["bilinear", "malvar2004", "x"])),
        ("--monitor", g.monitor), ("--json", lambda: g.out([".json"])),
    ])
    return argv


def _report(g):
    designs = []
    for _ in range(g.pick([0, 1, 1, 2])):
        designs.append(g.pick([g.json_file("design"), g.json_file("design"), g.text_file("design", ".json"),
                               g.odd_path(".json")]))
    argv = ["report"] + designs
    if g.chance(0.9):
        argv += ["--out", g.out([".html", ".htm", ".pdf"])]
    argv += _options(g, [("--sweep", lambda: g.pick(["noise_sigma=0,2", "noise_sigma", "bits=8", "nope=1,2", "exposure=nan",
                                                     "noise_sigma=" + ",".join(["1"] * 300)])),
                         ("--metric", lambda: g.pick(["CIELAB", "S-CIELAB", "dE"])),
                         ("--workers", lambda: g.number([1, 2])), ("--title", lambda: g.pick(["t", "", "<b>x</b>"]))])
    return argv


def _compare_real(g):
    # slow when it succeeds (the Cacaphony simulation): one bad value always, so it stops at a check
    bad = g.pick([("--out", lambda: g.pick([g.odd_path(".png"), str(g._new(".jpg"))])),
                  ("--block", lambda: g.pick(["0", "-3", "abc", "2.5", "1e9"])),
                  ("--distance", lambda: g.pick(["nan", "-1", "0", "inf", "1e308"])),
                  ("--exposure", lambda: g.pick(["nan", "-1", "0", "inf"])),
                  ("--f-stop", lambda: g.pick(["nan", "0", "-2", "1e308"])),
                  ("--black-percentile", lambda: g.pick(["nan", "-1", "101", "inf"])),
                  ("--raw", lambda: g.pick([g.bytes_file("tif", ".tif"), g.odd_path(".tif")])),
                  ("--monitor", lambda: g.pick(["crt", g.text_file("smon", ".Smon")])),
                  ("--seed", lambda: g.pick(["-1", "abc"]))])
    argv = ["compare-real", bad[0], bad[1]()]
    if bad[0] != "--out":
        argv += ["--out", g.out([".png"])]
    return argv + _options(g, [("--render", lambda: g.pick(["baseline", "illuminant", "x"])), ("--json", None),
                               ("--black-per-class", None)])


def _experiment(g):
    which = g.pick(["sensors", "mosaic", "pixel-size", "nothing"])
    argv = ["experiment", which, "--workers", g.pick(["0", "0", "0", "-1", "abc"]), "--no-progress"]
    if which == "pixel-size":
        argv += ["--pitches", g.pick(["2", "1,2", "0", "-1", "nan", "1:2:0", "abc", "1e308", "0.01"]),
                 "--lux", g.pick(["100", "0", "-5", "nan", "1e308", "x"])]
    else:
        argv += ["--scenes"] + g.pick([["macbeth"], [g.scene()], ["moon"]]) + ["--sigmas", g.pick(["0", "nan", "-1", "a", "0,1e308"])]
        argv += _options(g, [("--seeds", lambda: g.pick(["1", "0", "-1", "x"])),
                             ("--distance", lambda: g.pick(["3.32", "scene", "nan", "-1", "0", "far"])),
                             ("--monitor", g.monitor),
                             ("--samples-per-degree", lambda: g.pick(["10", "0", "-1", "nan", "inf"])),
                             ("--viewing", lambda: g.pick(["camera", "camera/10", "display:0.25mm@0.6m", "display:x", "sideways"]))])
        if which == "sensors":
            argv += ["--alphas", g.pick(["0", "0,1", "2", "-1", "nan", "0:1:0", "0:1:100000", "a"])]
        elif which == "mosaic":
            argv += _options(g, [("--centers", lambda: g.pick(["460,520,580,640", "1,2", "nan,1,2,3", "-1,0,1,2", "a"])),
                                 ("--std", lambda: g.pick(["27", "0", "-1", "nan", "1e308"])),
                                 ("--demosaic", lambda: g.pick(["bilinear", "x"]))])
    argv += ["--out", g.pick([str(g._new("")), g.odd_path("")])]
    if not CLI_FULL:
        # a sweep that succeeds takes seconds: the default run stops it at a check (one bad value always)
        argv += g.pick([["--workers", "-1"], ["--seeds", "-1"]]) if which != "pixel-size" else ["--workers", "-1"]
    return argv


def _calibrate(g):
    raw = g._new("")
    shutil.copytree(g.files["capture"], raw)
    manifest = raw / "manifest.json"
    r = g.rng.random()
    if r < 0.4:
        manifest.write_text(_mutated_text(manifest.read_text(), g.rng))
    elif r < 0.8:
        manifest.write_text(_mutated_json(manifest.read_text(), g.rng))
    elif r < 0.87:
        regions = raw / json.loads(manifest.read_text())["regions"]
        regions.write_text(_mutated_json(regions.read_text(), g.rng))
    elif r < 0.95:  # one plane cut short or replaced by an odd image
        plane = raw / g.pick(sorted(p.name for p in raw.glob("*.tif")))
        if g.chance(0.5):
            plane.write_bytes(_mutated_bytes(plane.read_bytes(), g.rng))
        else:
            shutil.copy(g.pick(g.files["odd_images"]), plane)
    argv = ["calibrate", g.pick([str(raw), str(raw), g.odd_path("")]), "--out", g.out([".npz"])]
    return argv + _options(g, [("--no-registration", None), ("--report", lambda: g.pick([str(g._new("")), g.odd_path("")])),
                               ("--mcc", lambda: g.odd_path(".json")), ("--reference", lambda: g.odd_path(".csv"))])


def _anything(g):
    return g.pick([[], ["--help"], ["simulate", "--help"], ["bogus"], ["--version"], ["info", "--bogus", "x"],
                   ["experiment"], ["simulate", "--scene"], ["measure", "--bits", "--seed"]])


_COMMANDS = [(_simulate, 0.32), (_info, 0.2), (_measure, 0.2), (_report, 0.07), (_compare_real, 0.05),
             (_experiment, 0.06), (_calibrate, 0.05), (_anything, 0.05)]


def cli_argv(g):
    """One random argument list (``serve`` is left out: it starts a server)."""
    makers, weights = zip(*_COMMANDS)
    argv = makers[g.rng.choice(len(makers), p=np.asarray(weights) / sum(weights))](g)
    if argv and g.chance(0.05):  # an option given twice, or one the command does not have
        argv = argv + g.pick([["--bogus"], argv[-2:], ["--seed"]])
    return [str(a) for a in argv]


def run_cli(argv):
    """``(status, stderr, exception)`` of ``main(argv)`` in this process; ``exception`` is an uncaught one."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status, exc = main(argv), None
        except SystemExit as stop:
            status, exc = stop.code, None
        except Exception as raised:  # what a user would see as a traceback
            status, exc = None, raised
    return status, err.getvalue(), exc


def cli_fuzz(files, work, count, seed=20240611):
    """Outcomes of ``count`` random runs: a list of ``(argv, status, stderr, exception)``."""
    rng = np.random.default_rng(seed)
    g = _Gen(rng, files, work)
    out = []
    for _ in range(count):
        argv = cli_argv(g)
        out.append((argv, *run_cli(argv)))
    return out


def test_cli_fuzz(cli_files, tmp_path, capsys):
    results = cli_fuzz(cli_files, tmp_path, CLI_RUNS)
    problems = []
    for argv, status, err, exc in results:
        lines = err.strip().splitlines()
        if exc is not None:
            problems.append(f"{argv}: uncaught {type(exc).__name__}: {exc}")
        elif status not in (0, 2):
            problems.append(f"{argv}: status {status}")
        elif "Traceback" in err:
            problems.append(f"{argv}: traceback on stderr: {err}")
        elif status == 2 and len(lines) != 1:
            problems.append(f"{argv}: {len(lines)} lines on stderr: {err}")
    counts = Counter("uncaught" if exc is not None else status for _, status, _, exc in results)
    with capsys.disabled():
        print(f"\ncli fuzz, {CLI_RUNS} runs{' (full)' if CLI_FULL else ''}: "
              + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items(), key=str)))
    assert not problems, "\n".join(problems[:20])
    assert counts[0] > 0 and counts[2] > 0, counts  # the fuzz reaches both successes and refusals
