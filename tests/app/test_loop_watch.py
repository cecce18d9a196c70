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


def test_the_place_is_read_from_a_dump_of_every_thread_without_frame_objects():
    """The loop's stack comes from a faulthandler dump, parsed: walking another thread's frame objects
    (``f_back``) read freed frames on CPython 3.11 (a frame's f_back was seen to be a bool, and a test server
    died)."""
    from camsim_explorer.loop_watch import _stack_of, _where

    dump = (
        "Thread 0x00007f0000000002 (most recent call first):\n"
        '  File "/usr/lib/python3.11/threading.py", line 320 in wait\n'
        '  File "/srv/app/state.py", line 88 in submit\n\n'
        "Current thread 0x00007f0000000001 (most recent call first):\n"
        '  File "/srv/app/loop_watch.py", line 9 in look\n'
    )
    stack = _stack_of(0x7F0000000002, dump)
    assert stack == [("/usr/lib/python3.11/threading.py", "wait"), ("/srv/app/state.py", "submit")]
    assert _where(stack) == "in wait (python3.11/threading.py) from submit (app/state.py)"
    assert _stack_of(0x7F0000000003, dump) == [] and _where([]) == ""
    # an engine's frame held the loop: the explorer's callback that called it is named, not the engine's caller
    engine = [("/srv/camsim_core/scene/scene.py", "__post_init__"), ("/srv/camsim_core/scene/io.py", "load"),
              ("/srv/camsim_explorer/views.py", "update"), ("/usr/lib/python3.11/asyncio/events.py", "_run")]
    assert _where(engine) == "in __post_init__ (scene/scene.py) from update (camsim_explorer/views.py)"

