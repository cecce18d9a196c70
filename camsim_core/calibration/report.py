"""Evaluation report of a calibration: the chapter's Figures 1.3, 1.4, 1.5 and a JSON summary.

Figures are drawn on :class:`matplotlib.figure.Figure` with the Agg canvas
(no GUI) and written atomically as PNG.

* Figure 1.3: luminance image (683 lm/W x CIE 1931 y-bar weighted sum of the
  calibrated planes, cd/m^2) without and with registration;
* Figure 1.4: image spectra (circles) against the measured spectra (lines)
  of the reference region and any further measured regions;
* Figure 1.5: all those points with the best line through the origin.
* ``calibration.json``: per plane the wavelength, exposure, f-stop, the
  registration transform and residual, the scatter slope and intercept and
  the radiometric factor.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..io.output import atomic_write

__all__ = ["luminance", "figure_1_3", "figure_1_4", "write_report", "summary"]


def _figure(size):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    return fig


def luminance(cube, wavelengths):
    """Luminance (cd/m^2) of an (H, W, N) radiance cube per band: 683 sum_i ybar_i L_i."""
    from ..datasets.sensors import cie1931_xyz

    ybar = cie1931_xyz().on(np.asarray(wavelengths, float))[1]
    return 683.0 * np.tensordot(np.asarray(cube, float), ybar, axes=([-1], [0]))


def figure_1_3(result):
    """Luminance without registration (left) and with it (right): chapter Figure 1.3."""
    wls = result.scene.wavelengths
    offset = result.intercept if result.intercept is not None else np.zeros(wls.size)
    unregistered = np.moveaxis((result.raw - offset[:, None, None]) * result.factors[:, None, None], 0, -1)
    lum = [luminance(unregistered, wls), luminance(result.scene.data, wls)]
    top = max(float(np.percentile(v, 99.5)) for v in lum) or 1.0
    h, w = lum[0].shape
    fig = _figure((2 * 4.5, 4.5 * h / w + 0.8))
    for i, (v, t) in enumerate(zip(lum, ("(a) luminance, without registration", "(b) luminance, with registration"))):
        ax = fig.add_subplot(1, 2, i + 1)
        ax.imshow(np.clip(v / top, 0, 1), cmap="gray", vmin=0, vmax=1, interpolation="nearest")
        ax.set_title(t, fontsize=10)
        ax.set_axis_off()
    fig.tight_layout()
    return fig


def figure_1_4(wavelengths, measured, image, names):
    """Measured spectra (lines) and image spectra (circles) per region: chapter Figure 1.4 (per nm)."""
    r = len(names)
    cols = min(r, 4)
    rows = -(-r // cols)
    fig = _figure((3.2 * cols, 2.8 * rows))
    for k in range(r):
        ax = fig.add_subplot(rows, cols, k + 1)
        ax.plot(wavelengths, measured[k], "k-", lw=1.2, label="measured")
        ax.plot(wavelengths, image[k], "o", mfc="none", ms=4, label="image")
        ax.set_title(names[k], fontsize=9)
        ax.set_xlabel("wavelength (nm)", fontsize=8)
        ax.set_ylabel("W/sr/m$^2$/nm", fontsize=8)
        ax.tick_params(labelsize=7)
    fig.axes[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def summary(result):
    """A JSON-ready dict of the calibration's per-plane numbers."""
    m = result.manifest
    planes = []
    for k, wl in enumerate(result.scene.wavelengths):
        reg = result.registration[k]
        entry = {
            "wavelength_nm": float(wl),
            "transform": reg.transform.as_dict(),
            "edge_residual_px": None if not np.isfinite(reg.residual) else float(reg.residual),
            "edges_matched": None if not np.isfinite(reg.matched) else float(reg.matched),
            "factor": float(result.factors[k]),
        }
        if m is not None:
            entry.update(exposure_s=m.planes[k].exposure, f_stop=m.planes[k].f_stop, file=m.planes[k].file.name)
        if result.intercept is not None:
            entry.update(scatter_slope=float(result.slope[k]), scatter_intercept=float(result.intercept[k]))
        planes.append(entry)
    out = {
        "scene": result.scene.name,
        "size_px": list(result.scene.data.shape[:2]),
        "interior_box": result.extra.get("interior_box"),
        "negative_values_clipped": result.clipped,
        "planes": planes,
    }
    comp = result.extra.get("comparison")
    if comp is not None:
        out["figure_1_5_slope"] = comp["slope"]
        out["regions_compared"] = comp["names"]
    return out


def _save_png(fig, path):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    atomic_write(path, lambda f: f.write(buf.getvalue()))


def write_report(result, folder):
    """Write ``figure-1-3.png``, ``figure-1-4.png``, ``figure-1-5.png`` and ``calibration.json`` into ``folder``."""
    from .evaluation import figure_1_5

    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ParameterError("report", f"{folder} exists and is not a folder")
    folder.mkdir(parents=True, exist_ok=True)
    _save_png(figure_1_3(result), folder / "figure-1-3.png")
    comp = result.extra.get("comparison")
    if comp is not None:
        wls = result.scene.wavelengths
        _save_png(figure_1_4(wls, comp["measured"], comp["image"], comp["names"]), folder / "figure-1-4.png")
        note = " (reference region only: 1 by construction)" if len(comp["names"]) == 1 else ""
        _save_png(figure_1_5(comp["measured"], comp["image"], title=f"Image against measured spectra{note}"), folder / "figure-1-5.png")
    text = json.dumps(summary(result), indent=1)
    atomic_write(folder / "calibration.json", lambda f: f.write(text.encode()))
    return folder
