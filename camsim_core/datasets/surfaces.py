"""Surface reflectance sets.

References
----------
* Munsell: 1269 matte Munsell chips (Parkkinen, Hallikainen & Jaaskelainen
  1989), SimToolbox ``spectra/munsell.mat``, 380:5:780 nm.
* Macbeth ColorChecker: BabelColor average of 30 charts (Pascale 2006), from
  colour-science, 380:10:730 nm.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..spectra import sampling_wavelengths
from . import SIMTOOLBOX

__all__ = ["munsell", "macbeth"]


@lru_cache(maxsize=None)
def munsell():
    """(wavelengths (81,), reflectances (1269, 81)) of the Munsell chips."""
    from scipy.io import loadmat

    r = np.asarray(loadmat(SIMTOOLBOX / "spectra" / "munsell.mat")["munsell"], float).T
    r.flags.writeable = False
    return sampling_wavelengths(380, 5, 81), r


@lru_cache(maxsize=None)
def macbeth():
    """(wavelengths, reflectances (24, N), names) of the Macbeth ColorChecker, row by row."""
    from .colour_science import colourchecker_names, table

    w, r = table("babelcolor")  # colour-science's BabelColor average, shipped: one column a patch
    return w, r.T, colourchecker_names()
