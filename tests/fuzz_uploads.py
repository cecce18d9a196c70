"""Seeded fuzzing of the MATLAB readers and of zipped uploads, run in a child process.

Formats: ``mat5`` (ICVL cubes, ISETCam scene structs and basis files,
compressed or not), ``mat73`` (the same written with h5py as MATLAB lays
them out), ``zip`` (uploads of a ``.Simg`` with its planes, an ENVI header
with its data, a folder of band PNGs, an ``.npz`` or a ``.mat`` inside a
zip). Each case is mutated: bytes flipped, the file cut short, a 4-byte
word set to an extreme, or a variable replaced by a wrong type, shape or
value (NaN, infinities, negatives, structs, text, empty arrays, huge
declared shapes). Every case goes through :func:`load_upload` (the
explorer's path) and, for MATLAB files, ``load_scene`` on a path (the
CLI's).

Run as a script (``python tests/fuzz_uploads.py FORMAT COUNT SEED``) it
prints ``case N`` before each case and one ``result`` line per case, so the
parent sees a crash (the child dies) or a hang (no line for
:data:`HANG_SECONDS`) and names the case. Outcomes: ``loaded`` (a valid
scene), ``error`` (a CamsimError naming the file), ``traceback`` (any
other exception), ``invalid`` (a scene that breaks the scene invariants),
``crash``, ``hang``.
"""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import tempfile
import time
import traceback
import warnings
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np

FORMATS = ("mat5", "mat73", "zip")
HANG_SECONDS = 60
WLS = np.arange(400.0, 701.0, 10.0)
BAD_VALUES = [np.nan, np.inf, -np.inf, -1.0, 0.0, 1e308, -1e308, 2.0**31, 1e-308]


def _bad_value(rng, like):
    """A wrong replacement for a variable ``like``."""
    n = np.asarray(like).size
    k = rng.integers(10)
    if k == 0:
        return "text"
    if k == 1:
        return {"oops": 1.0}
    if k == 2:
        return np.zeros((0, 3))
    if k == 3:
        return np.full(np.shape(like), BAD_VALUES[rng.integers(len(BAD_VALUES))])
    if k == 4:
        return np.ones(max(1, n + int(rng.integers(-3, 4))))
    if k == 5:
        return np.array([np.ones(2), "x"], dtype=object)
    if k == 6:
        return np.ones((2, 2, 2, 2))
    if isinstance(like, str):
        return np.ones(3)
    if k == 7:
        return np.asarray(like)[::-1].copy() if n > 1 else -np.asarray(like, float)
    if k == 8:
        return np.array(True)
    return np.asarray(like, float) * -1


def _variables(rng):
    """A valid MATLAB scene's variables, as a nested dict (structs are dicts)."""
    kind = rng.integers(3)
    cube = rng.uniform(0.1, 1.0, (4, 5, 31))
    if kind == 0:
        return {"rad": cube, "bands": WLS}
    if kind == 1:
        return {"scene": {"name": "s", "data": {"photons": cube * 1e15}, "spectrum": {"wave": WLS}, "wAngular": 10.0,
                          "distance": 1.2, "illuminant": {"data": {"photons": np.full(31, 1e16)},
                                                          "spectrum": {"wave": WLS}}}}
    basis = np.stack([np.ones(31), np.linspace(-1, 1, 31)], axis=1)
    return {"mcCOEF": rng.uniform(1e15, 2e15, (4, 5, 2)), "basis": {"basis": basis, "wave": WLS},
            "imgMean": np.full(31, 1e14), "illuminant": {"wave": WLS, "data": np.ones(31)}, "fov": 3.0, "dist": 1.5}


def _leaves(d, prefix=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, prefix + (k,))
        yield prefix + (k,)


def _replace(d, path, value):
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value


def mutate_leaf(rng, v):
    """Replace one leaf (a field at any depth) of the variables ``v`` with a bad value, in place."""
    leaves = list(_leaves(v))
    path = leaves[rng.integers(len(leaves))]
    node = v
    for k in path:
        node = node[k]
    _replace(v, path, _bad_value(rng, node if not isinstance(node, dict) else 1.0))


def _mutated_variables(rng):
    v = _variables(rng)
    if rng.random() < 0.7:
        mutate_leaf(rng, v)
    return v


def _flip(data, rng):
    b = bytearray(data)
    k = rng.integers(3)
    if k == 0:
        for _ in range(rng.integers(1, 5)):
            b[rng.integers(len(b))] = rng.integers(256)
    elif k == 1:
        b = b[: rng.integers(len(b))]
    else:
        p = int(rng.integers(0, max(1, len(b) - 4)))
        b[p:p + 4] = int(rng.choice([0, 1, 0xFFFFFFFF, 0x7FFFFFFF, 0x80000000, int(rng.integers(2**32))])).to_bytes(4, "little")
    return bytes(b)


