"""Spectral functions sampled on wavelengths, and resampling between samplings.

Units follow the chapter's convention (after its Eq. 1.3): radiance values are
power *per wavelength band* of their own sampling (W/sr/m^2 per band), and a
sensitivity is the response to one unit of such a band. Under that convention
a sensitivity curve resampled by interpolation onto another sampling gives the
same integrated response, because the band width is folded into the radiance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ParameterError

__all__ = ["Spectrum", "resample", "resample_power", "band_width", "sampling_wavelengths", "check_overlap"]


def sampling_wavelengths(start, step, count):
    """Wavelengths (nm) of a ``[start step count]`` sampling, as SimToolbox's ``S`` vectors.

    Examples
    --------
    >>> w = sampling_wavelengths(400, 10, 31)
    >>> w.size, float(w[0]), float(w[-1])
    (31, 400.0, 700.0)
    """
    return float(start) + float(step) * np.arange(int(count))


def check_overlap(source_wavelengths, target_wavelengths, what="sensitivities"):
    """Raise when two wavelength ranges do not overlap at all.

    Examples
    --------
    >>> check_overlap([400, 700], [500, 1000])  # overlap: nothing to say
    >>> check_overlap([400, 700], [800, 1000])
    Traceback (most recent call last):
    ...
    camsim_core.errors.ParameterError: sensitivities: measured over 400-700 nm, which does not overlap the scene's 800-1000 nm
    """
    s = np.asarray(source_wavelengths, float)
    t = np.asarray(target_wavelengths, float)
    if s.max() < t.min() or s.min() > t.max():
        raise ParameterError(
            what,
            f"measured over {s.min():g}-{s.max():g} nm, which does not overlap "
            f"the scene's {t.min():g}-{t.max():g} nm",
        )


def resample(wavelengths, values, target_wavelengths):
    """Linear interpolation of spectra onto ``target_wavelengths``; zero outside their range.

    Parameters
    ----------
    wavelengths : array_like, (N,)
        Sampling of ``values`` in nm, increasing.
    values : array_like, (..., N)
        Spectra along the last axis.
    target_wavelengths : array_like, (M,)

    Returns
    -------
    ndarray, (..., M)

    Examples
    --------
    A triangle peaking at 500 nm, read half-way up its side and beyond its range:

    >>> resample([400, 500, 600], [0.0, 1.0, 0.0], [450, 500, 650]).tolist()
    [0.5, 1.0, 0.0]
    """
    w = np.asarray(wavelengths, float)
    v = np.asarray(values, float)
    t = np.asarray(target_wavelengths, float)
    if v.shape[-1] != w.size:
        raise ParameterError("values", f"last axis has {v.shape[-1]} samples, wavelengths has {w.size}")
    if w.size > 1 and np.any(np.diff(w) <= 0):
        raise ParameterError("wavelengths", "must be strictly increasing")
    if w.size == t.size and np.allclose(w, t):
        return v.copy()
    flat = v.reshape(-1, w.size)
    out = np.stack([np.interp(t, w, row, left=0.0, right=0.0) for row in flat])
    return out.reshape(v.shape[:-1] + (t.size,))


def band_width(wavelengths):
    """The band width (nm) of a sampling: its median step (1 nm for a single sample).

    Examples
    --------
    >>> band_width([400, 410, 420])
    10.0
    >>> band_width([550])
    1.0
    """
    w = np.asarray(wavelengths, float)
    return float(np.median(np.diff(w))) if w.size > 1 else 1.0


def resample_power(wavelengths, values, target_wavelengths):
    """Power spectra given per band of ``wavelengths``, as power per band of ``target_wavelengths``.

    Interpolation as :func:`resample`, times the ratio of the band widths, so
    that a 5 nm-band illuminant on a 10 nm sampling keeps its radiance.

    Examples
    --------
    A flat power of 1 per 5 nm band is 2 per 10 nm band:

    >>> resample_power([400, 405, 410], [1.0, 1.0, 1.0], [400, 410]).tolist()
    [2.0, 2.0]
    """
    return resample(wavelengths, values, target_wavelengths) * (band_width(target_wavelengths) / band_width(wavelengths))


@dataclass(frozen=True, eq=False)
class Spectrum:
    """One spectral function (an illuminant, a reflectance) with its own sampling.

    ``values`` are per wavelength band of ``wavelengths`` for power spectra.

    Examples
    --------
    >>> ramp = Spectrum([400, 500], [1.0, 3.0], "ramp")
    >>> ramp.on([450, 600]).tolist()
    [2.0, 0.0]
    """

    wavelengths: np.ndarray
    values: np.ndarray
    name: str = ""

    def __post_init__(self):
        w = np.asarray(self.wavelengths, float).ravel()
        v = np.asarray(self.values, float).ravel()
        if w.size != v.size:
            raise ParameterError(self.name or "spectrum", f"{v.size} values for {w.size} wavelengths")
        if not np.all(np.isfinite(v)):
            raise ParameterError(self.name or "spectrum", "values must be finite")
        w.flags.writeable = False
        v.flags.writeable = False
        object.__setattr__(self, "wavelengths", w)
        object.__setattr__(self, "values", v)

    def on(self, wavelengths):
        """Values interpolated onto ``wavelengths`` (zero outside the measured range).

        Right for reflectances and sensitivities; a power spectrum that must
        keep its per-band units wants :meth:`per_band`.
        """
        return resample(self.wavelengths, self.values, wavelengths)

    def per_band(self, wavelengths):
        """A power spectrum as power per band of ``wavelengths`` (see :func:`resample_power`)."""
        return resample_power(self.wavelengths, self.values, wavelengths)
