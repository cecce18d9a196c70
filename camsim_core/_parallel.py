"""Blocks of one large array computed on the machine's cores, by kernels that release the GIL.

Hand-written (a shared thread pool and a split into row blocks): the
kernels it runs (numba functions compiled with ``nogil``, numpy's random
fills) already release the GIL, so threads are all they need; a process
pool or dask would copy the arrays. Small arrays run in the calling thread
(the explorer's images: starting threads costs more than it saves).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

__all__ = ["CORES", "PARALLEL_VALUES", "run_blocks", "split", "background", "BACKGROUND_NICE"]

#: Threads of the pool: the machine's cores.
CORES = max(1, os.cpu_count() or 1)

#: Work (values written) below which a call runs in the calling thread.
PARALLEL_VALUES = 1 << 21

class ThreadPool:
    """A pool of :data:`CORES` threads, made on first use and made again in a forked child.

    A forked child (a script's ``multiprocessing`` pool; fork is Linux's default) inherits the pool
    object but none of its threads: that pool would take work and never do it.
    """

    def __init__(self, thread_name_prefix):
        self.prefix = thread_name_prefix
        self._forget()
        os.register_at_fork(after_in_child=self._forget)

    def _forget(self):
        self._pool, self._lock = None, threading.Lock()

    def executor(self):
        """The pool's executor (``concurrent.futures.ThreadPoolExecutor``)."""
        with self._lock:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(CORES, thread_name_prefix=self.prefix)
            return self._pool


_blocks = ThreadPool("camsim-block")
_local = threading.local()
#: Niceness of a thread doing background work (sweeps, pinned designs): below a server's interactive work.
BACKGROUND_NICE = 10
#: One background job computes at a time in the whole process, in its own thread, on one core.
_background_slot = threading.Lock()


class background:
    """Run a block of work as background work: one at a time per process, at lower priority, on one core.

    For work a user waits for less than for the live view (a sweep's points,
    pinned designs): inside the block, :func:`run_blocks` runs every block in
    the calling thread (no share of the block pool, which serves the live
    views), the thread's niceness is raised to :data:`BACKGROUND_NICE` (Linux
    sets niceness per thread; it is never lowered again, so use it in a
    thread made for the work), and a process-wide lock lets one background
    block compute at a time, whatever session it belongs to. So sweeps of
    every session together take one core at most, and lose it to any
    interactive work.

    Hand-written: thread pools have no priority and no inline mode.

    Examples
    --------
    >>> with background():
    ...     run_blocks(lambda a, b: None, [0, 1, 2], values=10**9)  # runs here, in turn
    """

    def __enter__(self):
        if not getattr(_local, "niced", False):
            try:
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), BACKGROUND_NICE)
                _local.niced = True
            except (AttributeError, OSError):  # not Linux: the lock and the inline blocks still hold
                pass
        _background_slot.acquire()
        _local.depth = getattr(_local, "depth", 0) + 1
        return self

    def __exit__(self, *exc):
        _local.depth -= 1
        _background_slot.release()
        return False


def run_blocks(fn, bounds, *, values):
    """``fn(start, stop)`` for each consecutive pair of ``bounds`` (block edges), on the pool's threads when
    ``values`` (the work, in values written) is at least :data:`PARALLEL_VALUES`, else in turn here.

    ``fn`` must touch only its own block of the output. Exceptions are raised here, after every block ended.
    Called from one of the pool's own threads (a block whose work splits again), the blocks run in turn
    there: a block waiting on the pool it occupies could wait forever. Inside :class:`background` they
    run in turn too.
    """
    edges = [int(b) for b in bounds]
    pairs = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    nested = threading.current_thread().name.startswith(_blocks.prefix) or getattr(_local, "depth", 0) > 0
    if CORES == 1 or len(pairs) < 2 or values < PARALLEL_VALUES or nested:
        for a, b in pairs:
            fn(a, b)
        return
    futures = [_blocks.executor().submit(fn, a, b) for a, b in pairs]
    wait(futures)
    for f in futures:
        f.result()


def split(n, parts):
    """Edges of ``parts`` near-equal blocks of ``range(n)``."""
    return np.linspace(0, n, max(1, min(parts, n)) + 1).astype(int)
