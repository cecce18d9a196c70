"""Seeded fuzzing of the readers: every mutated file gives a valid object or a CamsimError naming the file.

The shipped ``.Simg`` (BFGB_128 header with its planes), ``.Scam``
(DCS-200 IR), ``.Smon`` (SimToolbox test monitor), ``.dat`` (Kodak DCS-200
sensitivities) and an ``.npz`` scene are mutated: numbers replaced by
NaN, infinities, negatives, zero, fractions, huge values or words; lines
deleted, duplicated or emptied; files truncated; bytes flipped; npz arrays
replaced by wrong types and shapes. A run of 150 mutations per format is
part of ``make test``; ``CAMSIM_FULL_FUZZ=1`` runs 3,000 per format and
prints the table of outcomes.
"""

from __future__ import annotations

import io
import os
import re
import shutil
import zipfile
from collections import Counter

import numpy as np
import pytest

from camsim_core.camera.load import read_scam
from camsim_core.datasets import SIMTOOLBOX
from camsim_core.errors import CamsimError
from camsim_core.datasets.sensors import read_dat_sensors
from camsim_core.monitor import read_smon
from camsim_core.scene import macbeth_scene, read_npz_scene, read_simg, save_npz_scene

FULL = os.environ.get("CAMSIM_FULL_FUZZ") == "1"
COUNT = 3000 if FULL else 150
NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])")
BAD_NUMBERS = ["nan", "NaN", "inf", "-inf", "-1", "0", "1e308", "-1e308", "2.5", "0.5", "1e9", "abc", "", "-0", "1e-308"]


def _mutate_text(text, rng):
    lines = text.split("\n")
    kind = rng.integers(7)
    if kind <= 2:  # replace one number (most mutations: they reach the checks)
        spots = [(i, m) for i, line in enumerate(lines) for m in NUMBER.finditer(line)]
        if spots:
            i, m = spots[rng.integers(len(spots))]
            lines[i] = lines[i][: m.start()] + BAD_NUMBERS[rng.integers(len(BAD_NUMBERS))] + lines[i][m.end():]
    elif kind == 3 and len(lines) > 1:
        del lines[rng.integers(len(lines))]
    elif kind == 4:
        i = rng.integers(len(lines))
        lines.insert(i, lines[i])
    elif kind == 5:
        lines[rng.integers(len(lines))] = ""
    else:
        text = "\n".join(lines)
        return text[: rng.integers(len(text) + 1)]
    return "\n".join(lines)


def _flip_bytes(data, rng):
    b = bytearray(data)
    for _ in range(rng.integers(1, 4)):
        b[rng.integers(len(b))] = rng.integers(256)
    return bytes(b)


def _check_scene(s):
    from fuzz_uploads import check_scene

    check_scene(s)


def _check_camera(c):
    from camsim_core.camera.camera import ANGULAR_RESOLUTION_RANGE, MAX_CAMERA_PIXELS, MAX_CAMERA_SIDE

    v = c.sensors.values
    assert np.all(np.isfinite(v)) and v.min() >= 0 and np.all(v.max(axis=1) > 0)
    assert np.all(np.diff(c.sensors.wavelengths) > 0)
    assert 1 <= c.height <= MAX_CAMERA_SIDE and 1 <= c.width <= MAX_CAMERA_SIDE
    assert c.height * c.width <= MAX_CAMERA_PIXELS
    lo, hi = ANGULAR_RESOLUTION_RANGE
    assert all(lo <= a <= hi for a in np.ravel(c.angular_resolution))
    if c.bits is not None:
        assert 1 <= c.bits <= 32
    if c.mosaic is not None:
        assert np.issubdtype(np.asarray(c.mosaic).dtype, np.integer)
        assert np.asarray(c.mosaic).min() >= 0 and np.asarray(c.mosaic).max() < v.shape[0]


def _check_monitor(m):
    assert np.all(np.isfinite(m.primaries)) and np.all(np.isfinite(m.gamma_table))
    assert m.primaries.min() >= 0 and m.gamma_table.min() >= 0
    assert m.gamma_input.size >= 2 and np.all(m.gamma_table[-1] > 0)
    assert np.all(np.diff(m.gamma_input) > 0)
    ambient = getattr(m, "ambient", None)
    if ambient is not None:
        assert np.all(np.isfinite(np.asarray(ambient, float))) and np.min(ambient) >= 0


def _check_sensors(s):
    assert np.all(np.isfinite(s.values)) and s.values.min() >= 0 and np.all(s.values.max(axis=1) > 0)
    assert np.all(np.diff(s.wavelengths) > 0) and s.wavelengths.min() > 0


def _read_dat(path):
    return read_dat_sensors(path, ("R", "G", "B"), "fuzz")


def _run(fmt, path, reader, check):
    """'loaded' or 'error'; any other exception or a message not naming the file fails the test."""
    try:
        obj = reader(path)
    except CamsimError as exc:
        assert path.name in str(exc), f"{fmt}: error does not name the file: {exc}"
        return "error"
    check(obj)
    return "loaded"


