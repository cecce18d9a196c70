"""Image spectra against spectroradiometer readings (chapter Figures 1.4 and 1.5).

Figure 1.5 plots, for every region and wavelength, the power in the
calibrated hyperspectral image (y) against the directly measured power (x),
with the best line through the origin; the chapter's slope is 0.96 (the
image slightly low). Spectra on different samplings are compared *per nm*
(the chapter's convention after Eq. 1.3 folds the band width into the
units): a 10 nm plane holds twice the power of a 5 nm spectroradiometer
band.

:func:`shipped_comparison` does this for the shipped SimToolbox scenes:
``Means.mat`` (mean raw plane values of a few regions, 400:10:700 nm) times
the header's ``#Sim#ImageFactors`` against ``refSpectra.mat`` (the lab's
readings of the same regions, 380:5:780 nm).
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["slope_through_origin", "region_comparison", "shipped_comparison", "figure_1_5"]


def slope_through_origin(x, y):
    """Least-squares slope ``k`` of ``y = k x`` (no intercept): ``sum(x y) / sum(x^2)``."""
    x = np.asarray(x, float).ravel()
    y = np.asarray(y, float).ravel()
    if x.shape != y.shape or x.size == 0:
        raise ParameterError("x, y", f"need two arrays of the same non-zero size, got {x.size} and {y.size}")
    sxx = float(x @ x)
    if sxx <= 0:
        raise ParameterError("x", "all zero: no slope")
    return float(x @ y) / sxx


def region_comparison(scene, boxes, measured_per_band):
    """(image (R, N), measured (R, N)) per nm: the scene's mean spectrum in each box beside the readings.

    ``measured_per_band`` (R, N) are on the scene's sampling, per band.
    """
    from .radiometric import band_widths

    bw = band_widths(scene.wavelengths)
    img = np.stack([scene.data[t:b, l:r].mean(axis=(0, 1)) for (t, l, b, r) in boxes])
    return img / bw, np.asarray(measured_per_band, float) / bw


def shipped_comparison(name):
    """Figure 1.5 data for a shipped scene folder (``"BFGB_128"`` or ``"Cacaphony290"``).

    Returns a dict: ``wavelengths`` (31,), ``measured`` and ``image`` (R, 31)
    in W/sr/m^2/nm, ``names`` of the regions, ``slope`` over all points, and
    per region ``slopes`` and ``correlations``.
    """
    from scipy.io import loadmat

    from ..datasets import SIMTOOLBOX
    from ..io.simtoolbox import group_numbers, read_tagged
    from ..spectra import resample, sampling_wavelengths

    folder = SIMTOOLBOX / name
    header = read_tagged(folder / f"{name}.Simg")
    start = group_numbers(header, "WavelengthSampling", "Start")[0]
    step = group_numbers(header, "WavelengthSampling", "Step")[0]
    count = int(group_numbers(header, "WavelengthSampling", "NumberSamples")[0])
    wls = sampling_wavelengths(start, step, count)
    factors = np.asarray(header.require("ImageFactors"), float).ravel()
    means = np.asarray(loadmat(folder / "Means.mat")["means"], float)  # (31, R) raw units
    ref = loadmat(folder / "refSpectra.mat")
    spectra = np.asarray(ref["refSpectra"], float)  # (81, R) per 5 nm band, 380:5:780
    names = [str(np.ravel(n)[0]) for n in np.ravel(ref["refNames"])] if "refNames" in ref else [f"region {i + 1}" for i in range(spectra.shape[1])]
    ref_wls = sampling_wavelengths(380, 5, spectra.shape[0])
    image = (means * factors[:, None]).T / step  # per plane band -> per nm
    measured = resample(ref_wls, spectra.T, wls) / 5.0  # per 5 nm band -> per nm
    slopes = [slope_through_origin(m, i) for m, i in zip(measured, image)]
    corrs = [float(np.corrcoef(m, i)[0, 1]) for m, i in zip(measured, image)]
    return {
        "name": name,
        "wavelengths": wls,
        "measured": measured,
        "image": image,
        "names": names,
        "slope": slope_through_origin(measured, image),
        "slopes": slopes,
        "correlations": corrs,
    }


def figure_1_5(measured, image, *, labels=None, title="", ax=None):
    """Figure 1.5: image power against measured power, every region and wavelength, with
    the best line through the origin and its slope. Returns the matplotlib ``Figure``
    (Agg canvas, no GUI). ``measured``/``image``: lists of (R_i, N) arrays, one per data set."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ms = measured if isinstance(measured, (list, tuple)) else [measured]
    ims = image if isinstance(image, (list, tuple)) else [image]
    labels = labels or [None] * len(ms)
    if ax is None:
        fig = Figure(figsize=(5.5 * len(ms), 5))
        FigureCanvasAgg(fig)
        axes = [fig.add_subplot(1, len(ms), i + 1) for i in range(len(ms))]
    else:
        fig, axes = ax.figure, [ax]
    for a, m, i, lab in zip(axes, ms, ims, labels):
        k = slope_through_origin(m, i)
        a.plot(np.ravel(m), np.ravel(i), "o", mfc="none", ms=4)
        top = max(np.max(m), np.max(i)) * 1.05
        a.plot([0, top], [0, k * top], "k-", lw=1)
        a.plot([0, top], [0, top], ":", color="0.6", lw=1)
        a.set_xlim(0, top)
        a.set_ylim(0, top)
        a.set_aspect("equal")
        a.set_xlabel("measured power (W/sr/m$^2$/nm)")
        a.set_ylabel("power from the hyperspectral image (W/sr/m$^2$/nm)")
        a.set_title(f"{lab + ': ' if lab else ''}slope {k:.3f}")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
