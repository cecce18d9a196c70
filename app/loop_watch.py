"""A watch on the server's event loop: every stall longer than a threshold is logged, one line each.

The event loop serves every session's page: while one callback runs,
nobody's page gets an answer. :func:`watch_event_loop` schedules a tick
every :data:`TICK_S` seconds and measures how late each tick runs; a tick
late by more than ``threshold_ms`` means a callback held the loop that
long, and the server's log says so (``event loop blocked N ms``), so a
teacher or an operator sees it and a load test can assert there is none.
The longest stall since start is kept in :data:`STALLS`. Each line also
says where the loop was while it was held: a thread looks at the loop's
stack (``sys._current_frames``) every tick while a tick is overdue, and the
line names the function seen most often, with the innermost of camsim's own
frames that led to it (``in serialize (bokeh/core/serialization.py) from
_apply (camsim_explorer/state.py)``).

Hand-written: asyncio's debug mode logs slow callbacks, but it also slows
every callback and is meant for development, not a served class.
"""

from __future__ import annotations

import gc
import logging
import os
import sys
import threading
import time
from collections import Counter

__all__ = ["watch_event_loop", "watch_garbage_collection", "STALLS", "TICK_S"]

#: How often the loop is looked at, seconds.
TICK_S = 0.02
#: ``{"longest_ms": float, "count": int}`` over the stalls logged since the watch started.
STALLS = {"longest_ms": 0.0, "count": 0}
_LOG = logging.getLogger("camsim.serve")


def _where(frame):
    """Where a stack is: its innermost function, and the innermost of camsim's own frames under it; "" when
    the stack cannot be read (another thread's frames change while they are read: a frame's ``f_back`` was
    once seen to be a bool)."""
    try:
        return _describe(frame)
    except Exception:
        return ""


def _describe(frame):
    if frame is None:
        return ""
    inner, ours = frame, None
    f = frame
    for _ in range(200):  # deep enough for any of the server's stacks; never a loop
        if f is None:
            break
        name = f.f_code.co_filename
        if ours is None and ("camsim_explorer" in name or "camsim_core" in name
                             or f"{os.sep}app{os.sep}" in name):
            ours = f
        f = f.f_back

    def label(fr):
        path = fr.f_code.co_filename.replace(os.sep, "/").split("/")
        return f"{fr.f_code.co_name} ({'/'.join(path[-2:])})"

    text = f"in {label(inner)}"
    if ours is not None and ours is not inner:
        text += f" from {label(ours)}"
    return text


def watch_event_loop(loop, threshold_ms=100.0, log=_LOG):
    """Start watching ``loop`` (an asyncio loop); returns a function that stops the watch.

    Parameters
    ----------
    loop : asyncio.AbstractEventLoop
        The loop, running (the watch's ticks are scheduled on it).
    threshold_ms : float
        A tick later than this, in milliseconds, is a stall: logged, with where the loop was.
    log : logging.Logger
        Where the stalls go (``camsim.serve``).

    Returns
    -------
    callable
        Stops the watch (and its thread).

    Examples
    --------
    >>> import asyncio
    >>> async def main():
    ...     stop = watch_event_loop(asyncio.get_running_loop())
    ...     await asyncio.sleep(0.05)
    ...     stop()
    >>> asyncio.run(main())
    """
    state = {"due": time.monotonic() + TICK_S, "handle": None, "stopped": False, "thread": None,
             "seen": Counter(), "seen_for": None}
    lock = threading.Lock()

    def tick():
        now = time.monotonic()
        late_ms = (now - state["due"]) * 1000.0
        state["thread"] = threading.get_ident()
        if late_ms > threshold_ms:
            STALLS["count"] += 1
            STALLS["longest_ms"] = max(STALLS["longest_ms"], late_ms)
            with lock:
                seen = state["seen"] if state["seen_for"] == state["due"] else Counter()
            where = seen.most_common(1)[0][0] if seen else ""
            log.warning("event loop blocked %.0f ms%s", late_ms, f" {where}" if where else "")
        if not state["stopped"]:
            state["due"] = now + TICK_S
            state["handle"] = loop.call_later(TICK_S, tick)

    def look():  # in a thread of its own: the loop's stack while a tick is overdue
        while not state["stopped"]:
            time.sleep(TICK_S)
            due, thread = state["due"], state["thread"]
            if thread is None or (time.monotonic() - due) * 1000.0 < TICK_S * 1000.0:
                continue
            where = _where(sys._current_frames().get(thread))
            with lock:
                if state["seen_for"] != due:
                    state["seen"], state["seen_for"] = Counter(), due
                state["seen"][where] += 1

    state["handle"] = loop.call_later(TICK_S, tick)
    threading.Thread(target=look, name="camsim-loop-watch", daemon=True).start()

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
