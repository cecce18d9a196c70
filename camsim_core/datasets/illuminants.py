"""Illuminant spectral power distributions.

References
----------
* Measured scene illuminants (``spd_cacaphony``, ``spd_BFGB``, ...) and
  ``spd_D65Render``: SimToolbox ``illuminants/*.mat`` (Brainard lab).
* CIE standard illuminants D65 and A: colour-science (CIE 015:2018).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from ..spectra import Spectrum, sampling_wavelengths
from . import SIMTOOLBOX

__all__ = ["illuminant", "ILLUMINANT_NAMES"]

_MAT = {
    "cacaphony": "spd_cacaphony",
    "bfgb": "spd_BFGB",
    "bfgg": "spd_BFGG",
    "bowl": "spd_bowl",
    "fluorescent": "spd_fluo",
    "d65-render": "spd_D65Render",
}
ILLUMINANT_NAMES = tuple(_MAT) + ("D65", "A")


@lru_cache(maxsize=None)
def illuminant(name):
    """An illuminant :class:`~camsim_core.spectra.Spectrum` by name (see ``ILLUMINANT_NAMES``)."""
    if name in ("D65", "A"):
        from .colour_science import table

        w, spd = table(name)  # colour-science's, shipped
        return Spectrum(w, spd, f"CIE {name}")
    if name not in _MAT:
        raise ParameterError("illuminant", f"unknown name {name!r}; known: {', '.join(ILLUMINANT_NAMES)}")
    from scipy.io import loadmat

    key = _MAT[name]
    m = loadmat(SIMTOOLBOX / "illuminants" / f"{key}.mat")
    s = np.asarray(m["S_" + key[4:]], float).ravel()
    return Spectrum(sampling_wavelengths(*s), np.asarray(m[key], float).ravel(), name)