def mat5_case(rng):
    import scipy.io

    buf = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scipy.io.savemat(buf, _mutated_variables(rng), do_compression=bool(rng.integers(2)))
    data = buf.getvalue()
    return _flip(data, rng) if rng.random() < 0.5 else data


def _h5_write(group, name, value, rng):
    if isinstance(value, dict):
        sub = group.create_group(name)
        for k, v in value.items():
            _h5_write(sub, k, v, rng)
        return
    a = np.asarray(value)
    if a.dtype.kind in "OU":
        group[name] = str(value).encode()
        return
    if a.ndim >= 2 and rng.random() < 0.9:
        a = a.T  # MATLAB's column-major order, as MATLAB writes it
    elif a.ndim == 1:
        a = a[:, None] if rng.random() < 0.5 else a
    if rng.random() < 0.05 and a.ndim >= 2:  # a huge declared shape, nothing written
        group.create_dataset(name, shape=(31, 100_000, 100_000), dtype="f4", chunks=(1, 64, 64))
        return
    group.create_dataset(name, data=a, **({"compression": "gzip"} if rng.random() < 0.3 and a.ndim and a.size else {}))


def mat73_case(rng):
    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w", userblock_size=512) as f:
        for k, v in _mutated_variables(rng).items():
            _h5_write(f, k, v, rng)
    data = bytearray(buf.getvalue())
    data[:116] = b"MATLAB 7.3 MAT-file".ljust(116)
    return _flip(bytes(data), rng) if rng.random() < 0.4 else bytes(data)


def _zip(members):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buf.getvalue()


def _simg_members(rng):
    from upload_helpers import plane_bytes, simg_header

    h, w, n = 3, 4, 3
    header = simg_header(h, w, n, image_root="p")
    members = {"scene.Simg": header}
    for i in range(n):
        members[f"p{400 + 10 * i}"] = plane_bytes(h, w, 1000 + i)
    return members


def _envi_members(rng):
    h, w, n = 3, 4, 5
    interleave = ["bsq", "bil", "bip"][rng.integers(3)]
    hdr = (f"ENVI\nsamples = {w}\nlines = {h}\nbands = {n}\nheader offset = 0\nfile type = ENVI Standard\n"
           f"data type = 4\ninterleave = {interleave}\nbyte order = 0\n"
           f"wavelength = {{{', '.join(str(400 + 10 * i) for i in range(n))}}}\nwavelength units = nm\n")
    return {"cube.hdr": hdr, "cube.img": np.full(h * w * n, 0.5, "<f4").tobytes()}


def _band_members(rng):
    from PIL import Image

    members = {}
    for i, wl in enumerate((400, 410, 420, 430)):
        buf = io.BytesIO()
        Image.fromarray(np.full((6, 5), 1000 * (i + 1), np.uint16)).save(buf, format="PNG")
        members[f"toy_ms/toy_ms_{i + 1:02d}.png"] = buf.getvalue()
    return members


def zip_case(rng):
    kind = rng.integers(5)
    if kind == 0:
        members = _simg_members(rng)
    elif kind == 1:
        members = _envi_members(rng)
    elif kind == 2:
        members = _band_members(rng)
    elif kind == 3:
        members = {"inner.mat": mat5_case(rng)}
    else:
        from camsim_core.scene import macbeth_scene, save_npz_scene

        with tempfile.TemporaryDirectory() as folder:
            p = Path(folder) / "s.npz"
            save_npz_scene(macbeth_scene(patch_size=2, border=1), p)
            members = {"scene.npz": p.read_bytes()}
    r = rng.random()
    if r < 0.5:  # one member mutated
        names = list(members)
        name = names[rng.integers(len(names))]
        data = members[name]
        data = data.encode("latin-1") if isinstance(data, str) else data
        members[name] = _flip(data, rng)
    elif r < 0.6 and len(members) > 1:  # one member missing
        del members[list(members)[rng.integers(len(members))]]
    elif r < 0.7:
        members[["../evil", "/abs/x", "a\\..\\b", "C:x"][rng.integers(4)]] = b"x"
    data = _zip(members)
    return _flip(data, rng) if r > 0.9 else data


CASES = {"mat5": (mat5_case, "case.mat"), "mat73": (mat73_case, "case.mat"), "zip": (zip_case, "case.zip")}


