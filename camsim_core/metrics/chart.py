"""Colour accuracy on the Macbeth chart: per-patch CIEDE2000 of a rendered chart against a reference.

Patches are found from the chart generator's known layout
(:func:`~camsim_core.scene.macbeth_scene`: 4 x 6 patches of ``patch_size``
scene pixels with ``border`` pixels of gap), scaled from the scene's size
to the camera image's (the camera's array must see the whole chart, as at
the default settings). Each patch's central part (``margin`` of its width
trimmed from every side, away from blurred or demosaiced edges) is averaged
in XYZ, turned into CIELAB and compared with colour-science's CIEDE2000.
Automatic detection of a photographed chart (``colour-checker-detection``)
is not used: it needs OpenCV, and simulated charts have a known layout.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .cielab import delta_e_lab, xyz_to_lab

__all__ = ["macbeth_patch_boxes", "chart_delta_e", "macbeth_delta_e", "patch_map"]


def macbeth_patch_boxes(image_shape, scene_shape=None, *, patch_size=16, border=4, margin=0.25):
    """(y0, y1, x0, x1) pixel boxes of the 24 patches in an image of ``image_shape``, row by row."""
    step = patch_size + border
    if scene_shape is None:
        scene_shape = (border + 4 * step, border + 6 * step)
    sy = image_shape[0] / scene_shape[0]
    sx = image_shape[1] / scene_shape[1]
    if not 0 <= margin < 0.5:
        raise ParameterError("margin", f"must lie in [0, 0.5), got {margin}")
    boxes = []
    for i in range(24):
        row, col = divmod(i, 6)
        y0 = border + row * step + margin * patch_size
        x0 = border + col * step + margin * patch_size
        y1 = y0 + (1 - 2 * margin) * patch_size
        x1 = x0 + (1 - 2 * margin) * patch_size
        box = (int(np.ceil(y0 * sy)), int(np.floor(y1 * sy)), int(np.ceil(x0 * sx)), int(np.floor(x1 * sx)))
        if box[1] <= box[0] or box[3] <= box[2]:
            raise ParameterError("image", f"is {image_shape[0]} x {image_shape[1]}: too small for patch {i + 1} to keep a pixel")
        boxes.append(box)
    return boxes


def _patch_means(xyz, boxes):
    a = np.asarray(xyz, float)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ParameterError("xyz", f"expected an (H, W, 3) XYZ image, got shape {a.shape}")
    return np.stack([a[y0:y1, x0:x1].reshape(-1, 3).mean(axis=0) for y0, y1, x0, x1 in boxes])


def chart_delta_e(xyz, reference_xyz, boxes, *, white, reference_white=None, method="CIE 2000"):
    """Per-patch colour difference of two XYZ images (cd/m^2) over ``boxes``.

    Returns ``{"per_patch": (P,), "mean", "max", "lab", "reference_lab", "boxes"}``.
    """
    ref_white = white if reference_white is None else reference_white
    lab = xyz_to_lab(_patch_means(xyz, boxes), white)
    ref = xyz_to_lab(_patch_means(reference_xyz, boxes), ref_white)
    de = np.asarray(delta_e_lab(lab, ref, method), float)
    return {"per_patch": de, "mean": float(de.mean()), "max": float(de.max()), "lab": lab, "reference_lab": ref,
            "boxes": boxes}


def macbeth_delta_e(rendered, reference, monitor, *, scene_shape=None, patch_size=16, border=4, margin=0.25,
                    method="CIE 2000"):
    """Per-patch dE (CIEDE2000 by default) of a rendered Macbeth chart against a rendered reference (the ideal image).

    Both are rendered monitor images of the chart of ``scene_shape`` (the
    default :func:`~camsim_core.scene.macbeth_scene` layout unless given),
    shown on ``monitor``, whose white is the CIELAB white.
    """
    from ..monitor import load_monitor
    from ..rendering import to_xyz, white_xyz

    mon = load_monitor(monitor)
    if tuple(rendered.shape) != tuple(reference.shape):
        raise ParameterError("reference", f"is {reference.shape}, the rendered chart {rendered.shape}: render both at one geometry")
    boxes = macbeth_patch_boxes(rendered.shape, scene_shape, patch_size=patch_size, border=border, margin=margin)
    return chart_delta_e(to_xyz(rendered, mon), to_xyz(reference, mon), boxes, white=white_xyz(mon), method=method)


def patch_map(shape, boxes, values):
    """An (H, W) map with each box filled with its value and NaN elsewhere (to draw a patch dE map)."""
    out = np.full(tuple(shape)[:2], np.nan)
    for (y0, y1, x0, x1), v in zip(boxes, np.asarray(values, float)):
        out[y0:y1, x0:x1] = v
    return out
