"""MATLAB v7.3 (HDF5) files that name other files are refused before any of those files is opened.

Each construct HDF5 offers for reaching outside a file (external storage,
an external link, a virtual dataset) points at a **FIFO** sentinel. A
blocking open of a FIFO waits for a writer, so a watcher thread that can
open the FIFO for writing (non-blocking: it fails with ENXIO while no
reader has it open) proves that something opened the sentinel, and never
misses a brief open. A soft-link loop, a user-defined filter (a plugin
id) and the same constructs nested in an ISETCam ``scene`` struct are
refused too. Every path a user reaches is tried: an upload (bytes), a path
given to ``load_scene`` (the CLI) and ``read_mat``. Messages must name the
user's file and no path of the server.
"""

from __future__ import annotations

import errno
import io
import os
import threading
import time
from contextlib import contextmanager

import h5py
import numpy as np
import pytest

import camsim_core as cs
from camsim_core.errors import CamsimError
from camsim_core.io.upload import load_upload
from camsim_core.scene.matlab import read_mat

SHAPE = (31, 5, 4)  # MATLAB's (H, W, N) = (4, 5, 31) as HDF5 stores it
NBYTES = int(np.prod(SHAPE)) * 8


@contextmanager
def fifo_watch(path):
    """Replace ``path`` with a FIFO; yield a list that gets an entry whenever anything opens it for reading."""
    if os.path.lexists(path):
        os.unlink(path)
    os.mkfifo(path)
    opened, stop = [], threading.Event()

    def watch():
        while not stop.is_set():
            try:
                fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
            except OSError as exc:
                assert exc.errno == errno.ENXIO, exc
                time.sleep(0.0005)
                continue
            opened.append(time.monotonic())
            os.close(fd)  # the reader sees end of file and goes on

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    try:
        yield opened
    finally:
        stop.set()
        t.join(5)


def _bands(f):
    f["bands"] = np.arange(400.0, 701.0, 10.0)[:, None]


def external_storage(f, target, where="rad"):
    f.create_dataset(where, shape=SHAPE, dtype="<f8", external=[(str(target), 0, NBYTES)])


def external_link(f, target, where="rad"):
    f[where] = h5py.ExternalLink(str(target), "/rad")


def virtual_dataset(f, target, where="rad"):
    layout = h5py.VirtualLayout(shape=SHAPE, dtype="<f8")
    layout[...] = h5py.VirtualSource(str(target), "rad", shape=SHAPE)
    f.create_virtual_dataset(where, layout)


def soft_link_loop(f, target, where="rad"):
    parent = where.rsplit("/", 1)[0] if "/" in where else ""
    f[where] = h5py.SoftLink(f"/{parent}/loop_a" if parent else "/loop_a")
    f[f"{parent}/loop_a" if parent else "loop_a"] = h5py.SoftLink(f"/{where}")


def plugin_filter(f, target, where="rad"):
    from h5py import h5d, h5p, h5s, h5t, h5z

    dcpl = h5p.create(h5p.DATASET_CREATE)
    dcpl.set_chunk(SHAPE)
    dcpl.set_filter(32_004, h5z.FLAG_OPTIONAL)  # a registered plugin id (LZ4) that is not built in
    parent = f.require_group(where.rsplit("/", 1)[0]) if "/" in where else f
    h5d.create(parent.id, where.rsplit("/", 1)[-1].encode(), h5t.IEEE_F64LE, h5s.create_simple(SHAPE), dcpl=dcpl)


CONSTRUCTS = {"external storage": external_storage, "external link": external_link,
              "virtual dataset": virtual_dataset, "soft-link loop": soft_link_loop, "plugin filter": plugin_filter}
EXPECTED = {"external storage": "external files", "external link": "external link", "virtual dataset": "virtual dataset",
            "soft-link loop": "soft link", "plugin filter": "filter 32004"}


def _file_bytes(construct, target, nested):
    buf = io.BytesIO()
    with h5py.File(buf, "w", userblock_size=512) as f:
        if nested:  # an ISETCam scene struct, the construct three groups down
            f["scene/spectrum/wave"] = np.arange(400.0, 701.0, 10.0)[:, None]
            CONSTRUCTS[construct](f, target, "scene/data/photons")
        else:
            _bands(f)
            CONSTRUCTS[construct](f, target)
    data = bytearray(buf.getvalue())
    data[:116] = b"MATLAB 7.3 MAT-file".ljust(116)  # as MATLAB writes its userblock
    return bytes(data)


@pytest.fixture
def sentinel(tmp_path):
    """A file elsewhere on the server, with a password file's first bytes and the size the dataset needs."""
    folder = tmp_path / "server"
    folder.mkdir()
    path = folder / "secret"
    path.write_bytes((b"root:x:0:0:root:/root:/bin/bash\n" * (NBYTES // 32 + 1))[:NBYTES])
    return path


def _no_server_path(message, *paths):
    for p in paths:
        assert str(p) not in message, message
        assert os.path.basename(str(p)) != "secret" or "secret" not in message, message


@pytest.mark.parametrize("nested", [False, True], ids=["top", "nested"])
@pytest.mark.parametrize("construct", list(CONSTRUCTS))
def test_hdf5_reaching_outside_is_refused_without_opening_the_target(construct, nested, sentinel, tmp_path):
    content = _file_bytes(construct, sentinel, nested)
    on_disk = tmp_path / "user" / "scene.mat"
    on_disk.parent.mkdir()
    on_disk.write_bytes(content)
    with fifo_watch(sentinel) as opened:
        calls = {"upload": lambda: load_upload("scene.mat", content),
                 "load_scene": lambda: cs.load_scene(str(on_disk)),
                 "read_mat": lambda: read_mat(on_disk)}
        for how, call in calls.items():
            with pytest.raises(CamsimError) as info:
                call()
            message = str(info.value)
            assert EXPECTED[construct] in message, f"{how}: {message}"
            assert "scene.mat" in message, f"{how}: {message}"
            _no_server_path(message, sentinel, sentinel.parent)
            if how == "upload":
                assert "/" not in message.split(":", 1)[0] and "/tmp" not in message and "/server" not in message
        time.sleep(0.01)  # one more look by the watcher
    assert opened == [], f"{construct}: the sentinel was opened {len(opened)} time(s)"


def test_the_watcher_sees_an_open(sentinel):
    """The FIFO watcher itself: a reader that opens the sentinel is seen (so the test above can fail)."""
    with fifo_watch(sentinel) as opened:
        with open(sentinel, "rb") as f:  # blocks until the watcher opens the writing end
            f.read()
        deadline = time.monotonic() + 5
        while not opened and time.monotonic() < deadline:
            time.sleep(0.001)
    assert opened


def test_h5py_itself_would_read_the_sentinel(sentinel):
    """Without the checks, h5py reads the external file's bytes: the refusal above is what protects the server."""
    content = _file_bytes("external storage", sentinel, nested=False)
    with h5py.File(io.BytesIO(content), "r") as f:
        values = f["rad"][()]
    assert values.tobytes()[:6] == b"root:x"


def test_a_plain_v73_scene_still_loads():
    buf = io.BytesIO()
    with h5py.File(buf, "w", userblock_size=512) as f:
        f["rad"] = np.ones(SHAPE)
        _bands(f)
    scene = load_upload("plain.mat", buf.getvalue())
    assert scene.shape == (4, 5, 31)
