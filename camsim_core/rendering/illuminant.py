"""Illuminant-based balancing (chapter section 4.2, Eqs. 1.5-1.7), and illuminant estimates.

Surfaces lie in an ``N_s``-dimensional linear model ``s = B_s w`` (Eq. 1.5)
fitted to the 1269 Munsell papers (SVD, no mean removed; references 33,
34, 47, 48). With the illuminant ``e`` the camera sees
``r_C = T_C diag(e) B_s w = M w`` (Eqs. 1.6, 1.7), so ``w = M^-1 r_C``
(the pseudo-inverse, least squares, when ``K != N_s``); the cone responses
of the same surfaces are ``r_H = T_H diag(e') B_s w`` with ``e' = e``, or
a re-rendering illuminant scaled to the same luminance. ``r_H`` is then
rendered by the baseline method with the cones (``baseline.py``).

Estimates of ``e`` from the image (hand-written; colour-science has no
spectral estimators), both in the 3-dimensional CIE daylight model
(S0, S1, S2 from colour-science) ``e = B_e u``:

* gray world (Buchsbaum 1980): the mean camera response is that of the mean
  Munsell reflectance ``s_bar``: ``mean r = T_C diag(s_bar) B_e u``;
* max-RGB (white patch, Land 1977): the largest response of each sensor is
  that of a perfect white: ``max r = T_C B_e u``.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from ..spectra import Spectrum, resample
from ._linear import luminance, per_band, solve_matrix

__all__ = ["surface_basis", "balance_matrix", "estimate_illuminant", "daylight_basis", "ESTIMATORS"]

ESTIMATORS = ("gray-world", "max-rgb")


@lru_cache(maxsize=16)
def _munsell_on(key):
    from ..datasets.surfaces import munsell

    mw, refl = munsell()
    w = np.asarray(key, float)
    r = resample(mw, refl, w)
    return r


def munsell_on(wavelengths):
    """(1269, N) Munsell reflectances on ``wavelengths``."""
    return _munsell_on(tuple(np.asarray(wavelengths, float).tolist()))


def surface_basis(wavelengths, dimensions=3):
    """B_s (N, N_s): the first ``dimensions`` right singular vectors of the Munsell set (Eq. 1.5)."""
    r = munsell_on(wavelengths)
    n = int(dimensions)
    if not 1 <= n <= min(r.shape):
        raise ParameterError("dimensions", f"must be between 1 and {min(r.shape)}, got {dimensions}")
    _, _, vt = np.linalg.svd(r, full_matrices=False)
    b = vt[:n].T
    return b * np.where(b.sum(axis=0) < 0, -1.0, 1.0)


def balance_matrix(t_c, t_h, e, b_s, e_render=None):
    """(3, K) matrix ``T_H diag(e') B_s (T_C diag(e) B_s)^-1``: camera responses -> cone responses."""
    m = np.asarray(t_c, float) @ (np.asarray(e, float)[:, None] * b_s)
    inv = solve_matrix(
        m, "illuminant-surface matrix T_C diag(e) B_s",
        "the sensors cannot recover the surface weights under this illuminant (fewer dimensions, or no overlap)",
    )
    er = e if e_render is None else e_render
    return np.asarray(t_h, float) @ (np.asarray(er, float)[:, None] * b_s) @ inv


def daylight_basis(wavelengths):
    """B_e (N, 3): the CIE daylight basis S0, S1, S2 (colour-science's, shipped) on ``wavelengths``."""
    from ..datasets.colour_science import table

    w, s = table("daylight-basis")
    return np.stack([resample(w, s[:, k], wavelengths) for k in range(3)], axis=1)


def estimate_illuminant(responses, sensitivities, wavelengths, method):
    """An illuminant :class:`Spectrum` (per band of ``wavelengths``) estimated from (H, W, K) responses.

    ``responses`` are in units of ``sensitivities @ radiance`` (gain divided
    out), so the estimate is in radiance units of a perfect white reflector.
    """
    if method not in ESTIMATORS:
        raise ParameterError("illuminant", f"unknown estimate {method!r}; valid: None, a Spectrum, {', '.join(ESTIMATORS)}")
    r = np.asarray(responses, float).reshape(-1, responses.shape[-1])
    b_e = daylight_basis(wavelengths)
    t = np.asarray(sensitivities, float)
    if method == "gray-world":
        s_bar = munsell_on(wavelengths).mean(axis=0)
        a = t @ (s_bar[:, None] * b_e)
        target = r.mean(axis=0)
    else:
        a = t @ b_e
        target = r.max(axis=0)
    u = solve_matrix(a, f"{method} illuminant estimate", "the sensors cannot resolve the daylight model") @ target
    e = np.clip(b_e @ u, 0.0, None)
    if not np.any(e > 0):
        raise ParameterError("illuminant", f"the {method} estimate has no power (is the image black?)")
    return Spectrum(wavelengths, e, method)


def resolve_illuminant(image, responses, illuminant):
    """The illuminant on the image's wavelengths, and the Spectrum used (None -> the image's own)."""
    wls = image.wavelengths
    if illuminant is None:
        if image.illuminant is None:
            raise ParameterError(
                "illuminant",
                "the image carries no scene illuminant: pass a Spectrum or an estimate ('gray-world', 'max-rgb')",
            )
        return per_band(image.illuminant, wls), image.illuminant
    if isinstance(illuminant, str):
        if illuminant.lower() in ESTIMATORS:
            spd = estimate_illuminant(responses, image.sensitivities, wls, illuminant.lower())
            return spd.values, spd
        from ..datasets.illuminants import ILLUMINANT_NAMES
        from ..datasets.illuminants import illuminant as named

        if illuminant not in ILLUMINANT_NAMES:
            raise ParameterError(
                "illuminant",
                f"unknown illuminant {illuminant!r}; valid: None (the scene's), a Spectrum, "
                f"an estimate ({', '.join(ESTIMATORS)}) or a name ({', '.join(ILLUMINANT_NAMES)})",
            )
        spd = named(illuminant)
        return per_band(spd, wls), spd
    if isinstance(illuminant, Spectrum):
        return per_band(illuminant, wls), illuminant
    raise ParameterError("illuminant", f"must be None, a Spectrum, a name, or one of {ESTIMATORS}; got {illuminant!r}")


def matched_luminance(e_render, e, wavelengths):
    """``e_render`` scaled to the luminance of ``e`` (re-rendering keeps the overall light level)."""
    y, yr = luminance(wavelengths, e), luminance(wavelengths, e_render)
    if not yr > 0:
        raise ParameterError("render_illuminant", "has no luminance in the image's wavelength range")
    return e_render * (y / yr)
