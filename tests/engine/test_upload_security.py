"""Uploads never reach a file of the server, and bombs are refused quickly and cheaply.

Every file the loader opens is recorded with a ``sys.addaudithook`` hook
(the interpreter's ``open`` audit event, raised by ``open``, ``os.open``
and numpy's file reads); tests assert that nothing outside the upload's
temporary folder and the shipped data was opened, that a sentinel file's
content never appears, and that messages are the same whether a server
path exists or not.
"""

from __future__ import annotations

import os
import sys
import tempfile
import threading
import time
import tracemalloc
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import psutil
import pytest

from camsim_core.datasets import SIMTOOLBOX
from camsim_core.errors import CamsimError, FileFormatError
from camsim_core.io.upload import DEFAULT_LIMITS, UploadLimits, load_upload
from camsim_core.scene import macbeth_scene, read_simg, save_npz_scene
from upload_helpers import npz_declaring, plane_bytes, simg_header, simg_zip, zip_bomb, zip_bytes

_OPENED = []
_RECORD = threading.local()


def _audit(event, args):
    if event == "open" and getattr(_RECORD, "on", False) and args and isinstance(args[0], (str, bytes, os.PathLike)):
        _OPENED.append(os.fsdecode(args[0]))


sys.addaudithook(_audit)


@contextmanager
def opened_files():
    """Paths opened in this thread inside the block (a list filled as files are opened)."""
    _OPENED.clear()
    _RECORD.on = True
    try:
        yield _OPENED
    finally:
        _RECORD.on = False


def _outside(paths):
    """Opened paths that are neither in a camsim upload folder nor in the shipped data."""
    tmp = os.path.realpath(tempfile.gettempdir())
    allowed = [os.path.join(tmp, "camsim-upload-"), os.path.realpath(SIMTOOLBOX)]
    allowed += [os.path.realpath(p) + os.sep for p in {sys.prefix, sys.base_prefix, sys.exec_prefix}]  # imports
    bad = []
    for p in paths:
        if not os.path.isabs(p) and os.sep not in p and p != "..":
            continue  # a name relative to a folder descriptor (shutil.rmtree of the upload's folder)
        real = os.path.realpath(p)
        if any(real.startswith(a) for a in allowed):
            continue
        bad.append(p)
    return bad


@pytest.fixture
def sentinel(tmp_path_factory):
    """A server file outside any upload: a plane-sized file and a camera file, with a recognisable content."""
    folder = Path(tempfile.mkdtemp(prefix="sentinel-", dir=tempfile.gettempdir()))
    secret = b"SECRET"  # 6 bytes... padded to one 1 x 6 plane of 16-bit values
    (folder / "secret_400").write_bytes((secret * 2)[:12])
    (folder / "secret.Scam").write_text("#SimAngularResolution\n##SimX 4242\n##SimY 4242\n##SimEnd\n")
    yield folder
    for f in folder.iterdir():
        f.unlink()
    folder.rmdir()


def _refused(content, name="scene.zip"):
    with opened_files() as opened:
        with pytest.raises(FileFormatError) as info:
            load_upload(name, content)
    msg = str(info.value)
    return msg, list(opened)


def _relative_to_upload(target):
    """A '../' path from an upload's folder (``TMP/camsim-upload-X/upload``) to ``target``."""
    rel = os.path.relpath(target, os.path.join(tempfile.gettempdir(), "camsim-upload-x", "upload"))
    assert rel.startswith("..")
    return rel


def test_image_root_outside_the_upload_is_refused_without_opening_it(sentinel):
    missing = sentinel / "nothing-here_"
    cases = {
        "absolute, existing": str(sentinel / "secret_"),
        "absolute, missing": str(missing),
        "dotdot, existing": _relative_to_upload(sentinel / "secret_"),
        "dotdot, missing": _relative_to_upload(missing),
        "device": "/dev/zer",  # + '400'... any absolute name is refused by its text
    }
    messages = {}
    for label, root in cases.items():
        msg, opened = _refused(simg_zip(simg_header(image_root=root)))
        assert _outside(opened) == [], (label, opened)
        assert not any(str(sentinel) in p for p in opened)
        assert "SECRET" not in msg and str(sentinel) not in msg and "4242" not in msg
        assert msg.startswith("scene.zip:scene.Simg: #SimImageRoot must name a file beside the header")
        messages[label] = msg
    # the same words whether the server path exists or not
    assert messages["absolute, existing"] == messages["absolute, missing"]
    assert messages["dotdot, existing"] == messages["dotdot, missing"]


