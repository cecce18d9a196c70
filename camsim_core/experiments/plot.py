"""Figures of the experiments with matplotlib's object API and the Agg canvas (no pyplot, no GUI)."""

from __future__ import annotations

import io
import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ..io.output import atomic_write

__all__ = ["sensors_figure", "save_png"]

_PANEL_TITLES = {"baseline": "Baseline rendering", "illuminant": "Illuminant-based rendering"}


def sensors_figure(summary, *, title=None, methods=("baseline", "illuminant")):
    """Figure 1.14: mean S-CIELAB error against alpha, one panel per rendering method, one curve per noise sigma.

    ``summary`` rows are those of :func:`camsim_core.experiments.sensors.summarize`
    (keys alpha, sigma, method, mean, std, n) for one scene; error bars show
    the standard deviation over seeds when there are several. Both panels
    share the y axis, as in the chapter.
    """
    fig = Figure(figsize=(9.0, 3.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(methods), sharey=True, squeeze=False)[0]
    sigmas = sorted(dict.fromkeys(r["sigma"] for r in summary))
    markers = "osd^v<>"
    for ax, method in zip(axes, methods):
        for i, sigma in enumerate(sigmas):
            rows = sorted((r for r in summary if r["method"] == method and r["sigma"] == sigma), key=lambda r: r["alpha"])
            if not rows:
                continue
            a = np.array([r["alpha"] for r in rows])
            m = np.array([r["mean"] for r in rows])
            s = np.array([r["std"] if math.isfinite(r["std"]) else 0.0 for r in rows])
            ax.errorbar(a, m, yerr=s if np.any(s > 0) else None, marker=markers[i % len(markers)], ms=4, capsize=2,
                        label=f"noise σ = {sigma:g}")
        ax.set_title(_PANEL_TITLES.get(method, method))
        ax.set_xlabel("α (0 = human cones, 1 = Kodak DCS-200)")
        ax.set_xlim(-0.03, 1.03)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("mean S-CIELAB ΔE*ab")
    axes[0].set_ylim(bottom=0)
    axes[-1].legend(loc="upper left", fontsize="small")
    n = max((r["n"] for r in summary), default=1)
    fig.suptitle("Effect of sensor choice (chapter Figure 1.14)" + (f", {title}" if title else "")
                 + (f", mean ± std over {n} seeds" if n > 1 else ""), fontsize="medium")
    return fig


def save_png(fig, path, dpi=120):
    """Write ``fig`` as a PNG atomically (never a partial file)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    data = buf.getvalue()
    return atomic_write(path, lambda f: f.write(data))
