"""Bayer-only demosaicing methods through colour-demosaicing.

* ``malvar2004``: H. S. Malvar, L.-W. He and R. Cutler, "High-quality linear
  interpolation for demosaicing of Bayer-patterned color images", ICASSP 2004.
* ``menon2007``: D. Menon, S. Andriani and G. Calvagno, "Demosaicing with
  directional filtering and a posteriori decision", IEEE TIP 16 (2007).

They need a 2 x 2 Bayer tile of three classes (one of them twice on a
diagonal); the two single classes play R and B (the methods treat R and B
alike). Any other tile raises a ParameterError naming the methods that work.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ._masks import bayer_pattern, check_mosaiced

__all__ = ["demosaic_malvar2004", "demosaic_menon2007"]


def _run(image, method, func):
    data, tile, k = check_mosaiced(image, method)
    found = bayer_pattern(tile, k)
    if found is None:
        raise ParameterError(
            "method",
            f"{method!r} works on a 2 x 2 Bayer tile of three sensor classes only; this image has a "
            f"{'x'.join(str(d) for d in tile.shape[:2])} tile of {k} classes: use 'bilinear', 'freeman' or 'bayesian'",
        )
    pattern, order = found
    rgb = np.asarray(func(data[:, :, 0], pattern), float)
    out = np.empty_like(rgb)
    for j, c in enumerate(order):
        out[:, :, c] = rgb[:, :, j]
    return out


def demosaic_malvar2004(image):
    """Malvar-He-Cutler (2004) gradient-corrected linear interpolation (colour-demosaicing)."""
    from colour_demosaicing import demosaicing_CFA_Bayer_Malvar2004

    return _run(image, "malvar2004", demosaicing_CFA_Bayer_Malvar2004)


def demosaic_menon2007(image, refining_step=True):
    """Menon-Andriani-Calvagno (2007) directional filtering with a posteriori decision (colour-demosaicing)."""
    from colour_demosaicing import demosaicing_CFA_Bayer_Menon2007

    return _run(image, "menon2007", lambda cfa, pattern: demosaicing_CFA_Bayer_Menon2007(cfa, pattern, refining_step))