@pytest.mark.parametrize("camera", ["/dev/zero", "ABS_SENTINEL", "DOTDOT_SENTINEL", "ABS_MISSING"])
def test_camera_file_outside_the_upload_is_refused_without_opening_it(sentinel, camera):
    camera = {
        "ABS_SENTINEL": str(sentinel / "secret.Scam"),
        "DOTDOT_SENTINEL": _relative_to_upload(sentinel / "secret.Scam"),
        "ABS_MISSING": str(sentinel / "missing.Scam"),
    }.get(camera, camera)
    header = simg_header(camera_file=camera)
    t0 = time.monotonic()
    msg, opened = _refused(simg_zip(header, {"400": plane_bytes()}))
    assert time.monotonic() - t0 < 2.0  # /dev/zero is never read
    assert _outside(opened) == [] and "/dev/zero" not in opened
    assert "#SimCameraFile must name a file beside the header" in msg
    assert str(sentinel) not in msg and "/dev" not in msg and "4242" not in msg


def test_camera_file_comes_from_the_upload_or_the_shipped_presets(sentinel):
    plane = {"400": plane_bytes()}
    shipped = load_upload("s.zip", simg_zip(simg_header(), plane))
    assert shipped.angular_resolution == pytest.approx((read_simg(SIMTOOLBOX / "BFGB_128" / "BFGB_128.Simg").angular_resolution))
    own = "#SimAngularResolution\n##SimX 12.5\n##SimY 13.5\n##SimEnd\n"
    mine = load_upload("m.zip", simg_zip(simg_header(camera_file="mine.Scam"), plane, {"mine.Scam": own}))
    assert mine.angular_resolution == (12.5, 13.5)
    assert np.allclose(mine.data, 1000.0)  # the plane's 16-bit value times factor 1
    msg, _ = _refused(simg_zip(simg_header(camera_file="nowhere.Scam"), plane))
    assert "'nowhere.Scam'" in msg and "neither beside the header nor a shipped camera" in msg


def test_fifo_and_device_planes_are_refused_everywhere(tmp_path):
    """A local header whose plane is a FIFO (it would hang a plain read) or a device."""
    (tmp_path / "scene.Simg").write_text(simg_header(image_root="p_"))
    os.mkfifo(tmp_path / "p_400")
    t0 = time.monotonic()
    with pytest.raises(FileFormatError, match="not a regular file"):
        read_simg(tmp_path / "scene.Simg")
    assert time.monotonic() - t0 < 2.0
    (tmp_path / "p_400").unlink()
    os.symlink("/dev/zero", tmp_path / "p_400")  # a link inside the folder pointing out
    with pytest.raises(FileFormatError, match="beside the header"):
        read_simg(tmp_path / "scene.Simg")
    (tmp_path / "cam.Scam").unlink(missing_ok=True)
    os.mkfifo(tmp_path / "cam.Scam")
    (tmp_path / "p_400").unlink()
    (tmp_path / "p_400").write_bytes(plane_bytes())
    (tmp_path / "scene.Simg").write_text(simg_header(image_root="p_", camera_file="cam.Scam"))
    with pytest.raises(FileFormatError, match="not a regular file"):
        read_simg(tmp_path / "scene.Simg")


def test_zip_members_with_absolute_or_dotdot_names_are_refused():
    for member in ("/etc/scene.Simg", "../scene.Simg", "a/../../b", "C:/x.Simg"):
        msg, opened = _refused(zip_bytes({member: "x", "scene.Simg": simg_header()}))
        assert "unsafe path in zip" in msg and _outside(opened) == []


def refused_within(call, seconds=2.0, megabytes=50):
    """Run ``call`` twice: timed alone, then with allocation tracing; assert both bounds; return the numbers.

    Growth is the larger of the traced allocation peak (Python and numpy
    allocations, :mod:`tracemalloc`) and the change of the process's
    resident memory.
    """
    t0 = time.monotonic()
    call()
    took = time.monotonic() - t0
    with bounded(seconds=float("inf"), megabytes=megabytes) as used:
        call()
    used["seconds_untraced"] = took
    print(f"untraced: {took:.3f} s")
    assert took < seconds, used
    return used


