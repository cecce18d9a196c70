"""Inputs through widgets, files and URLs are bounded, each refusal with a message; the server's
websocket origins are the printed host's, never '*'."""

import json
import time

import pytest

from camsim_explorer import state as state_module
from camsim_explorer.main import _long_url_values
from camsim_explorer.state import ExplorerState, json_depth, parse_numbers, parse_tile
from camsim_explorer.serve import allowed_origins, public_host
from camsim_core.errors import CamsimError, ParameterError


def test_many_gaussian_centres_are_refused():
    with pytest.raises(ParameterError, match="at most 16 sensors"):
        parse_numbers(", ".join(str(400 + i) for i in range(17)), "gaussian_centers")
    assert len(parse_numbers(", ".join(str(400 + i) for i in range(16)), "gaussian_centers")) == 16
    with pytest.raises(CamsimError):
        parse_numbers("1e999, 500", "gaussian_centers")


def test_large_custom_tiles_and_long_text_are_refused():
    with pytest.raises(ParameterError, match="at most 8 x 8"):
        parse_tile("; ".join(" ".join("0" for _ in range(9)) for _ in range(9)))
    with pytest.raises(ParameterError, match="characters"):
        parse_tile("0 " * 1000)
    assert parse_tile("1 0; 2 1").shape == (2, 2)


def test_json_depth_is_measured_without_recursion():
    deep = "[" * 100_000 + "]" * 100_000
    t0 = time.monotonic()
    assert json_depth(deep) == 100_000
    assert time.monotonic() - t0 < 2.0
    assert json_depth('{"a": "[[[[", "b": [1, [2]]}') == 3  # brackets inside strings do not count


@pytest.fixture(scope="module")
def state():
    return ExplorerState()


def test_deep_or_large_parameter_files_get_a_message(state):
    assert not state.from_json("[" * 10_000 + "]" * 10_000)  # 20 kB, nested 10,000 deep
    assert "nested deeper than 4 levels" in state.message
    assert not state.from_json(json.dumps({"seed": 1, "pad": "x" * 100_000}))
    assert "larger than" in state.message
    assert not state.from_json(json.dumps({"gaussian_centers": "5" * 5000}))
    assert "at most 256 characters" in state.message


def test_long_url_values_are_named_and_ignored():
    assert _long_url_values("?seed=" + "9" * 5000 + "&noise_sigma=2") == ["seed"]
    assert _long_url_values("?seed=3&noise_sigma=2") == []


def test_origins_for_a_class_are_the_printed_host_never_a_wildcard():
    origins = allowed_origins("0.0.0.0", 5006, ["review.example.org"])
    assert "*" not in " ".join(origins)
    assert f"{public_host('0.0.0.0')}:5006" in origins and "review.example.org:5006" in origins
    assert set(allowed_origins("127.0.0.1", 5006)) == {"localhost:5006", "127.0.0.1:5006", "[::1]:5006"}
    with pytest.raises(ParameterError, match="without wildcards"):
        allowed_origins("0.0.0.0", 5006, ["*"])


def test_server_limits_are_the_documented_defaults():
    lim = state_module.ServerLimits()
    assert (lim.max_sensors, lim.max_tile, lim.max_text, lim.max_json_bytes, lim.max_json_depth) == (16, 8, 256, 65536, 4)
    assert lim.upload.max_upload_bytes == 16 * 2**20 and lim.upload.max_scene_values == 8_000_000


class _Cycle:
    def __init__(self):
        self.me = self


def test_closed_sessions_cycles_are_collected_and_the_heaps_trimmed_once_the_closes_stop():
    """The release hook of ``camsim serve``: a burst of closes gives one full collection (objects held
    only by reference cycles are freed) and one heap trim, once no close came for the quiet time."""
    import asyncio
    import gc
    import weakref

    from tornado.ioloop import IOLoop

    from camsim_explorer.serve import _collect_and_trim_once_quiet

    trims = []

    class Libc:
        def malloc_trim(self, pad):
            trims.append(pad)

    loop = IOLoop(make_current=False)
    gc.disable()  # no automatic collection may free the cycle first
    try:
        garbage = _Cycle()
        gone = weakref.ref(garbage)
        del garbage
        seen = {}

        async def closes():
            hook = _collect_and_trim_once_quiet(Libc(), quiet_s=0.1)
            for _ in range(3):  # three sessions released 30 ms apart: one collection, after the last
                hook()
                await asyncio.sleep(0.03)
            seen["before"] = (len(trims), gone() is None)
            await asyncio.sleep(0.3)

        loop.run_sync(closes)
    finally:
        loop.close()
        gc.enable()
    assert seen["before"] == (0, False)  # nothing while sessions are still closing
    assert trims == [0] and gone() is None


def test_startup_objects_are_frozen_after_garbage_is_collected():
    """``camsim serve`` freezes what start-up made (later collections skip it), collecting first: garbage
    present at that moment is freed, not frozen for the life of the server."""
    import gc
    import weakref

    from camsim_explorer.serve import _freeze_startup_objects

    gc.disable()  # no automatic collection may free the cycle first
    garbage = _Cycle()
    gone = weakref.ref(garbage)
    del garbage
    try:
        assert gone() is not None
        _freeze_startup_objects()
        assert gone() is None
        assert gc.get_freeze_count() > 0
    finally:
        gc.unfreeze()
        gc.enable()


