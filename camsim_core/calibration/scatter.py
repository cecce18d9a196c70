"""Affine scatter correction with the Macbeth Color Checker (chapter section 2).

At each wavelength the 24 patch values of the chart should be proportional
to the patches' known reflectances. The best line ``c_i = m_i r_i + b_i``
(least squares over the patches in view) gives an intercept ``b_i``: light
scattered in the optics, taken to be spatially uniform (a veiling
luminance), which is subtracted from the whole plane.

Known reflectances: the BabelColor average chart from colour-science
(:func:`camsim_core.datasets.surfaces.macbeth`), linearly interpolated onto
the plane wavelengths, its 730 nm value held beyond (as
:func:`camsim_core.scene.macbeth_scene` does).
"""

from __future__ import annotations

import numpy as np

from ..datasets.surfaces import macbeth
from ..errors import ParameterError
from ..spectra import resample

__all__ = ["macbeth_reflectances", "region_means", "fit_scatter", "macbeth_names"]


def macbeth_names():
    """The 24 patch names, row by row (patch number = index + 1)."""
    return macbeth()[2]


def macbeth_reflectances(wavelengths, patches=None):
    """(P, N) reflectances of the chart's patches (0-based indices, default all 24) at ``wavelengths`` nm."""
    mw, refl, _ = macbeth()
    w = np.asarray(wavelengths, float)
    r = resample(mw, refl, w)
    r[:, w > mw[-1]] = refl[:, -1:]
    r[:, w < mw[0]] = refl[:, :1]
    return r if patches is None else r[list(patches)]


def region_means(cube, boxes):
    """(R, N) mean of ``cube`` (N, H, W) over each box ``(top, left, bottom, right)`` (half-open, px)."""
    return np.stack([cube[:, t:b, l:r].mean(axis=(1, 2)) for (t, l, b, r) in boxes])


def fit_scatter(means, reflectances):
    """Per-plane least-squares line ``c = m r + b`` through the patch values.

    Parameters
    ----------
    means : (P, N) patch means per plane (dark-subtracted counts)
    reflectances : (P, N) known reflectances of the same patches

    Returns
    -------
    m, b : (N,) slope (counts per unit reflectance) and intercept (counts)
    """
    c = np.asarray(means, float)
    r = np.asarray(reflectances, float)
    if c.shape != r.shape or c.shape[0] < 3:
        raise ParameterError("mcc", f"need at least 3 chart patches for the scatter regression, got {c.shape[0]}")
    rm, cm = r.mean(axis=0), c.mean(axis=0)
    var = ((r - rm) ** 2).sum(axis=0)
    if np.any(var <= 0):
        raise ParameterError("mcc", "the chart patches in view have the same reflectance at some wavelength; the regression is undetermined")
    m = ((r - rm) * (c - cm)).sum(axis=0) / var
    return m, cm - m * rm
