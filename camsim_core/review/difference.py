"""Two designs against each other (A/B): the dE between their renderings and where each one wins.

Both designs must see the scene at the same size (same distance and pixel
geometry). The difference is CIELAB dE*ab (CIE 1976) between the two rendered
images' XYZ on the monitor, with the monitor white as the reference white
(the same comparison the error maps make against the ideal image, chapter 4.3).

No GUI imports: this module is engine code.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .design import measures

__all__ = ["ab_difference"]


def ab_difference(a, b, metric="CIELAB"):
    """Compare two :class:`~camsim_core.review.design.DesignResult` objects.

    Returns a dict: ``delta_e`` (H, W) dE*ab between the renderings of ``a``
    and ``b``; ``measures`` its mean, median and 95th percentile; ``a_wins``
    (H, W) boolean, True where ``a``'s error against the ideal image (the
    ``metric`` map) is below ``b``'s; ``a_wins_fraction`` and
    ``b_wins_fraction`` (pixels where one is strictly better; ties count for neither).
    """
    from ..metrics import delta_e

    if a.shape != b.shape:
        raise ParameterError("A/B difference", f"{a.name} is {a.shape[0]} x {a.shape[1]} pixels but {b.name} is "
                                               f"{b.shape[0]} x {b.shape[1]}: compare designs of the same geometry")
    if not np.allclose(a.white, b.white):
        raise ParameterError("A/B difference", f"{a.name} and {b.name} use different monitors")
    de = np.asarray(delta_e(a.xyz, b.xyz, a.white), float)
    ea, eb = a.error_map(metric), b.error_map(metric)
    if ea is None or eb is None:
        raise ParameterError("A/B difference", f"no {metric} error map for both designs")
    return {
        "delta_e": de,
        "measures": measures(de),
        "a_wins": ea < eb,
        "a_wins_fraction": float(np.mean(ea < eb)),
        "b_wins_fraction": float(np.mean(eb < ea)),
    }
