"""Simulate the Kodak DCS-200 raw image of the chapter's real-versus-simulated test.

The chapter's Figure 1.8 setting: the Cacaphony hyperspectral scene seen by a
DCS-200 with the IR filter at 3.32 m, 0.1 s, f/11. Writes the 8-bit Bayer raw
(as the camera would) and a view of it with each pixel coloured by its
sensor, and the green plane bilinearly filled, side by side.

Run: ``.venv/bin/python examples/plot_dcs200_raw.py [OUT.png]``
"""

import sys

import numpy as np
from matplotlib.figure import Figure

import camsim_core as cs
from camsim_core.simulation import tile_index_map

scene = cs.load_scene("cacaphony290")
camera = cs.load_camera("kodak-dcs200-ir")
raw = cs.simulate(scene, camera, distance=3.32, exposure=0.1, f_stop=11)

# each pixel shown in its sensor's colour (R, G, B), at its digital value
index = tile_index_map(raw.tile, raw.data.shape)
coloured = np.zeros(raw.data.shape + (3,))
for k in range(3):
    coloured[..., k] = np.where(index == k, raw.data / 255.0, 0.0)

fig = Figure(figsize=(10, 3.6), dpi=110)
ax1, ax2 = fig.subplots(1, 2)
ax1.imshow(np.clip(coloured * 1.4, 0, 1), interpolation="nearest")
ax1.set_title(f"simulated DCS-200 raw, {raw.data.shape[0]} x {raw.data.shape[1]}, 8-bit Bayer")
zoom = coloured[100:124, 150:182]
ax2.imshow(np.clip(zoom * 1.4, 0, 1), interpolation="nearest")
ax2.set_title("detail: the GR/BG tile")
for ax in (ax1, ax2):
    ax.set_xticks([])
    ax.set_yticks([])
fig.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "docs/dcs200-raw.png"
fig.savefig(out)
print(f"wrote {out}")
