"""A watch on the server's event loop: every stall longer than a threshold is logged, one line each.

The event loop serves every session's page: while one callback runs,
nobody's page gets an answer. :func:`watch_event_loop` schedules a tick
every :data:`TICK_S` seconds and measures how late each tick runs; a tick
late by more than ``threshold_ms`` means a callback held the loop that
long, and the server's log says so (``event loop blocked N ms``), so a
teacher or an operator sees it and a load test can assert there is none.
The longest stall since start is kept in :data:`STALLS`.

Hand-written: asyncio's debug mode logs slow callbacks, but it also slows
every callback and is meant for development, not a served class.
"""

from __future__ import annotations

import gc
import logging
import time

__all__ = ["watch_event_loop", "watch_garbage_collection", "STALLS", "TICK_S"]

#: How often the loop is looked at, seconds.
TICK_S = 0.02
#: ``{"longest_ms": float, "count": int}`` over the stalls logged since the watch started.
STALLS = {"longest_ms": 0.0, "count": 0}
_LOG = logging.getLogger("camsim.serve")


def watch_event_loop(loop, threshold_ms=100.0, log=_LOG):
    """Start watching ``loop`` (an asyncio loop); returns a function that stops the watch."""
    state = {"due": time.monotonic() + TICK_S, "handle": None, "stopped": False}

    def tick():
        now = time.monotonic()
        late_ms = (now - state["due"]) * 1000.0
        if late_ms > threshold_ms:
            STALLS["count"] += 1
            STALLS["longest_ms"] = max(STALLS["longest_ms"], late_ms)
            log.warning("event loop blocked %.0f ms", late_ms)
        if not state["stopped"]:
            state["due"] = now + TICK_S
            state["handle"] = loop.call_later(TICK_S, tick)

    state["handle"] = loop.call_later(TICK_S, tick)

    def stop():
        state["stopped"] = True
        if state["handle"] is not None:
            state["handle"].cancel()

    return stop


def watch_garbage_collection(threshold_ms=100.0, log=_LOG):
    """Log every garbage collection longer than ``threshold_ms`` (it holds every thread, the loop's too: with
    ten sessions open a full collection took 60-180 ms); returns a function that stops the watch."""
    started = [0.0]

    def on_gc(phase, info):
        if phase == "start":
            started[0] = time.perf_counter()
            return
        took = 1000.0 * (time.perf_counter() - started[0])
        if took > threshold_ms:
            log.warning("garbage collection (generation %d, %d objects freed) took %.0f ms",
                        info["generation"], info["collected"], took)

    gc.callbacks.append(on_gc)
    return lambda: gc.callbacks.remove(on_gc)
