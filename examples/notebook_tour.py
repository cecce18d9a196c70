"""camsim in a notebook: a scene, a camera's picture of it, and how far that is from what an observer sees.

A script in cells (``# %%``): open it in Jupyter or VS Code as a notebook
(jupytext reads it as one), or run it as it is:
``.venv/bin/python examples/notebook_tour.py OUT_DIR`` writes the previews
a notebook would show as HTML and PNG files into OUT_DIR (default: a
temporary folder) and prints what it did.

In a notebook, the last expression of a cell shows itself: a scene or a
camera image displays an sRGB preview (at most 256 pixels on its long side)
beside its shape, wavelengths, unit and name (``_repr_html_``).
"""

# %%
# The chapter's scene and camera: cacaphony290 (400-700 nm every 10 nm) seen by a Kodak DCS-200.
import sys
import tempfile
from pathlib import Path

import camsim_core as cs

scene = cs.load_scene("cacaphony290")
camera = cs.load_camera("kodak-dcs200-ir")
scene  # noqa: B018 (in a notebook: the scene's preview and table)

# %%
# Simulate the raw camera image (a Bayer mosaic, 8 bits), then demosaic and render it on a monitor.
raw = cs.simulate(scene, camera, distance=3.32, exposure=0.1, f_stop=11, seed=0)
monitor = cs.load_monitor("simtoolbox-test")
shown = cs.render(cs.demosaic(raw, "bilinear"), monitor)
raw  # noqa: B018 (the mosaic, each pixel in its sensor's colour)

# %%
# The ideal image: what a human observer sees of the same scene on the same monitor.
ideal = cs.ideal_image(scene, camera, monitor, distance=3.32)
shown  # noqa: B018

# %%
# S-CIELAB: the colour difference per pixel after blurring both images as the eye does.
de = cs.metrics.scielab(shown, ideal, cs.metrics.samples_per_degree(raw),
                        cs.rendering.white_xyz(monitor), monitor=monitor)
print(f"{raw.data.shape} raw, mean S-CIELAB dE {de.mean():.2f}")

# %%
# The explorer, inline, for this scene and camera (needs the [app] extra; in a notebook, make it
# the cell's last expression to show it):
#
#     import camsim_explorer
#     camsim_explorer.show(scene="cacaphony290", camera="kodak-dcs200-ir")

# %%
# Outside a notebook: write what the cells above would show.
if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="camsim-tour-"))
    out.mkdir(parents=True, exist_ok=True)
    for name, thing in (("scene", scene), ("raw", raw), ("rendered", shown), ("ideal", ideal)):
        (out / f"{name}.html").write_text(thing._repr_html_(), encoding="utf-8")
        (out / f"{name}.png").write_bytes(thing._repr_png_())
    print(f"previews written to {out}")
