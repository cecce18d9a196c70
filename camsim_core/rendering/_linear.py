"""Private linear-algebra helpers of balancing and rendering: spectra per band, the cones, safe inverses."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from ..spectra import Spectrum

__all__ = []

#: Ratio of smallest to largest singular value below which a matrix counts as singular.
RCOND = 1e-8


def per_band(spectrum, wavelengths):
    """A power spectrum on ``wavelengths`` in per-band units of that sampling.

    ``Spectrum.on`` interpolates values; a power per band must also be scaled
    by the ratio of band widths (chapter, after Eq. 1.3: "the spacing between
    wavelength samples has been folded into the units"). A bare array is
    taken to be on ``wavelengths`` already.
    """
    if isinstance(spectrum, Spectrum):
        return spectrum.per_band(wavelengths)
    v = np.asarray(spectrum, float).ravel()
    if v.size != np.size(wavelengths):
        raise ParameterError("illuminant", f"an array illuminant must have one value per wavelength ({np.size(wavelengths)}), got {v.size}")
    return v


@lru_cache(maxsize=16)
def _cones(key):
    from ..camera import camera_preset

    return camera_preset("human-cones").sensors.on(np.asarray(key, float))


def cones(wavelengths):
    """T_H (3, N): the human cones of the ideal camera (``camera_preset("human-cones")``, Smith-Pokorny
    on the DCS-200's common scale) on ``wavelengths``; the same scale as the ideal image's sensor data."""
    return _cones(tuple(np.asarray(wavelengths, float).tolist()))


def luminance(wavelengths, values):
    """CIE 1931 luminance (683 x y-bar . values) of per-band power values."""
    from ..datasets.sensors import cie1931_xyz

    return 683.0 * float(cie1931_xyz().on(wavelengths)[1] @ np.asarray(values, float))


def solve_matrix(a, what, hint=""):
    """Inverse of ``a`` (pseudo-inverse when not square), or a ParameterError when it is (nearly) singular."""
    a = np.asarray(a, float)
    sv = np.linalg.svd(a, compute_uv=False)
    rank_needed = min(a.shape)
    if sv.size < rank_needed or sv[0] <= 0 or sv[rank_needed - 1] / sv[0] < RCOND:
        rank = int(np.sum(sv > RCOND * (sv[0] if sv.size and sv[0] > 0 else 1.0)))
        raise ParameterError(
            what,
            f"the {a.shape[0]} x {a.shape[1]} matrix is singular (rank {rank}, needs {rank_needed})"
            + (f": {hint}" if hint else ""),
        )
    return np.linalg.inv(a) if a.shape[0] == a.shape[1] else np.linalg.pinv(a)


def apply_matrix(data, m):
    """Per-pixel ``m @ v`` over (H, W, K) -> (H, W, J), in ``data``'s float dtype (float32 stays float32)."""
    h, w, k = data.shape
    m = np.asarray(m, float)
    if data.dtype == np.float32:
        m = m.astype(np.float32)
    return (data.reshape(-1, k) @ m.T).reshape(h, w, -1)
