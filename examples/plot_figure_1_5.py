"""Figure 1.5 on the shipped data: image spectra (Means x ImageFactors) against the
spectroradiometer's (refSpectra), per nm, with the best line through the origin.

Run: ``.venv/bin/python examples/plot_figure_1_5.py [OUT.png]``
"""

import sys

from camsim_core.calibration.evaluation import figure_1_5, shipped_comparison

data = [shipped_comparison(name) for name in ("BFGB_128", "Cacaphony290")]
for d in data:
    per_region = ", ".join(f"{n} {s:.3f}" for n, s in zip(d["names"], d["slopes"]))
    print(f"{d['name']}: slope {d['slope']:.3f} ({per_region})")
fig = figure_1_5(
    [d["measured"] for d in data],
    [d["image"] for d in data],
    labels=[f"{d['name']} ({len(d['names'])} region{'s' if len(d['names']) > 1 else ''})" for d in data],
    title="Figure 1.5 on the shipped data: Means x ImageFactors against refSpectra, per nm (chapter: slope 0.96)",
)
out = sys.argv[1] if len(sys.argv) > 1 else "docs/figure-1-5.png"
fig.savefig(out)
print(f"wrote {out}")
