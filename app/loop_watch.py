"""A watch on the server's event loop: every stall longer than a threshold is logged, one line each.

The event loop serves every session's page: while one callback runs,
nobody's page gets an answer. :func:`watch_event_loop` schedules a tick
every :data:`TICK_S` seconds and measures how late each tick runs; a tick
late by more than ``threshold_ms`` means a callback held the loop that
long, and the server's log says so (``event loop blocked N ms``), so a
teacher or an operator sees it and a load test can assert there is none.
The longest stall since start is kept in :data:`STALLS`. Each line also
says where the loop was while it was held: while a tick is overdue, a
thread asks the loop's thread every tick, by a signal (``SIGUSR2``), to read
its own stack, and the line names the function seen most often, with the
innermost of the explorer's frames that led to it (``in serialize
(bokeh/core/serialization.py) from _apply (camsim_explorer/state.py)``).

Another thread's stack is not read from outside: walking its frame objects
(``sys._current_frames()``, ``f_back``) on CPython 3.11 can read freed frames
(a frame's ``f_back`` was seen to be a bool, and a test server died;
python/cpython#99110, getsentry/sentry-python#2386); a ``faulthandler`` dump
of every thread is safe but held the GIL 23 ms per look with the server's
45 threads. A signal's handler runs in the loop's thread at its next
bytecode, so it reads the loop's own frames.

Hand-written: asyncio's debug mode logs slow callbacks, but it also slows
every callback and is meant for development, not a served class.
"""

from __future__ import annotations

import gc
import logging
import os
import signal
import threading
import time
from collections import Counter

__all__ = ["watch_event_loop", "watch_garbage_collection", "STALLS", "TICK_S"]

#: How often the loop is looked at, seconds.
TICK_S = 0.02
#: ``{"longest_ms": float, "count": int}`` over the stalls logged since the watch started.
STALLS = {"longest_ms": 0.0, "count": 0}
_LOG = logging.getLogger("camsim.serve")


#: The signal that asks the loop's thread (the main thread) where it is.
SAMPLE_SIGNAL = getattr(signal, "SIGUSR2", None)
#: At most this many places are kept for one stall (50 a second: a stall of over three minutes).
_MAX_SAMPLES = 10_000


def _stack(frame, depth=200):
    """``[(file, function), ...]`` from ``frame`` outwards: for the calling thread's own frames only (another
    thread's frames, walked through ``f_back`` on CPython 3.11, can be freed while they are read)."""
    out = []
    while frame is not None and len(out) < depth:
        out.append((frame.f_code.co_filename, frame.f_code.co_name))
        frame = frame.f_back
    return out


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
    state = {"due": time.monotonic() + TICK_S, "handle": None, "stopped": False, "thread": None, "samples": []}

    def sampled(signum, frame):  # in the loop's thread, at its next bytecode: where it is, read from itself
        samples = state["samples"]
        if len(samples) < _MAX_SAMPLES:
            samples.append((state["due"], _where(_stack(frame))))

    # Where the loop is can only be read safely by the loop's own thread: a signal asks it. Python runs a
    # signal's handler in the main thread, so only a loop there (``camsim serve``'s) says where it stalls.
    main = threading.main_thread()
    asking = (SAMPLE_SIGNAL is not None and threading.current_thread() is main
              and signal.getsignal(SAMPLE_SIGNAL) in (signal.SIG_DFL, None))
    if asking:
        signal.signal(SAMPLE_SIGNAL, sampled)

    def tick():
        now = time.monotonic()
        due, late_ms = state["due"], (now - state["due"]) * 1000.0
        state["thread"] = threading.get_ident()
        # The handler runs in this thread and can interrupt this very function (at any bytecode, or in a
        # garbage collection's callback): it appends to a fresh list while this one is counted, never to
        # the one being read (a shared Counter changed size under ``most_common`` and ended the watch).
        samples, state["samples"] = state["samples"], []
        try:
            if late_ms > threshold_ms:
                STALLS["count"] += 1
                STALLS["longest_ms"] = max(STALLS["longest_ms"], late_ms)
                seen = Counter(where for when, where in samples if when == due)
                where = seen.most_common(1)[0][0] if seen else ""
                log.warning("event loop blocked %.0f ms%s", late_ms, f" {where}" if where else "")
        finally:  # whatever happened above, the watch goes on
            if not state["stopped"]:
                state["due"] = now + TICK_S
                state["handle"] = loop.call_later(TICK_S, tick)

    def look():  # in a thread of its own: asks the loop where it is while a tick is overdue
        while True:
            time.sleep(TICK_S)
            if state["stopped"]:  # looked at after the sleep: ``stop`` may have come during it
                return
            due, thread = state["due"], state["thread"]
            if thread != main.ident or (time.monotonic() - due) * 1000.0 < TICK_S * 1000.0:
                continue
            try:
                signal.pthread_kill(thread, SAMPLE_SIGNAL)
            except (OSError, ValueError):  # the process is ending
                return

    state["handle"] = loop.call_later(TICK_S, tick)
    looking = threading.Thread(target=look, name="camsim-loop-watch", daemon=True)
    if asking:
        looking.start()

    def stop():
        state["stopped"] = True
        if state["handle"] is not None:
            state["handle"].cancel()
        if asking and threading.current_thread() is main:
            # the handler goes only once the thread that signals has ended: a signal sent after the default
            # action is back would end the process
            looking.join()
            signal.signal(SAMPLE_SIGNAL, signal.SIG_DFL)

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
