"""Full garbage collections at quiet moments, in ``camsim serve``.

Python's collector makes a full collection (generation 2) whenever the
objects moved to generation 2 since the last one number a quarter of those
that survived it. In a served class that is one every few seconds of use:
with ten pages open, each full collection walked the ~23,000 objects every
page holds and held every thread, the event loop's too, for 100-180 ms
(the hostile load test of issue 36: three or four per minute of changes,
each a stall all ten pages waited on).

:class:`QuietCollector` takes full collections out of Python's hands: the
threshold of generation 2 is set out of reach (young collections go on as
before) and a full collection runs instead

- once the pages have been quiet (no message for ``quiet_s``, no session
  computing) and ``every_s`` has passed since the last full collection;
- at the latest ``at_most_s`` after the last, quiet or not, so that a
  server busy without a pause still frees what only a full collection frees;

each time only if a young collection moved objects to generation 2 since.
Memory held by reference cycles is then freed up to ``at_most_s`` later than
Python would have freed it.

Written by hand: Python offers the thresholds and :func:`gc.collect`, no
policy tied to a server's activity.
"""

from __future__ import annotations

import gc
import logging
import time

__all__ = ["QuietCollector", "OUT_OF_REACH"]

#: Generation 2's threshold while a :class:`QuietCollector` runs: the young collections Python would count
#: before a full collection of its own (at one young collection per ~7,000 objects made, never reached).
OUT_OF_REACH = 10**9

_log = logging.getLogger("camsim.serve")


class QuietCollector:
    """Full collections when the pages are quiet, at most ``at_most_s`` apart (see the module docstring).

    Parameters
    ----------
    idle_for : callable
        ``idle_for() -> float``: seconds since a page last sent the server a message.
    busy : callable
        ``busy() -> bool``: a session is computing.
    quiet_s : float
        Seconds without a page's message that make a quiet moment.
    every_s : float
        Shortest time between two full collections made at quiet moments (s).
    at_most_s : float
        Longest time between two full collections (s), quiet or not.
    clock : callable
        Monotonic seconds (``time.monotonic``; a test passes its own).

    Examples
    --------
    >>> c = QuietCollector(idle_for=lambda: 60.0, busy=lambda: False, every_s=0.0)
    >>> c.start()
    >>> gc.get_threshold()[2] == OUT_OF_REACH
    True
    >>> _ = gc.collect(1)  # a young collection: what survives it reaches generation 2
    >>> c.check()  # the pages are quiet: a full collection
    True
    >>> c.stop()
    >>> gc.get_threshold()[2] == OUT_OF_REACH
    False
    """

    def __init__(self, idle_for, busy, quiet_s=2.0, every_s=20.0, at_most_s=120.0, clock=time.monotonic):
        self.idle_for, self.busy, self.clock = idle_for, busy, clock
        self.quiet_s, self.every_s, self.at_most_s = quiet_s, every_s, at_most_s
        self.last_full = clock()
        self._threshold = None

    def _noted(self, phase, info):
        if phase == "stop" and info["generation"] == 2:  # any full collection, this one's or another's
            self.last_full = self.clock()

    def start(self):
        """Turn Python's own full collections off and note every full collection from now on."""
        self._threshold = gc.get_threshold()
        gc.set_threshold(self._threshold[0], self._threshold[1], OUT_OF_REACH)
        gc.callbacks.append(self._noted)

    def stop(self):
        """Give Python its own full collections back."""
        if self._threshold is not None:
            gc.set_threshold(*self._threshold)
            self._threshold = None
        if self._noted in gc.callbacks:
            gc.callbacks.remove(self._noted)

    def due(self):
        """Whether a full collection should run now."""
        if gc.get_count()[2] == 0:  # nothing reached generation 2 since the last full collection
            return False
        since = self.clock() - self.last_full
        if since >= self.at_most_s:
            return True
        return since >= self.every_s and self.idle_for() >= self.quiet_s and not self.busy()

    def check(self):
        """One look (the server calls it every second): a full collection if :meth:`due`; True when one ran."""
        if not self.due():
            return False
        when = "at a quiet moment" if self.clock() - self.last_full < self.at_most_s else "at the longest interval"
        t0 = time.perf_counter()
        freed = gc.collect()
        _log.info("full garbage collection %s: %d objects freed in %.0f ms", when, freed,
                  1000 * (time.perf_counter() - t0))
        return True
