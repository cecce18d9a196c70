"""Monitors: phosphor spectra and gamma tables (chapter section 4.2, Eqs. 1.3-1.4).

References
----------
* ``simtoolbox-test``: SimToolbox ``monitors/SimToolboxTest.Smon`` (a
  Psychtoolbox calibration, 380:4:780 nm, 1024-entry gamma tables).
* ``brainard-crt``: colour-science's 'Typical CRT Brainard 1997' primaries,
  with a 2.2 power-law gamma table (the dataset has none of its own).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from .datasets import SIMTOOLBOX
from .errors import FileFormatError, ParameterError
from .spectra import resample_power, sampling_wavelengths

__all__ = ["Monitor", "load_monitor", "MONITOR_NAMES"]

MONITOR_NAMES = ("simtoolbox-test", "brainard-crt")


@dataclass(frozen=True, eq=False)
class Monitor:
    """A calibrated display.

    Attributes
    ----------
    wavelengths : ndarray (N,)
        nm, sampling of the spectra.
    primaries : ndarray (N, 3)
        Spectral power of each phosphor at full linear setting, per band of
        ``wavelengths`` (the columns of B_M in Eq. 1.3).
    gamma_input : ndarray (M,)
        Settings in [0, 1] at which the gamma table was measured.
    gamma_table : ndarray (M, 3)
        Linear output (0-1) of each phosphor at those settings.
    ambient : ndarray (N,)
    bits : int
        Depth of the frame buffer (8: values 0-255).
    """

    wavelengths: np.ndarray
    primaries: np.ndarray
    gamma_input: np.ndarray
    gamma_table: np.ndarray
    ambient: np.ndarray | None = None
    background: tuple = (0.5, 0.5, 0.5)
    bits: int = 8
    name: str = ""

    def __post_init__(self):
        w = np.asarray(self.wavelengths, float).ravel()
        p = np.asarray(self.primaries, float)
        if p.shape != (w.size, 3):
            raise ParameterError(self.name or "monitor", f"primaries must be ({w.size}, 3), got {p.shape}")
        gi = np.asarray(self.gamma_input, float).ravel()
        gt = np.asarray(self.gamma_table, float)
        if gt.shape != (gi.size, 3):
            raise ParameterError(self.name or "monitor", f"gamma table must be ({gi.size}, 3), got {gt.shape}")
        # a table inverted by interpolation must be non-decreasing
        gt = np.maximum.accumulate(gt, axis=0)
        for a in (w, p, gi, gt):
            a.flags.writeable = False
        object.__setattr__(self, "wavelengths", w)
        object.__setattr__(self, "primaries", p)
        object.__setattr__(self, "gamma_input", gi)
        object.__setattr__(self, "gamma_table", gt)

    @property
    def levels(self):
        return 2 ** self.bits

    def primaries_on(self, wavelengths):
        """B_M on another sampling, kept in per-band units (scaled by the ratio of band widths)."""
        return resample_power(self.wavelengths, self.primaries.T, wavelengths).T

    def linear_to_settings(self, linear):
        """Gamma correction by table lookup: linear intensities (..., 3) in [0, 1] -> settings in [0, 1]."""
        lin = np.clip(np.asarray(linear, float), 0.0, 1.0)
        out = np.empty_like(lin)
        for c in range(3):
            table = self.gamma_table[:, c] / self.gamma_table[-1, c]
            # strictly increasing x for interp: drop flat steps
            keep = np.concatenate([[True], np.diff(table) > 0])
            out[..., c] = np.interp(lin[..., c], table[keep], self.gamma_input[keep])
        return out

    def settings_to_linear(self, settings):
        """The gamma table forward: settings (..., 3) in [0, 1] -> linear intensities in [0, 1]."""
        s = np.clip(np.asarray(settings, float), 0.0, 1.0)
        out = np.empty_like(s)
        for c in range(3):
            table = self.gamma_table[:, c] / self.gamma_table[-1, c]
            out[..., c] = np.interp(s[..., c], self.gamma_input, table)
        return out

    def describe(self):
        return {"name": self.name, "kind": "monitor", "wavelengths_nm": f"{self.wavelengths[0]:g}-{self.wavelengths[-1]:g}",
                "bits": self.bits, "gamma_entries": int(self.gamma_input.size)}


def read_smon(path):
    """Read a SimToolbox ``.Smon`` monitor file."""
    from .io.simtoolbox import group_numbers, read_tagged

    path = Path(path)
    t = read_tagged(path)
    start = group_numbers(t, "WavelengthSampling", "Start")[0]
    step = group_numbers(t, "WavelengthSampling", "Step")[0]
    count = group_numbers(t, "WavelengthSampling", "NumberSamples")[0]
    w = sampling_wavelengths(start, step, count)
    prim = np.asarray(t.require("EmissionSpectra", "phosphor spectra"), float)
    if prim.shape[0] != w.size:
        raise FileFormatError(path, f"#Sim#EmissionSpectra has {prim.shape[0]} rows for {w.size} wavelengths")
    if prim.shape[1] != 3:
        raise FileFormatError(path, f"#Sim#EmissionSpectra must have 3 columns (phosphors), has {prim.shape[1]}")
    gi = np.asarray(t.require("GammaInput"), float).ravel()
    gt = np.asarray(t.require("GammaTable"), float)
    if gt.shape != (gi.size, 3):
        raise FileFormatError(path, f"#Sim#GammaTable must be {gi.size} x 3 to match #Sim#GammaInput, is {gt.shape[0]} x {gt.shape[1]}")
    amb = t.get_tag("AmbientSpectrum")
    bg = t.get_tag("BgColor")
    return Monitor(
        w, prim, gi, gt,
        None if amb is None else np.asarray(amb, float).ravel(),
        tuple(np.asarray(bg, float).ravel()) if bg is not None else (0.5, 0.5, 0.5),
        8,
        path.stem,
    )


@lru_cache(maxsize=None)
def _shipped(name):
    if name == "simtoolbox-test":
        m = read_smon(SIMTOOLBOX / "monitors" / "SimToolboxTest.Smon")
        return Monitor(m.wavelengths, m.primaries, m.gamma_input, m.gamma_table, m.ambient, m.background, 8, name)
    import colour

    p = colour.MSDS_DISPLAY_PRIMARIES["Typical CRT Brainard 1997"]
    gi = np.linspace(0, 1, 1024)
    gt = np.repeat((gi ** 2.2)[:, None], 3, axis=1)
    return Monitor(p.wavelengths, p.values, gi, gt, None, (0.5, 0.5, 0.5), 8, name)


def load_monitor(name_or_path):
    """A :class:`Monitor` from a shipped name (``MONITOR_NAMES``) or an ``.Smon`` path."""
    if isinstance(name_or_path, Monitor):
        return name_or_path
    key = str(name_or_path)
    if key.lower() in MONITOR_NAMES:
        return _shipped(key.lower())
    p = Path(key)
    if not p.exists():
        raise FileFormatError(p, f"no such file, and not a shipped monitor name ({', '.join(MONITOR_NAMES)})")
    if p.suffix.lower() != ".smon":
        raise FileFormatError(p, "unknown monitor format: expected a SimToolbox .Smon file")
    return read_smon(p)
