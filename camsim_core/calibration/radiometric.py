"""Radiometric calibration (chapter section 2) and the illuminant from a white reference.

A spectroradiometer reading of one small, nearly uniform region gives the
radiance at each wavelength; dividing it by the scatter-corrected image
values in the same region gives one factor per plane that brings the plane
into W/sr/m^2.

Units follow the chapter (after Eq. 1.3): the calibrated scene holds power
per wavelength band of its own sampling. A spectroradiometer reports power
per nm (or per band of *its* sampling); :func:`reference_per_band` folds the
plane spacing into the units, so the factor 2 between 10 nm planes and a
5 nm instrument is accounted for.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, ParameterError
from ..spectra import resample

__all__ = ["read_reference_csv", "reference_per_band", "calibration_factors", "band_widths"]


def band_widths(wavelengths):
    """Width (nm) of each sample's band: the local spacing (``np.gradient``)."""
    w = np.asarray(wavelengths, float)
    return np.gradient(w) if w.size > 1 else np.ones(1)


def read_reference_csv(path):
    """Read a reference spectrum: ``(wavelengths nm, radiance W/sr/m^2/nm)``.

    CSV with a header line ``wavelength,radiance`` and one row per sample.
    A first line ``# unit: per band`` says the values are per band of the
    file's own sampling (converted to per nm here); the default is per nm.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise FileFormatError(path, f"cannot read the reference spectrum: {exc.strerror or exc}") from None
    per_band = False
    rows = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            low = s.lower().replace(" ", "")
            if low.startswith("#unit:"):
                per_band = "perband" in low
            continue
        rows.append(s)
    data = []
    for i, row in enumerate(csv.reader(rows)):
        try:
            data.append([float(row[0]), float(row[1])])
        except (ValueError, IndexError):
            if i == 0:
                continue  # the header
            raise FileFormatError(path, f"row {i + 1} should hold 'wavelength,radiance' numbers, got {row!r}") from None
    if len(data) < 2:
        raise FileFormatError(path, "needs at least two 'wavelength,radiance' rows")
    a = np.array(data)
    order = np.argsort(a[:, 0])
    w, v = a[order, 0], a[order, 1]
    if np.any(np.diff(w) <= 0):
        raise FileFormatError(path, "wavelengths must be distinct")
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise FileFormatError(path, "radiances must be finite and non-negative")
    if per_band:
        v = v / band_widths(w)
    return w, v


def reference_per_band(ref_wavelengths, ref_per_nm, wavelengths):
    """The reference resampled onto the plane ``wavelengths`` and expressed per plane band (W/sr/m^2 per band)."""
    w = np.asarray(wavelengths, float)
    rw = np.asarray(ref_wavelengths, float)
    if w.min() < rw.min() - 1e-9 or w.max() > rw.max() + 1e-9:
        raise ParameterError("reference", f"spectrum covers {rw.min():g}-{rw.max():g} nm, the planes {w.min():g}-{w.max():g} nm")
    return resample(rw, ref_per_nm, w) * band_widths(w)


def calibration_factors(region_values, reference, wavelengths):
    """Per-plane factors ``reference / region_values`` (W/sr/m^2 per band per count)."""
    v = np.asarray(region_values, float)
    bad = v <= 0
    if np.any(bad):
        wl = np.asarray(wavelengths)[bad]
        raise ParameterError("reference region", "has no signal after dark and scatter correction at " + ", ".join(f"{x:g}" for x in wl) + " nm; choose a brighter region")
    return np.asarray(reference, float) / v