@pytest.fixture(scope="module")
def sources(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz-src")
    simg = root / "simg"
    simg.mkdir()
    for f in (SIMTOOLBOX / "BFGB_128").iterdir():
        if f.name == "BFGB_128.Simg" or f.name.isdigit():
            shutil.copy(f, simg / f.name)
    scene = macbeth_scene(patch_size=4, border=1)
    save_npz_scene(scene, root / "scene.npz")
    return {
        "simg": (simg / "BFGB_128.Simg").read_bytes().decode("latin-1").replace("\r", "\n"),
        "simg_dir": simg,
        "scam": (SIMTOOLBOX / "cameras" / "kodakdcs200_50mmIR.Scam").read_bytes().decode("latin-1").replace("\r", "\n"),
        "smon": (SIMTOOLBOX / "monitors" / "SimToolboxTest.Smon").read_bytes().decode("latin-1").replace("\r", "\n"),
        "dat": (SIMTOOLBOX / "spectra" / "KodakDCS200.dat").read_bytes().decode("latin-1").replace("\r", "\n"),
        "npz": (root / "scene.npz").read_bytes(),
        "scene": scene,
    }


def _npz_variant(scene, rng):
    arrays = {"data": scene.data, "wavelengths": scene.wavelengths, "distance": np.float64(scene.distance),
              "angular_resolution": np.asarray(scene.angular_resolution, float)}
    key = ["data", "wavelengths", "distance", "angular_resolution", "illuminant"][rng.integers(5)]
    n = scene.wavelengths.size
    choices = [
        np.array([1.0, 2.0]), np.array("far"), np.array(["a"] * n), np.zeros((0, 24, n)), np.zeros((2, 2)),
        np.full(n, np.nan), -np.ones(n), (scene.data + 1j) if key == "data" else np.ones(n) + 1j,
        np.zeros((2, 2, n), dtype="timedelta64[s]") if key == "data" else np.zeros(n, dtype="timedelta64[s]"),
        np.array(1e308), np.array(-1.0), np.array(np.inf), np.arange(n)[::-1].astype(float), np.zeros(n, dtype=bool),
        np.zeros((4, 4, n), dtype=np.uint8),
    ]
    arrays[key] = choices[rng.integers(len(choices))]
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


FORMATS = ("simg", "scam", "smon", "dat", "npz")


def fuzz(sources, tmp_path, count, seed=20240601):
    """Outcome counts ``{format: Counter(loaded=, error=)}`` of ``count`` mutations per format."""
    rng = np.random.default_rng(seed)
    out = {f: Counter() for f in FORMATS}
    work = tmp_path / "work"
    shutil.copytree(sources["simg_dir"], work)
    header = work / "BFGB_128.Simg"
    for _ in range(count):
        # .Simg: the header mutated (and now and then one plane cut short)
        header.write_text(_mutate_text(sources["simg"], rng), encoding="latin-1")
        plane = work / "400"
        if rng.random() < 0.1:
            plane.write_bytes((sources["simg_dir"] / "400").read_bytes()[: rng.integers(0, 32768)])
        out["simg"][_run("simg", header, read_simg, _check_scene)] += 1
        shutil.copy(sources["simg_dir"] / "400", plane)
        for fmt, reader, check, suffix in (("scam", read_scam, _check_camera, ".Scam"),
                                           ("smon", read_smon, _check_monitor, ".Smon"),
                                           ("dat", _read_dat, _check_sensors, ".dat")):
            p = tmp_path / f"fuzz{suffix}"
            p.write_text(_mutate_text(sources[fmt], rng), encoding="latin-1")
            out[fmt][_run(fmt, p, reader, check)] += 1
        p = tmp_path / "fuzz.npz"
        r = rng.random()
        if r < 0.6:
            p.write_bytes(_npz_variant(sources["scene"], rng))
        elif r < 0.8:
            p.write_bytes(_flip_bytes(sources["npz"], rng))
        else:
            p.write_bytes(sources["npz"][: rng.integers(len(sources["npz"]))])
        out["npz"][_run("npz", p, read_npz_scene, _check_scene)] += 1
    return out


def test_reader_fuzz(sources, tmp_path, capsys):
    counts = fuzz(sources, tmp_path, COUNT)
    with capsys.disabled():
        print(f"\nreader fuzz, {COUNT} mutations per format{' (full)' if FULL else ''}:")
        print(f"{'format':8} {'loaded':>8} {'error':>8}")
        for f, c in counts.items():
            print(f"{f:8} {c['loaded']:8d} {c['error']:8d}")
    for f, c in counts.items():
        assert sum(c.values()) == COUNT
        assert c["error"] > 0, f"{f}: no mutation was refused: the fuzzer does not reach the checks"


UPLOAD_COUNT = 1500 if FULL else 15


@pytest.mark.parametrize("fmt", ["mat5", "mat73", "zip"])
def test_upload_fuzz(fmt, capsys):
    """MATLAB v5 / v7.3 files and zipped uploads (.Simg, ENVI, band PNGs, .npz, .mat inside), in a child process:
    no raw traceback, no invalid scene, no crash of the interpreter, no hang (see tests/fuzz_uploads.py)."""
    from fuzz_uploads import fuzz as fuzz_uploads

    outcomes, signatures = fuzz_uploads(fmt, UPLOAD_COUNT)
    with capsys.disabled():
        print(f"\nupload fuzz {fmt}, {UPLOAD_COUNT} cases: " + ", ".join(f"{k} {v}" for k, v in sorted(outcomes.items())))
        for sig, n in signatures.most_common():
            print(f"  {n:5d}  {sig}")
    assert sum(outcomes.values()) == UPLOAD_COUNT
    bad = {k: v for k, v in outcomes.items() if k not in ("loaded", "error")}
    assert not bad, f"{fmt}: {bad}; signatures: {dict(signatures)}"
    assert outcomes["error"] > 0 and outcomes["loaded"] > 0, "the fuzzer reaches neither the checks nor a valid scene"
