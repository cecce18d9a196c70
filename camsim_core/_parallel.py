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

__all__ = ["CORES", "PARALLEL_VALUES", "run_blocks", "split"]

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


def run_blocks(fn, bounds, *, values):
    """``fn(start, stop)`` for each consecutive pair of ``bounds`` (block edges), on the pool's threads when
    ``values`` (the work, in values written) is at least :data:`PARALLEL_VALUES`, else in turn here.

    ``fn`` must touch only its own block of the output. Exceptions are raised here, after every block ended.
    Called from one of the pool's own threads (a block whose work splits again), the blocks run in turn
    there: a block waiting on the pool it occupies could wait forever.
    """
    edges = [int(b) for b in bounds]
    pairs = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]
    nested = threading.current_thread().name.startswith(_blocks.prefix)
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