@contextmanager
def bounded(seconds=2.0, megabytes=50):
    """Assert the block takes under ``seconds`` and under ``megabytes`` of memory growth.

    Growth is the larger of the traced allocation peak (Python and numpy
    allocations, :mod:`tracemalloc`) and the change of the process's
    resident memory; the numbers measured are yielded for the report.
    """
    proc = psutil.Process()
    rss0 = proc.memory_info().rss
    tracemalloc.start()
    t0 = time.monotonic()
    measured = {}
    try:
        yield measured
    finally:
        measured["seconds"] = time.monotonic() - t0
        measured["traced_peak_mb"] = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        measured["rss_growth_mb"] = (proc.memory_info().rss - rss0) / 2**20
        print(f"\nresource use: {measured}")
    assert measured["seconds"] < seconds, measured
    assert max(measured["traced_peak_mb"], measured["rss_growth_mb"]) < megabytes, measured


def _declare_size(data, name, size):
    """The zip ``data`` with member ``name``'s uncompressed size rewritten to ``size`` (directory and local header)."""
    import struct

    out = bytearray(data)
    pos = out.find(b"PK\x01\x02")
    while pos >= 0:
        n = struct.unpack_from("<H", out, pos + 28)[0]
        if bytes(out[pos + 46: pos + 46 + n]) == name:
            struct.pack_into("<I", out, pos + 24, size)
            local = struct.unpack_from("<I", out, pos + 42)[0]
            struct.pack_into("<I", out, local + 22, size)
        pos = out.find(b"PK\x01\x02", pos + 4)
    return bytes(out)


@pytest.fixture(scope="module")
def bomb():
    """A 1 GiB-uncompressed zip in under 5 MB (four members of 256 MiB of zeros)."""
    return zip_bomb(256 * 2**20, members=4)


def test_zip_bomb_is_refused_from_its_directory(bomb):
    assert len(bomb) < 8 * 2**20  # under the upload cap: only its directory gives it away
    with bounded() as used:
        with pytest.raises(FileFormatError, match="more than the 32 MiB allowed"):
            load_upload("bomb.zip", bomb)
    assert used["seconds"] < 2


def test_zip_declaring_small_sizes_is_still_bounded_while_extracting():
    """A member whose directory entry lies about its size: the bytes actually decompressed are counted."""
    limits = UploadLimits(max_member_bytes=4 * 2**20, max_total_bytes=8 * 2**20)
    header = simg_header(height=1024, width=1024, planes=1)
    data = zip_bytes({"scene.Simg": header, "400": bytes(16 * 2**20)}, zipfile.ZIP_DEFLATED)
    lied = _declare_size(data, b"400", 1000)
    with bounded():
        with pytest.raises(FileFormatError, match="liar.zip: not a readable zip file"):
            load_upload("liar.zip", bytes(lied), limits)


def test_ten_thousand_member_zip_is_refused_quickly():
    content = zip_bytes({f"p/{i}": b"" for i in range(10_000)})

    def call():
        with pytest.raises(FileFormatError, match="10000 members, more than the 512 allowed"):
            load_upload("many.zip", content)

    refused_within(call)


def test_npz_declaring_an_oversized_scene_is_refused_before_allocation():
    content = npz_declaring((4000, 4000, 31))  # would be 3.7 GiB as float64
    assert len(content) < 10_000
    with bounded():
        with pytest.raises(FileFormatError, match=r"4000 x 4000 pixels x 31 planes = 496000000 values, more than the 8000000"):
            load_upload("huge.npz", content)


def test_simg_declaring_an_oversized_scene_is_refused_before_its_planes_are_written():
    header = simg_header(height=20000, width=20000, planes=31)
    with bounded():
        with pytest.raises(FileFormatError, match="more than the 8000000 allowed"):
            load_upload("huge.zip", simg_zip(header))


def test_upload_over_the_size_cap_is_refused_by_its_length():
    limits = UploadLimits(max_upload_bytes=1000)
    with pytest.raises(FileFormatError, match=r"big.npz: is 0.00191 MiB, more than the 0.000954 MiB"):
        load_upload("big.npz", bytes(2000), limits)
    assert DEFAULT_LIMITS.max_upload_bytes < 20 * 2**20  # below Bokeh's websocket message limit


def test_good_uploads_still_load_and_name_the_users_file(tmp_path):
    scene = macbeth_scene(patch_size=4, border=1)
    save_npz_scene(scene, tmp_path / "mine.npz")
    got = load_upload("/home/someone/mine.npz", (tmp_path / "mine.npz").read_bytes())
    assert got.name == "mine" and np.array_equal(got.data, scene.data)
    bad = npz_declaring((2, 3, 4), payload=b"")  # truncated data
    with pytest.raises(CamsimError) as info:
        load_upload("cut.npz", bad)
    assert str(info.value).startswith("cut.npz: ") and tempfile.gettempdir() not in str(info.value)
