"""Dark subtraction (chapter section 2): each plane minus the dark frame of its own exposure time.

Dark frames (shutter closed) hold the camera's offset and its fixed pattern
for one exposure duration; subtracting the frame of the same exposure, pixel
by pixel, gives the *raw hyperspectral image* of the chapter.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["dark_for", "subtract_darks", "DARKER_PLANE_SHARE"]

#: A plane darker than its own dark frame at more than this share of its pixels is refused: with no
#: light a plane is below its dark frame at about half of them (noise); at nearly all, the files are mixed up.
DARKER_PLANE_SHARE = 0.9


def dark_for(exposure, darks, what="plane"):
    """The dark frame (H, W) of ``darks`` {exposure s: frame} taken at ``exposure`` seconds."""
    for t, frame in darks.items():
        if abs(t - exposure) <= 1e-6 * max(abs(t), abs(exposure)):
            return frame
    have = ", ".join(f"{t:g}" for t in sorted(darks)) or "none"
    raise ParameterError(what, f"no dark frame for an exposure of {exposure:g} s (dark frames for: {have} s)")


def subtract_darks(planes, exposures, darks, wavelengths=None):
    """Planes (N, H, W) minus, for each, the dark frame of its exposure time (float array)."""
    planes = np.asarray(planes, float)
    out = np.empty_like(planes)
    for k, t in enumerate(exposures):
        what = f"the {wavelengths[k]:g} nm plane" if wavelengths is not None else f"plane {k}"
        dark = dark_for(t, darks, what)
        if dark.shape != planes.shape[1:]:
            raise ParameterError(what, f"dark frame is {dark.shape}, plane is {planes.shape[1:]}")
        out[k] = planes[k] - dark
        if out[k].size >= 16 and np.mean(out[k] < 0) > DARKER_PLANE_SHARE:
            raise ParameterError(
                what, f"its dark frame ({t:g} s) is brighter than the plane at {100 * np.mean(out[k] < 0):.0f} % of "
                      f"the pixels (median {np.median(dark):.4g} against {np.median(planes[k]):.4g}): are the plane "
                      "and dark files swapped in the manifest?")
    return out
