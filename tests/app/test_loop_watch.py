"""The event-loop watch logs a stall (a turn of the loop longer than the threshold) with its length."""

import asyncio
import logging
import time

from camsim_explorer.loop_watch import STALLS, watch_event_loop, watched_event_loop


def _hold_the_loop(seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end:  # busy, as a computation is (a sleep would show as time.sleep)
        pass


def _run(coroutine):
    """Run ``coroutine`` to its end on a new loop the watch can watch (as ``asyncio.run`` would on its own)."""
    loop = watched_event_loop()
    try:
        return loop.run_until_complete(coroutine)
    finally:
        loop.close()


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
        quiet = _run(main())
    assert STALLS["count"] >= quiet + 1
    assert 150 <= STALLS["longest_ms"] < 5000
    lines = [r.getMessage() for r in caplog.records if "event loop blocked" in r.getMessage()]
    # and where: the function that held it, called from this test
    assert any("in _hold_the_loop (app/test_loop_watch.py)" in line for line in lines), lines


def test_the_place_is_the_innermost_function_and_the_explorers_callback_under_it():
    """Where a stack is: read by the loop's thread from its own frames (a signal asks it); walking another
    thread's frame objects on CPython 3.11 read freed frames (a frame's f_back was a bool, a server died)."""
    import sys

    from camsim_explorer.loop_watch import _stack, _where

    def inner():
        return _stack(sys._getframe())

    stack = inner()
    assert stack[0][1] == "inner" and stack[1][1] == "test_the_place_is_the_innermost_function_and_the_explorers_callback_under_it"
    assert _where([]) == ""
    # an engine's frame held the loop: the explorer's callback that called it is named, not the engine's caller
    engine = [("/srv/camsim_core/scene/scene.py", "__post_init__"), ("/srv/camsim_core/scene/io.py", "load"),
              ("/srv/camsim_explorer/views.py", "update"), ("/usr/lib/python3.11/asyncio/events.py", "_run")]
    assert _where(engine) == "in __post_init__ (scene/scene.py) from update (camsim_explorer/views.py)"


def test_the_watch_leaves_the_signal_as_it_found_it():
    import signal

    from camsim_explorer.loop_watch import SAMPLE_SIGNAL

    async def main():
        stop = watch_event_loop(asyncio.get_running_loop())
        during = signal.getsignal(SAMPLE_SIGNAL)
        await asyncio.sleep(0.05)
        stop()
        return during

    assert _run(main()) not in (signal.SIG_DFL, None)
    assert signal.getsignal(SAMPLE_SIGNAL) == signal.SIG_DFL


def test_a_signal_arriving_while_a_stall_is_counted_neither_breaks_nor_ends_the_watch(caplog, monkeypatch):
    """CI: the handler runs in the loop's thread and can interrupt the tick while it counts the places seen (a
    garbage collection's callback is enough); with one Counter shared by both, ``most_common`` raised
    "dictionary changed size during iteration" in the tick, the server logged a traceback and the watch stopped."""
    import os

    import camsim_explorer.loop_watch as loop_watch

    class Interrupted(loop_watch.Counter):
        def most_common(self, n=None):  # the signal arrives while the places are read
            for _ in self:
                os.kill(os.getpid(), loop_watch.SAMPLE_SIGNAL)
                time.sleep(0.005)  # Python bytecodes: the handler runs here, mid-iteration
            return super().most_common(n)

    monkeypatch.setattr(loop_watch, "Counter", Interrupted)

    async def main():
        stop = watch_event_loop(asyncio.get_running_loop(), threshold_ms=100)
        await asyncio.sleep(0.05)
        _hold_the_loop(0.2)
        await asyncio.sleep(0.1)
        _hold_the_loop(0.2)  # the watch still watches
        await asyncio.sleep(0.1)
        stop()

    with caplog.at_level(logging.WARNING):
        _run(main())
    messages = [r.getMessage() for r in caplog.records]
    assert not [m for m in messages if "Exception in callback" in m], messages
    assert len([m for m in messages if "in _hold_the_loop" in m]) >= 2, messages


def test_a_stall_is_measured_whole_and_a_waiting_loop_is_left_asleep(caplog):
    """The turn's own length, read from the clock: a tick every 20 ms, looked at for how late it ran, read a
    130 ms stall as 110-130 ms, and woke the waiting loop and the watch's thread 100 times a second."""
    import camsim_explorer.loop_watch as loop_watch

    async def main():
        loop = asyncio.get_running_loop()
        stop = watch_event_loop(loop, threshold_ms=100)
        turns = loop_watch._SELECTORS[loop].turns
        await asyncio.sleep(0.05)
        first = turns.turn
        await asyncio.sleep(0.5)  # nothing to do but wait
        idle_turns = turns.turn - first
        asleep = turns.looker_asleep
        _hold_the_loop(0.13)
        await asyncio.sleep(0.05)
        stop()
        return idle_turns, asleep

    with caplog.at_level(logging.WARNING, logger="camsim.serve"):
        idle_turns, asleep = _run(main())
    assert idle_turns <= 3 and asleep, (idle_turns, asleep)
    blocked = [float(r.getMessage().split()[3]) for r in caplog.records if "event loop blocked" in r.getMessage()]
    assert len(blocked) == 1 and 130 <= blocked[0] < 1000, blocked


def test_a_loop_the_watch_cannot_time_is_refused():
    import pytest

    async def main():
        return watch_event_loop(asyncio.get_running_loop())

    with pytest.raises(ValueError, match="watched_event_loop"):
        asyncio.run(main())
