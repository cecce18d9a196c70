"""The event-loop watch logs a stall (how late its tick ran) with its length."""

import asyncio
import logging
import time

from camsim_explorer.loop_watch import STALLS, watch_event_loop


def _hold_the_loop(seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:  # busy, as a computation is (a sleep would show as time.sleep)
        pass


def test_a_blocked_loop_is_logged_and_a_free_one_is_not(caplog):
    async def main():
        loop = asyncio.get_running_loop()
        stop = watch_event_loop(loop, threshold_ms=100)
        await asyncio.sleep(0.1)
        quiet = STALLS["count"]
        _hold_the_loop(0.25)  # a callback holding the loop for 250 ms
        await asyncio.sleep(0.1)
        stop()
        return quiet

    before = STALLS["count"]
    with caplog.at_level(logging.WARNING, logger="camsim.serve"):
        quiet = asyncio.run(main())
    assert STALLS["count"] >= quiet + 1
    assert 150 <= STALLS["longest_ms"] < 5000
    lines = [r.getMessage() for r in caplog.records if "event loop blocked" in r.getMessage()]
    # and where: the function that held it, called from this test
    assert any("in _hold_the_loop (app/test_loop_watch.py)" in line for line in lines), lines


def test_a_stack_that_cannot_be_read_gives_no_place_and_no_exception():
    """Another thread's frames change while the watch reads them (a frame's f_back was seen to be a bool, and
    the watch's thread died with a traceback in the server's log)."""
    from camsim_explorer.loop_watch import _where

    class Broken:
        f_code = type("Code", (), {"co_filename": "x.py", "co_name": "f"})()
        f_back = True

    assert _where(Broken()) == ""
