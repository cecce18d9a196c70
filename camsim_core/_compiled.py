"""numba kernels compiled on first use: one rule for every compiled loop of the engine.

Each kernel is a plain Python function of arrays (readable, testable as
Python); :func:`compiled` gives the getter that compiles it once per process
(``nogil`` so that blocks of rows run on the machine's cores, ``cache`` so
that later processes load it from disk), importing numba only then.
"""

from __future__ import annotations

from functools import lru_cache

__all__ = ["compiled"]


def compiled(fn):
    """A function returning ``fn`` compiled by numba (``njit(cache=True, nogil=True)``), compiled on its first call."""

    @lru_cache(maxsize=1)
    def kernel():
        import numba

        return numba.njit(cache=True, nogil=True)(fn)

    kernel.__doc__ = f"The numba-compiled :func:`{fn.__name__}` (compiled on first use, cached on disk)."
    return kernel
