"""Sensor spectral sensitivity sets.

Each set is a :class:`Sensors` (wavelengths in nm, a (K, N) array of
sensitivities, names, and the unit of the sensitivities).

References
----------
* Smith, V. C. & Pokorny, J. (1975) cone fundamentals, from SimToolbox's
  ``spectra/SmithPokornyCones.dat`` (peak-normalized L, M, S).
* Stockman, A. & Sharpe, L. T. (2000) 2-degree cone fundamentals, and the
  CIE 1931 2-degree colour matching functions, from colour-science.
* Vora, P. L., Farrell, J. E., Tietz, J. D. & Brainard, D. H. (1997) Kodak
  DCS-200 sensitivities, from SimToolbox's ``cameras/kodakdcs200_50mm*.Scam``
  (response in digital units to W/sr/m^2 per 5 nm band, at f/5.6 and 1 s).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from ..spectra import resample, sampling_wavelengths
from . import SIMTOOLBOX

__all__ = [
    "Sensors",
    "smith_pokorny_cones",
    "stockman_sharpe_cones",
    "cie1931_xyz",
    "kodak_dcs200",
    "gaussian_sensors",
    "mixture",
    "WAVELENGTHS_380_780",
]

#: The SimToolbox sampling of spectral functions, 380:5:780 nm.
WAVELENGTHS_380_780 = sampling_wavelengths(380, 5, 81)


@dataclass(frozen=True, eq=False)
class Sensors:
    """A set of sensor spectral sensitivities.

    ``values`` (K, N) are responses per unit radiance in one wavelength band
    of the scene's sampling ("Watts") or probabilities of absorbing a photon
    ("Quanta").
    """

    wavelengths: np.ndarray
    values: np.ndarray
    names: tuple = ()
    unit: str = "Watts"
    name: str = ""

    def __post_init__(self):
        w = np.asarray(self.wavelengths, float).ravel()
        v = np.atleast_2d(np.asarray(self.values, float))
        if v.shape[1] != w.size:
            raise ParameterError(self.name or "sensors", f"sensitivities have {v.shape[1]} samples for {w.size} wavelengths")
        if not np.all(np.isfinite(v)):
            raise ParameterError(self.name or "sensors", "sensitivities must be finite")
        names = tuple(self.names) or tuple(f"S{i + 1}" for i in range(v.shape[0]))
        if len(names) != v.shape[0]:
            raise ParameterError(self.name or "sensors", f"{len(names)} names for {v.shape[0]} sensors")
        if self.unit not in ("Watts", "Quanta"):
            raise ParameterError("unit", f"sensitivity unit must be 'Watts' or 'Quanta', got {self.unit!r}")
        w.flags.writeable = False
        v = v.copy()
        v.flags.writeable = False
        object.__setattr__(self, "wavelengths", w)
        object.__setattr__(self, "values", v)
        object.__setattr__(self, "names", names)

    def __len__(self):
        return self.values.shape[0]

    def on(self, wavelengths):
        """Sensitivities interpolated onto ``wavelengths``, zero outside the measured range (cached, read-only)."""
        key = np.asarray(wavelengths, float).tobytes()
        cache = self.__dict__.setdefault("_on_cache", {})
        if key not in cache:
            if len(cache) > 8:
                cache.clear()
            v = resample(self.wavelengths, self.values, wavelengths)
            v.flags.writeable = False
            cache[key] = v
        return cache[key]

    def scaled(self, factors, name=None):
        f = np.broadcast_to(np.asarray(factors, float), (len(self),))
        return Sensors(self.wavelengths, self.values * f[:, None], self.names, self.unit, name or self.name)


def read_dat_sensors(path, names, name=""):
    """Sensitivities from an old-style SimToolbox ``.dat`` file, checked; errors name the file and the tag.

    Parameters
    ----------
    path : path
        The ``.dat`` file: ``#SimWavelengthSampling start step count`` and
        ``#SimData`` with one row of ``count`` values per name.
    names : sequence of str
        The sensors' names, one per row.
    name : str
        The set's name.

    Returns
    -------
    Sensors
        In "Watts".

    Raises
    ------
    FileFormatError
        Naming the file: a missing tag; a start or step that is not a
        positive finite number, a count that is not a whole number from 1 to
        :data:`~camsim_core.io.simtoolbox.MAX_SAMPLES`; data of the wrong
        size, NaN, infinite or negative (a sensor cannot record negative
        light), or a sensor that is 0 at every wavelength.
    """
    from ..errors import FileFormatError
    from ..io.simtoolbox import MAX_SAMPLES, _numbers, checked_number, checked_sensitivities, checked_wavelengths, read_tagged

    t = read_tagged(path)
    s = _numbers(t.path, "WavelengthSampling", t.require("WavelengthSampling", "start step count"))
    if s.size < 3:
        raise FileFormatError(t.path, "#SimWavelengthSampling should hold start, step and count")
    start = checked_number(t.path, "#SimWavelengthSampling start", s[:1], positive=True)
    step = checked_number(t.path, "#SimWavelengthSampling step", s[1:2], positive=True)
    count = checked_number(t.path, "#SimWavelengthSampling count", s[2:3], integer=True, positive=True)
    if count > MAX_SAMPLES:
        raise FileFormatError(t.path, f"#SimWavelengthSampling count is {count}, more than {MAX_SAMPLES}")
    wavelengths = checked_wavelengths(t.path, "#SimWavelengthSampling", start, step, count)
    data = _numbers(t.path, "Data", t.require("Data", "the sensitivities"))
    if data.size != len(names) * count:
        raise FileFormatError(t.path, f"#SimData has {data.size} values, expected {len(names)} x {count}")
    data = checked_sensitivities(t.path, "#SimData", data.reshape(len(names), count), tuple(names), wavelengths)
    try:
        return Sensors(wavelengths, data, names, "Watts", name)
    except ValueError as exc:
        raise FileFormatError(t.path, str(exc)) from None


def _dat_sensors(filename, names, name):
    return read_dat_sensors(SIMTOOLBOX / "spectra" / filename, names, name)


@lru_cache(maxsize=None)
def smith_pokorny_cones():
    """Smith-Pokorny L, M, S cone fundamentals (peak 1), 380:5:780 nm."""
    return _dat_sensors("SmithPokornyCones.dat", ("L", "M", "S"), "Smith-Pokorny cones")


@lru_cache(maxsize=None)
def stockman_sharpe_cones():
    """Stockman-Sharpe 2-degree L, M, S cone fundamentals from colour-science (its table, shipped)."""
    from .colour_science import table

    w, v = table("stockman-sharpe")
    return Sensors(w, v.T, ("L", "M", "S"), "Watts", "Stockman-Sharpe cones")


@lru_cache(maxsize=None)
def cie1931_xyz():
    """CIE 1931 2-degree colour matching functions x-bar, y-bar, z-bar from colour-science (its table, shipped)."""
    from .colour_science import table

    w, v = table("cie1931")
    return Sensors(w, v.T, ("X", "Y", "Z"), "Watts", "CIE 1931 XYZ")


@lru_cache(maxsize=None)
def kodak_dcs200(ir_filter=True):
    """Kodak DCS-200 R, G, B (Vora et al. 1997); ``ir_filter`` picks the IR-filtered measurement."""
    from ..io.simtoolbox import read_tagged

    name = "kodakdcs200_50mmIR.Scam" if ir_filter else "kodakdcs200_50mm.Scam"
    t = read_tagged(SIMTOOLBOX / "cameras" / name)
    from ..io.simtoolbox import group_numbers

    s = group_numbers(t, "WavelengthSampling", "Start"), group_numbers(t, "WavelengthSampling", "Step"), group_numbers(
        t, "WavelengthSampling", "NumberSamples"
    )
    return Sensors(sampling_wavelengths(s[0][0], s[1][0], s[2][0]), t.require("SpectralSensitivity"), ("R", "G", "B"), "Watts", "Kodak DCS-200")


def gaussian_sensors(centers, sigmas, *, wavelengths=WAVELENGTHS_380_780, peak=None, names=None):
    """Gaussian sensitivities exp(-(lambda - c)^2 / (2 sigma^2)).

    Parameters
    ----------
    centers, sigmas : array_like
        Peak wavelengths and standard deviations, nm (a scalar sigma applies to all).
    peak : float, optional
        Peak sensitivity. By default each curve has the same area as the mean
        DCS-200 curve, so that a Gaussian camera gives responses of the
        DCS-200's magnitude at the DCS-200's exposure settings.
    """
    c = np.atleast_1d(np.asarray(centers, float))
    s = np.broadcast_to(np.atleast_1d(np.asarray(sigmas, float)), c.shape)
    if np.any(s <= 0):
        raise ParameterError("sigmas", "Gaussian widths must be positive (nm)")
    w = np.asarray(wavelengths, float)
    v = np.exp(-0.5 * ((w[None, :] - c[:, None]) / s[:, None]) ** 2)
    if peak is None:
        ref = kodak_dcs200().on(w).sum(axis=1).mean()
        v = v * (ref / v.sum(axis=1, keepdims=True))
    else:
        v = v * float(peak)
    names = names or tuple(f"G{int(round(ci))}" for ci in c)
    return Sensors(w, v, tuple(names), "Watts", "Gaussian")


def common_scale(sensors, wavelengths=WAVELENGTHS_380_780):
    """Sensors on ``wavelengths`` with each curve scaled to the mean DCS-200 curve area.

    The chapter's mixture (section 5) adds cones and camera curves: this puts
    both on one scale first. Each curve is normalized to unit area (sum over
    the 380:5:780 samples), then multiplied by the mean area of the three
    DCS-200 curves, so that the mixture keeps the DCS-200's calibrated
    magnitude and its exposure settings stay meaningful at every alpha.
    """
    v = sensors.on(wavelengths)
    ref = kodak_dcs200().on(wavelengths).sum(axis=1).mean()
    return v * (ref / v.sum(axis=1, keepdims=True))


def mixture(alpha, *, cones=None, camera=None, wavelengths=WAVELENGTHS_380_780):
    """(1 - alpha) x cones + alpha x camera, after :func:`common_scale` of both sets.

    Defaults: Smith-Pokorny cones and the IR-filtered Kodak DCS-200 (chapter section 5).
    """
    a = float(alpha)
    if not 0.0 <= a <= 1.0:
        raise ParameterError("alpha", f"must lie in [0, 1], got {alpha}")
    cones = cones or smith_pokorny_cones()
    camera = camera or kodak_dcs200()
    if len(cones) != len(camera):
        raise ParameterError("mixture", f"{len(cones)} cone curves but {len(camera)} camera curves")
    v = (1 - a) * common_scale(cones, wavelengths) + a * common_scale(camera, wavelengths)
    return Sensors(wavelengths, v, camera.names, "Watts", f"mixture alpha={a:g}")
