"""A watch on the server's event loop: every stall longer than a threshold is logged, one line each.

The event loop serves every session's page: while one callback runs,
nobody's page gets an answer. The loop is made by :func:`watched_event_loop`
(asyncio's own loop over a selector that notes the time each time the loop
stops waiting and each time it waits again), so :func:`watch_event_loop`
knows how long every turn of the loop worked between two waits: a turn
longer than ``threshold_ms`` means its callbacks held the loop that long,
and the server's log says so (``event loop blocked N ms``), so a teacher or
an operator sees it and a load test can assert there is none. The longest
stall since start is kept in :data:`STALLS`. Each line also says where the
loop was while it was held: while a turn lasts longer than :data:`TICK_S`,
a thread asks the loop's thread every :data:`TICK_S`, by a signal
(``SIGUSR2``), to read its own stack, and the line names the function seen
most often, with the innermost of the explorer's frames that led to it
(``in serialize (bokeh/core/serialization.py) from _apply
(camsim_explorer/state.py)``).

A turn's length is read from the clock, not from a tick scheduled on the loop
(how late it runs): a tick every 20 ms woke an idle server 100 times a
second (the tick and the thread that looks), 1.2 % of a core for a server
nobody used, and read a stall up to one tick short. The thread that looks
now sleeps while the loop waits.

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

import asyncio
import gc
import logging
import os
import selectors
import signal
import threading
import time
import weakref
from collections import Counter

__all__ = ["watched_event_loop", "watch_event_loop", "watch_garbage_collection", "STALLS", "TICK_S"]

#: How often the loop's stack is read while a turn of the loop lasts, seconds.
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


class _TimedSelector(selectors.DefaultSelector):
    """The platform's selector, telling a watch (``turns``) when the loop stops waiting and when it waits again."""

    turns = None

    def select(self, timeout=None):
        turns = self.turns
        if turns is not None:
            turns.waiting()
        try:
            return super().select(timeout)
        finally:
            if turns is not None:
                turns.working()


#: The selector of each loop :func:`watched_event_loop` made.
_SELECTORS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def watched_event_loop():
    """A new asyncio event loop that :func:`watch_event_loop` can watch: asyncio's selector loop, over a
    selector that notes the time each time the loop stops waiting and each time it waits again.

    Returns
    -------
    asyncio.AbstractEventLoop
        Not running and not set as the current loop (``asyncio.set_event_loop`` does that).

    Examples
    --------
    >>> loop = watched_event_loop()
    >>> loop.run_until_complete(asyncio.sleep(0))
    >>> loop.close()
    """
    selector = _TimedSelector()
    loop = asyncio.SelectorEventLoop(selector)
    _SELECTORS[loop] = selector
    return loop


class _Turns:
    """The turns of one loop: called in the loop's thread by its selector (``working``, ``waiting``)."""

    def __init__(self, threshold_ms, log):
        self.threshold_ms, self.log = threshold_ms, log
        self.since = None  # perf_counter() when the current turn began; None while the loop waits
        self.turn = 0  # the current turn's number
        self.thread = None  # the loop's thread
        self.samples = []  # (turn, where) read while a turn lasted
        self.looker_asleep = False
        self.wake = threading.Event()
        self.stopped = False

    def working(self):
        self.turn += 1
        self.thread = threading.get_ident()
        self.since = time.perf_counter()
        if self.looker_asleep:
            self.wake.set()

    def waiting(self):
        since = self.since
        if since is None:
            return
        self.since = None
        held_ms = (time.perf_counter() - since) * 1000.0
        if held_ms <= self.threshold_ms:
            if self.samples:  # read during a turn shorter than a stall
                self.samples = []
            return
        # The handler runs in this thread and can interrupt this very function (at any bytecode, or in a
        # garbage collection's callback): it appends to a fresh list while this one is counted, never to
        # the one being read (a shared Counter changed size under ``most_common`` and ended the watch).
        samples, self.samples = self.samples, []
        turn = self.turn
        STALLS["count"] += 1
        STALLS["longest_ms"] = max(STALLS["longest_ms"], held_ms)
        seen = Counter(where for when, where in samples if when == turn)
        where = seen.most_common(1)[0][0] if seen else ""
        self.log.warning("event loop blocked %.0f ms%s", held_ms, f" {where}" if where else "")

    def look(self, thread):
        """In a thread of its own: asks the loop's thread where it is, every ``TICK_S`` while a turn lasts;
        asleep while the loop waits."""
        while not self.stopped:
            since, turn = self.since, self.turn
            if since is None:
                self.looker_asleep = True
                if self.since is None and not self.stopped:  # looked at again once the loop can see it asleep
                    self.wake.wait()
                self.wake.clear()
                self.looker_asleep = False
                continue
            time.sleep(TICK_S)
            if self.stopped:  # looked at after the sleep: ``stop`` may have come during it
                return
            if (self.turn != turn or self.since is None or self.thread != thread
                    or time.perf_counter() - since < TICK_S):
                continue
            try:
                signal.pthread_kill(thread, SAMPLE_SIGNAL)
            except (OSError, ValueError):  # the process is ending
                return


def watch_event_loop(loop, threshold_ms=100.0, log=_LOG):
    """Start watching ``loop``, made by :func:`watched_event_loop`; returns a function that stops the watch.

    Parameters
    ----------
    loop : asyncio.AbstractEventLoop
        The loop to watch, from :func:`watched_event_loop` (running or not).
    threshold_ms : float
        A turn of the loop longer than this, in milliseconds, is a stall: logged, with where the loop was.
    log : logging.Logger
        Where the stalls go (``camsim.serve``).

    Returns
    -------
    callable
        Stops the watch (and its thread).

    Raises
    ------
    ValueError
        ``loop`` was not made by :func:`watched_event_loop` (nothing would be watched).

    Examples
    --------
    >>> loop = watched_event_loop()
    >>> stop = watch_event_loop(loop)
    >>> loop.run_until_complete(asyncio.sleep(0.05))
    >>> stop()
    >>> loop.close()
    """
    selector = _SELECTORS.get(loop)
    if selector is None:
        raise ValueError("loop: not made by camsim_explorer.loop_watch.watched_event_loop(), so its turns "
                         "cannot be timed")
    turns = _Turns(threshold_ms, log)

    def sampled(signum, frame):  # in the loop's thread, at its next bytecode: where it is, read from itself
        if len(turns.samples) < _MAX_SAMPLES:
            turns.samples.append((turns.turn, _where(_stack(frame))))

    # Where the loop is can only be read safely by the loop's own thread: a signal asks it. Python runs a
    # signal's handler in the main thread, so only a loop there (``camsim serve``'s) says where it stalls.
    main = threading.main_thread()
    asking = (SAMPLE_SIGNAL is not None and threading.current_thread() is main
              and signal.getsignal(SAMPLE_SIGNAL) in (signal.SIG_DFL, None))
    if asking:
        signal.signal(SAMPLE_SIGNAL, sampled)
    selector.turns = turns
    looking = threading.Thread(target=turns.look, args=(main.ident,), name="camsim-loop-watch", daemon=True)
    if asking:
        looking.start()

    def stop():
        turns.stopped = True
        turns.wake.set()
        if selector.turns is turns:
            selector.turns = None
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