def check_scene(s):
    """The scene invariants every reader's result keeps."""
    d = np.asarray(s.data)
    assert d.ndim == 3 and min(d.shape) >= 1
    assert np.all(np.isfinite(d)) and d.min() >= 0
    w = np.asarray(s.wavelengths)
    assert np.all(np.isfinite(w)) and np.all(np.diff(w) > 0) and w.min() >= 100 and w.max() <= 20000
    assert np.isfinite(s.distance) and s.distance > 0
    assert all(np.isfinite(a) and a > 0 for a in s.angular_resolution)


def run_case(fmt, data, folder):
    """The outcome of one case, through the upload and (for MATLAB) a path as the CLI reads it."""
    from camsim_core.errors import CamsimError
    from camsim_core.io.upload import load_upload
    from camsim_core.scene import load_scene

    _, name = CASES[fmt]
    calls = [("upload", lambda: load_upload(name, data))]
    if fmt != "zip":
        path = folder / name
        path.write_bytes(data)
        calls.append(("path", lambda: load_scene(str(path))))
    outcomes = []
    for how, call in calls:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                scene = call()
        except CamsimError as exc:
            if name not in str(exc) or "/tmp/camsim-upload" in str(exc):
                return "traceback", f"{how}: message does not name the file or names a server path: {exc}"
            outcomes.append("error")
            continue
        except Exception as exc:  # the signature: type and the innermost frame
            tb = traceback.extract_tb(exc.__traceback__)[-1]
            return "traceback", f"{how}: {type(exc).__name__} at {Path(tb.filename).name}:{tb.lineno}: {str(exc)[:120]}"
        try:
            check_scene(scene)
        except AssertionError:
            return "invalid", f"{how}: a scene that breaks the invariants"
        outcomes.append("loaded")
    return ("loaded" if "loaded" in outcomes else "error"), ""


def fuzz(fmt, count, seed=20261125):
    """``(Counter of outcomes, {signature: count})`` of ``count`` cases of ``fmt`` run in a child process.

    A crash or hang ends the child; it is counted against that case and the
    child is started again from the next case's seed position (the case
    generator is replayed, so case numbers stay the same).
    """
    outcomes, signatures, start = Counter(), Counter(), 0
    # the children write their cases in a folder of the parent's, removed here: a child killed on a crash or a
    # hang removes nothing (a folder made by each child was left in the temporary directory at every run)
    with tempfile.TemporaryDirectory(prefix="camsim-fuzz-") as folder:
        return _fuzz(fmt, count, seed, folder, outcomes, signatures, start)


def _fuzz(fmt, count, seed, folder, outcomes, signatures, start):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(__file__).parent.parent), os.environ.get("PYTHONPATH", "")]))
    while start < count:
        proc = subprocess.Popen([sys.executable, __file__, fmt, str(count), str(seed), str(start), folder],
                                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
        current, last = None, time.monotonic()
        import selectors

        sel = selectors.DefaultSelector()
        sel.register(proc.stdout, selectors.EVENT_READ)
        buf = ""
        done = False
        while not done:
            if not sel.select(timeout=1.0):
                if time.monotonic() - last > HANG_SECONDS:
                    proc.kill()
                    proc.wait()
                    outcomes["hang"] += 1
                    signatures[f"hang in case {current}"] += 1
                    start = (current if current is not None else start) + 1
                    break
                continue
            chunk = os.read(proc.stdout.fileno(), 65536).decode()
            if not chunk:
                rc = proc.wait()
                if current is not None and rc != 0:
                    outcomes["crash"] += 1
                    signatures[f"crash (signal {-rc}) in case {current}"] += 1
                    start = current + 1
                else:
                    start = count
                done = True
                break
            last = time.monotonic()
            buf += chunk
            *lines, buf = buf.split("\n")
            for line in lines:
                if line.startswith("case "):
                    current = int(line[5:])
                elif line.startswith("result "):
                    i, outcome, detail = json.loads(line[7:])
                    outcomes[outcome] += 1
                    if detail:
                        signatures[detail.split(": ", 2)[1] if outcome == "traceback" else detail] += 1
                    current = None
                    start = i + 1
        sel.close()
        proc.stdout.close()
    return outcomes, signatures


if __name__ == "__main__":
    fmt, count, seed, start, folder = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), Path(sys.argv[5])
    sys.path.insert(0, str(Path(__file__).parent))
    rng = np.random.default_rng([seed, FORMATS.index(fmt)])
    make, _ = CASES[fmt]
    for i in range(count):
        try:
            data = make(rng)  # replayed from the seed, so case i is the same in every child
        except Exception:  # a variant the writers themselves refuse: not a case
            data = None
        if i < start:
            continue
        if data is None:
            continue
        print(f"case {i}", flush=True)
        outcome, detail = run_case(fmt, data, folder)
        print("result " + json.dumps([i, outcome, detail]), flush=True)