def test_a_write_to_a_closed_page_is_one_log_line_and_other_errors_reach_asyncio(caplog):
    from tornado.iostream import StreamClosedError
    from tornado.websocket import WebSocketClosedError

    from camsim_explorer.serve import closed_page_exception_handler

    class Loop:
        def __init__(self):
            self.passed_on = []

        def default_exception_handler(self, context):
            self.passed_on.append(context)

    loop = Loop()
    with caplog.at_level("INFO", logger="camsim.explorer"):
        for exc in (WebSocketClosedError(), StreamClosedError()):
            closed_page_exception_handler(loop, {"message": "Task exception was never retrieved", "exception": exc})
    assert loop.passed_on == []
    assert caplog.text.count("a message to a closed page was dropped") == 2
    other = {"message": "Task exception was never retrieved", "exception": ValueError("a real bug")}
    closed_page_exception_handler(loop, other)
    closed_page_exception_handler(loop, {"message": "no exception at all"})
    assert loop.passed_on == [other, {"message": "no exception at all"}]


def test_the_server_logs_a_write_to_a_closed_page_in_one_line():
    """The handler above, on the loop the server runs: installed through Tornado's current loop before the server
    made its own, it went to a loop that never ran, and a tab closed mid-update put a traceback in the log."""
    from pathlib import Path

    from app_helpers import ARTIFACTS, explorer_server, server_log, wait_until

    ARTIFACTS.mkdir(exist_ok=True)
    launcher = Path(__file__).resolve().parents[1] / "serve_closed_page_write.py"
    with explorer_server(launcher=launcher, extra_args=["--no-spare-page", "--no-upload"]) as url:
        log = wait_until(lambda: (text := server_log(url)) and ("closed page was dropped" in text
                                                                 or "never retrieved" in text) and text,
                         what="the server's log says what became of the write to a closed page")
    assert "a message to a closed page was dropped" in log, log[-2000:]
    assert "Traceback" not in log and "never retrieved" not in log, log[-2000:]


def test_sigterm_stops_the_server_with_status_0_and_leaves_nothing_in_the_temporary_directory():
    """A service manager stops a server with SIGTERM (``systemctl stop``, ``docker stop``). Killed by the signal's
    default action the server exited with status -15 and its upload readers' fork server left its folder (a
    ``pymp-*`` folder with a socket) in the temporary directory at every stop."""
    import shutil
    import tempfile
    from pathlib import Path

    # a short path: the fork server's socket lives there, and a socket's path is at most 107 bytes (pytest's
    # tmp_path under a worker of pytest-xdist is longer: "AF_UNIX path too long")
    tmp = Path(tempfile.mkdtemp(prefix="camsim-sigterm-", dir="/tmp"))
    try:
        _stop_with_sigterm(tmp)
    finally:
        shutil.rmtree(tmp)


def _stop_with_sigterm(tmp):
    import os
    import signal
    import subprocess
    import sys

    from app_helpers import ROOT, free_port, wait_until

    port = free_port()
    env = dict(os.environ, TMPDIR=str(tmp), PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               OPENBLAS_NUM_THREADS="1", BOKEH_LOG_LEVEL="warn")
    proc = subprocess.Popen([sys.executable, "-m", "camsim_core.cli", "serve", "--port", str(port), "--address",
                             "127.0.0.1", "--no-spare-page"], cwd=tmp, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        wait_until(lambda: proc.poll() is not None or any(p.name.startswith("pymp-") for p in tmp.iterdir()),
                   what="the upload readers' fork server made its folder")
        assert proc.poll() is None, proc.communicate()[0]
        wait_until(lambda: proc.poll() is not None or _answers(port), what="the server answers")
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, out[-2000:]
    assert "camsim explorer stopped" in out and "Traceback" not in out, out[-2000:]
    assert list(tmp.iterdir()) == [], out[-2000:]


def _answers(port):
    import socket

    try:
        with socket.create_connection(("127.0.0.1", port), timeout=2):
            return True
    except OSError:
        return False


def test_a_temporary_directory_too_long_for_the_upload_readers_socket_is_named():
    """The upload readers' fork server listens on a socket in the temporary directory, whose path is at most
    107 bytes: with a longer TMPDIR ``camsim serve`` said only "OSError: AF_UNIX path too long"."""
    import os
    import shutil
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    from app_helpers import ROOT, free_port

    tmp = Path(tempfile.mkdtemp(prefix="camsim-long-", dir="/tmp"))
    deep = tmp / ("d" * 100)
    deep.mkdir()
    env = dict(os.environ, TMPDIR=str(deep), PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               OPENBLAS_NUM_THREADS="1", BOKEH_LOG_LEVEL="warn")
    try:
        run = subprocess.run([sys.executable, "-m", "camsim_core.cli", "serve", "--port", str(free_port()),
                              "--address", "127.0.0.1", "--no-spare-page"], cwd=tmp, env=env, capture_output=True,
                             text=True, timeout=120)
        left = list(deep.iterdir())
    finally:
        shutil.rmtree(tmp)
    assert run.returncode == 2, run.stdout + run.stderr
    assert "camsim serve: error: TMPDIR: " in run.stderr and "--no-upload" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr + run.stdout and left == []
