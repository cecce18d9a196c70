"""An upload is read in a worker process of its own: a crash, a hang, a CPU or memory bomb costs only that read.

The misbehaving readers in ``isolation_readers`` stand for a compiled
library failing on a crafted file; the real hostile files (the v5 file
whose array class crashed scipy, a v7.3 file whose external storage is a
FIFO) go through the same path. After each, this process is alive and a
good upload still reads.
"""

from __future__ import annotations

import io
import os
import time

import h5py
import numpy as np
import pytest
import scipy.io

import isolation_readers
from camsim_core.errors import FileFormatError
from camsim_core.io.isolated import load_upload_isolated
from camsim_core.io.upload import UploadLimits

FAST = UploadLimits(worker_cpu_seconds=2, worker_wall_seconds=4, worker_memory_bytes=512 * 2**20)
#: For the CPU limit: a niced worker on a loaded machine gets its 2 s of CPU in well over 4 s of wall time.
PATIENT = UploadLimits(worker_cpu_seconds=2, worker_wall_seconds=120, worker_memory_bytes=512 * 2**20)


def _good_npz():
    buf = io.BytesIO()
    np.savez(buf, data=np.full((3, 4, 31), 0.5), wavelengths=np.arange(400.0, 701.0, 10.0), distance=np.float64(2.0))
    return buf.getvalue()


def _still_serving():
    scene = load_upload_isolated("good.npz", _good_npz(), FAST)
    assert scene.shape == (3, 4, 31) and scene.distance == 2.0 and not scene.data.flags.writeable


@pytest.mark.parametrize("reader,expected", [
    (isolation_readers.crash, "the reader stopped \\(SIGSEGV\\)"),
    pytest.param(isolation_readers.spin, "more than 2 s of CPU", id="spin"),
    (isolation_readers.sleep, "took longer than 4 s"),
    (isolation_readers.hog, "needs more than the 512 MiB"),
    (isolation_readers.exits, "stopped without an answer"),
    (isolation_readers.raises, "the reader failed: ZeroDivisionError"),
])
def test_a_misbehaving_read_costs_only_itself(reader, expected):
    t0 = time.monotonic()
    with pytest.raises(FileFormatError, match=f"^bad.mat: .*{expected}"):
        load_upload_isolated("bad.mat", b"x" * 100, PATIENT if reader is isolation_readers.spin else FAST, reader=reader)
    assert time.monotonic() - t0 < 125
    _still_serving()


def test_the_scipy_crasher_and_a_fifo_backed_hdf5_file_are_refused(tmp_path):
    buf = io.BytesIO()
    scipy.io.savemat(buf, {"rad": np.ones((2, 3, 31)), "bands": np.arange(400.0, 701.0, 10.0)})
    data = bytearray(buf.getvalue())
    flags = [i + 8 for i in range(128, len(data) - 16, 8) if data[i:i + 8] == (6).to_bytes(4, "little") + (8).to_bytes(4, "little")]
    data[flags[1]] = 196  # the array class that made scipy's reader segfault
    with pytest.raises(FileFormatError, match="crash.mat: .*array class 196"):
        load_upload_isolated("crash.mat", bytes(data), FAST)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    h5 = io.BytesIO()
    with h5py.File(h5, "w") as f:
        f.create_dataset("rad", shape=(31, 3, 2), dtype="<f8", external=[(str(fifo), 0, 31 * 6 * 8)])
    t0 = time.monotonic()
    with pytest.raises(FileFormatError, match="fifo.mat: .*external files"):
        load_upload_isolated("fifo.mat", h5.getvalue(), FAST)
    assert time.monotonic() - t0 < 4  # refused by the check, not by the wall-time limit
    _still_serving()


def test_the_parent_builds_and_checks_the_scene():
    """What the worker sends is rebuilt as a Scene here: its invariants hold in the trusted process."""
    scene = load_upload_isolated("good.npz", _good_npz(), FAST)
    np.testing.assert_array_equal(scene.data, np.full((3, 4, 31), 0.5))
    assert scene.name == "good" and scene.wavelengths[0] == 400.0


def test_bad_names_and_oversized_uploads_need_no_worker():
    with pytest.raises(FileFormatError, match="NUL or control character"):
        load_upload_isolated("a\x00b.npz", b"x")
    with pytest.raises(FileFormatError, match="more than the"):
        load_upload_isolated("big.npz", b"x" * 2000, UploadLimits(max_upload_bytes=1000))


def test_after_the_warm_up_the_first_upload_imports_nothing_and_starts_no_fork_server():
    """``warm_up`` (called by ``camsim serve`` at start) leaves a first upload nothing to import and no fork
    server to start: 0.25 s of the thread reading it, against 0.035 s for the next, before."""
    import subprocess
    import sys

    script = ("import io, sys, numpy as np, scipy.io\n"
              "from multiprocessing import forkserver\n"
              "from camsim_core.io import isolated\n"
              "isolated.warm_up()\n"
              "modules, server = set(sys.modules), forkserver._forkserver._forkserver_pid\n"
              "buf = io.BytesIO(); scipy.io.savemat(buf, {'rad': np.ones((2, 3, 31)), 'bands': np.arange(400.0, 701.0, 10.0)})\n"
              "isolated.load_upload_isolated('x.mat', buf.getvalue())\n"
              "print(sorted(set(sys.modules) - modules), forkserver._forkserver._forkserver_pid == server)\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[-2] == "[] True", out.stdout
