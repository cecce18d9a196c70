"""Optical transfer functions of a circular aperture: diffraction-limited, and with defocus.

Incoherent imaging through an aberration-free circular pupil of f-number N
at wavelength lambda has the optical transfer function (Goodman,
*Introduction to Fourier Optics*, 3rd ed., section 6.3.2)

    H(v) = 2/pi (acos v - v sqrt(1 - v^2)),   v = f / f_c,   f_c = 1 / (lambda N),

for v <= 1 and 0 beyond the cutoff ``f_c`` (cycles per unit length at the
sensor). It is real and non-negative, so it is also the MTF.

Defocus adds the pupil phase 2 pi w rho^2 (``w`` = W020 in waves, rho the
normalized pupil radius). The OTF is then the pupil's normalized
autocorrelation, which reduces to one integral (Hopkins 1955; derived in
:func:`defocus_otf`), evaluated here by Gauss-Legendre quadrature. Written
by hand: neither scipy nor colour-science provides these transfer functions.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ParameterError

__all__ = ["diffraction_mtf", "cutoff_frequency", "defocus_otf", "defocus_waves", "MIN_F_NUMBER"]

#: The smallest f-number accepted: N = 1 / (2 NA) and NA <= 1 in air.
MIN_F_NUMBER = 0.5


def check_f_number(f_number, name="f_number"):
    """A finite f-number >= 0.5 (a numerical aperture of at most 1 in air).

    Examples
    --------
    >>> check_f_number("2.8")
    2.8
    >>> check_f_number(0.3)
    Traceback (most recent call last):
    ...
    camsim_core.errors.ParameterError: f_number: must be a finite f-number >= 0.5 (numerical aperture <= 1), got 0.3
    """
    try:
        n = float(f_number)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be a number, got {f_number!r}") from None
    if not np.isfinite(n) or n < MIN_F_NUMBER:
        raise ParameterError(name, f"must be a finite f-number >= {MIN_F_NUMBER} (numerical aperture <= 1), got {f_number!r}")
    return n


def _wavelength_mm(wavelength):
    w = np.asarray(wavelength, float)
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ParameterError("wavelength", f"must be positive nm, got {wavelength!r}")
    return w * 1e-6


def cutoff_frequency(wavelength, f_number):
    """Incoherent cutoff 1 / (lambda N), cycles/mm at the sensor, for ``wavelength`` in nm.

    Examples
    --------
    Green light (500 nm) at f/4: 1 / (0.0005 mm x 4) = 500 cycles/mm.

    >>> round(float(cutoff_frequency(500, 4)), 6)
    500.0
    """
    return 1.0 / (_wavelength_mm(wavelength) * check_f_number(f_number))


def _mtf_of_v(v):
    v = np.clip(np.abs(np.asarray(v, float)), 0.0, 1.0)
    return (2.0 / np.pi) * (np.arccos(v) - v * np.sqrt(1.0 - v * v))


def diffraction_mtf(frequency, wavelength, f_number):
    """The incoherent diffraction-limited MTF of a circular aperture.

    Parameters
    ----------
    frequency : array_like
        Spatial frequency at the sensor, cycles/mm (the sign is ignored).
    wavelength : float or array_like
        nm; broadcast against ``frequency``.
    f_number : float
        Working f-number N (>= 0.5).

    Returns
    -------
    ndarray
        2/pi (acos v - v sqrt(1 - v^2)) with v = frequency x lambda x N, and 0 for v >= 1.

    Examples
    --------
    At 0, half and all of the 500 cycles/mm cutoff of 500 nm at f/4
    (2/pi (pi/3 - sqrt(3)/4) = 0.391 at half the cutoff):

    >>> import numpy as np
    >>> np.round(diffraction_mtf([0, 250, 500], 500, 4), 3).tolist()
    [1.0, 0.391, 0.0]
    """
    f = np.asarray(frequency, float)
    if not np.all(np.isfinite(f)):
        raise ParameterError("frequency", "must be finite cycles/mm")
    v = np.abs(f) * _wavelength_mm(wavelength) * check_f_number(f_number)
    return np.where(v < 1.0, _mtf_of_v(v), 0.0)


def defocus_waves(dioptres, wavelength, f_number, focal_length):
    """W020 in waves at ``wavelength`` (nm) of a focus error of ``dioptres`` (1/m).

    The defocus wavefront error at the pupil edge is W020 = dD a^2 / 2 with
    a = f / (2 N) the pupil radius (m); divided by the wavelength.

    Examples
    --------
    1 dioptre of focus error, a 50 mm lens at f/4 (pupil radius 6.25 mm), 500 nm:
    1 x 0.00625^2 / 2 / 500e-9 = 39.06 waves.

    >>> round(float(defocus_waves(1.0, 500, 4, 50)), 2)
    39.06
    """
    a = (float(focal_length) * 1e-3) / (2.0 * check_f_number(f_number))
    return float(dioptres) * a * a / 2.0 / (np.asarray(wavelength, float) * 1e-9)


@lru_cache(maxsize=8)
def _nodes(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1.0) / 2.0, w / 2.0


def defocus_otf(v, waves):
    """OTF of a circular pupil with defocus W020 = ``waves``, at normalized frequency v = f / f_c.

    The pupil P = exp(i 2 pi w rho^2) on the unit disk; its autocorrelation
    at a shear of 2v, normalized by the pupil area pi, is

        H(v) = (4/pi) int_0^sqrt(1-v^2) sin(b X(y)) / b dy,
        X(y) = sqrt(1 - y^2) - v,  b = 8 pi w v,

    which tends to the diffraction-limited formula as w -> 0. Real (it may
    go negative: contrast reversal). 0 at and beyond v = 1.

    Examples
    --------
    Without defocus it is the diffraction-limited MTF; a quarter wave of defocus lowers it:

    >>> import numpy as np
    >>> v = np.array([0.0, 0.5])
    >>> np.round(defocus_otf(v, 0.0), 3).tolist(), bool(defocus_otf(0.5, 0.25) < defocus_otf(0.5, 0.0))
    ([1.0, 0.391], True)
    """
    v = np.clip(np.abs(np.asarray(v, float)), 0.0, 1.0)
    w = float(waves)
    if w == 0.0:
        return np.where(v < 1.0, _mtf_of_v(v), 0.0)
    n = int(min(2000, 64 + 16 * abs(w)))
    t, wt = _nodes(n)
    ymax = np.sqrt(1.0 - v * v)
    y = ymax[..., None] * t  # nodes on [0, ymax]
    X = np.sqrt(1.0 - y * y) - v[..., None]
    b = 8.0 * np.pi * w * v[..., None]
    integrand = X * np.sinc(b * X / np.pi)  # sin(bX)/b, with the b -> 0 limit X
    out = (4.0 / np.pi) * ymax * (integrand @ wt)
    return np.where(v < 1.0, out, 0.0)
