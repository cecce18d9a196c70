"""A counter of threads inside a block at once, for tests of what must (or may) run concurrently."""

import threading


class Overlap:
    """``with overlap: ...`` in each thread; ``overlap.most`` is the most threads that were inside at once."""

    def __init__(self):
        self._lock = threading.Lock()
        self.inside = 0
        self.most = 0

    def __enter__(self):
        with self._lock:
            self.inside += 1
            self.most = max(self.most, self.inside)
        return self

    def __exit__(self, *exc):
        with self._lock:
            self.inside -= 1
