"""A watch on the server's event loop: every stall longer than a threshold is logged, one line each.

The event loop serves every session's page: while one callback runs,
nobody's page gets an answer. :func:`watch_event_loop` schedules a tick
every :data:`TICK_S` seconds and measures how late each tick runs; a tick
late by more than ``threshold_ms`` means a callback held the loop that
long, and the server's log says so (``event loop blocked N ms``), so a
teacher or an operator sees it and a load test can assert there is none.
The longest stall since start is kept in :data:`STALLS`. Each line also
says where the loop was while it was held: a thread looks at the loop's
stack (a ``faulthandler`` dump) every tick while a tick is overdue, and the
line names the function seen most often, with the innermost of camsim's own
frames that led to it (``in serialize (bokeh/core/serialization.py) from
_apply (camsim_explorer/state.py)``).

Hand-written: asyncio's debug mode logs slow callbacks, but it also slows
every callback and is meant for development, not a served class.
"""

from __future__ import annotations

import faulthandler
import gc
import logging
import os
import re
import tempfile
import threading
import time
from collections import Counter

__all__ = ["watch_event_loop", "watch_garbage_collection", "STALLS", "TICK_S"]

#: How often the loop is looked at, seconds.
TICK_S = 0.02
#: ``{"longest_ms": float, "count": int}`` over the stalls logged since the watch started.
STALLS = {"longest_ms": 0.0, "count": 0}
_LOG = logging.getLogger("camsim.serve")


_THREAD = re.compile(r"^(?:Current thread|Thread) (0x[0-9a-f]+)", re.M)
_FRAME = re.compile(r'^  File "(.*)", line \d+ in (.*)$', re.M)


def _stack_of(thread_id, dump):
    """The frames of one thread in a ``faulthandler`` dump of all threads, innermost first, as
    ``(file, function)`` pairs; ``[]`` when the thread is not in it."""
    parts = _THREAD.split(dump)  # ["", id, block, id, block, ...]
    for ident, block in zip(parts[1::2], parts[2::2]):
        if int(ident, 16) == thread_id:
            return _FRAME.findall(block)
    return []


def _where(stack):
    """Where a stack is: its innermost function, and the innermost of the explorer's frames under it (of the
    engine's when the explorer has none; "" for an empty stack). ``stack`` is ``[(file, function), ...]``,
    innermost first."""
    if not stack:
        return ""

    def app(path):  # the explorer's frames name the callback that held the loop; the engine's say less
        return "camsim_explorer" in path or f"{os.sep}app{os.sep}" in path

    def ours(path):
        return app(path) or "camsim_core" in path

    def label(frame):
        path, func = frame
        return f"{func} ({'/'.join(path.replace(os.sep, '/').split('/')[-2:])})"

    inner = stack[0]
    own = next((f for f in stack[1:] if app(f[0])), None) or next((f for f in stack[1:] if ours(f[0])), None)
    text = f"in {label(inner)}"
    if own is not None:
        text += f" from {label(own)}"
    return text


def _loop_stack(thread_id, scratch):
    """The loop thread's stack, read by ``faulthandler`` into the file ``scratch``.

    Not ``sys._current_frames()``: walking another thread's frame objects
    (``f_back``) on CPython 3.11 reads freed frames (a frame's ``f_back`` was
    seen to be a bool, and a test server died; python/cpython#99110 and
    getsentry/sentry-python#2386 report the same crash in 3.11.5).
    ``faulthandler`` reads the interpreter's own frame chain, holding the GIL,
    and makes no frame objects.
    """
    scratch.seek(0)
    scratch.truncate()
    faulthandler.dump_traceback(scratch, all_threads=True)
    scratch.seek(0)
    return _stack_of(thread_id, scratch.read().decode("ascii", "replace"))


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
        scratch = tempfile.TemporaryFile()
        while not state["stopped"]:
            time.sleep(TICK_S)
            due, thread = state["due"], state["thread"]
            if thread is None or (time.monotonic() - due) * 1000.0 < TICK_S * 1000.0:
                continue
            where = _where(_loop_stack(thread, scratch))
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
