"""Draw the slanted-edge MTF of the simulated Kodak DCS-200 (bilinear demosaic) beside a full-colour camera.

Run: ``.venv/bin/python examples/plot_mtf.py docs/mtf-dcs200.png``.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import camsim_core as cs  # noqa: E402
from camsim_core.metrics.report import quality_report  # noqa: E402


def main(out="mtf-dcs200.png"):
    cam = cs.load_camera("kodak-dcs200-ir")
    scene = cs.load_scene("slanted-edge")
    bayer = quality_report(scene, cam, ("mtf",), exposure=cs.auto_exposure(scene, cam))["mtf"]
    full = cam.replace(mosaic=None)
    ideal = quality_report(scene, full, ("mtf",), exposure=cs.auto_exposure(scene, full))["mtf"]["luminance"]
    fig, ax = plt.subplots(figsize=(6.4, 4))
    for name, colour in (("R", "tab:red"), ("G", "tab:green"), ("B", "tab:blue"), ("luminance", "black")):
        v = bayer[name]
        ax.plot(v["frequency"], v["mtf"], color=colour, lw=2.5 if name == "luminance" else 1.2,
                label=f"DCS-200 {name}: MTF50 {v['mtf50']:.3f}")
    ax.plot(ideal["frequency"], ideal["mtf"], color="gray", ls="--", label=f"no mosaic (pixel aperture): MTF50 {ideal['mtf50']:.3f}")
    ax.axvline(0.5, color="gray", ls=":", lw=1)
    ax.set(xlim=(0, 1), ylim=(0, 1.05), xlabel="cycles per pixel", ylabel="MTF",
           title="Slanted-edge MTF (ISO 12233 e-SFR), simulated Kodak DCS-200, bilinear demosaic")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)


if __name__ == "__main__":
    main(*sys.argv[1:])
