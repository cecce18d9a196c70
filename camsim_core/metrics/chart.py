"""Colour accuracy on the Macbeth chart: per-patch CIEDE2000 of a rendered chart against a reference.

Patches are found from the chart generator's known layout
(:func:`~camsim_core.scene.macbeth_scene`: 4 x 6 patches of ``patch_size``
scene pixels with ``border`` pixels of gap), scaled from the scene's size
to the camera image's (the camera's array must see the whole chart, as at
the default settings). Each patch's central part (``margin`` of its width
trimmed from every side, away from blurred or demosaiced edges) is averaged
in XYZ, turned into CIELAB and compared with colour-science's CIEDE2000.
A chart anywhere else in an image (a photo made into a scene, an uploaded
scene) is found by :func:`find_macbeth_patches` with colour-science's
``colour-checker-detection`` (segmentation, OpenCV); ``macbeth_delta_e(...,
patches="detect")`` uses it and falls back on the layout, saying so, where
the detector is missing or finds no chart.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from .cielab import delta_e_lab, xyz_to_lab

__all__ = ["macbeth_patch_boxes", "find_macbeth_patches", "chart_delta_e", "macbeth_delta_e", "patch_map"]


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


def find_macbeth_patches(rgb, *, margin=0.35):
    """(y0, y1, x0, x1) boxes of the 24 patches of a ColorChecker Classic found in an image, or None.

    ``rgb``: an (H, W, 3) image, display-encoded (a rendered image's monitor
    settings, 0-255, or values in [0, 1]). The chart is found by
    ``colour_checker_detection.detect_colour_checkers_segmentation`` (which
    also turns it to the reference orientation); each patch's central part,
    ``margin`` of the patch pitch trimmed from every side, is mapped back
    through the detector's perspective transform to the image, and the box
    inside its four corners is kept (the patches of a chart tilted by a few
    degrees stay inside their swatch). None when the package (or OpenCV's
    system libraries) is missing, or no chart is found.
    """
    try:
        import cv2
        from colour_checker_detection import SETTINGS_SEGMENTATION_COLORCHECKER_CLASSIC as settings
        from colour_checker_detection import detect_colour_checkers_segmentation
    except (ImportError, OSError):  # not installed, or OpenCV without its system libraries (libGL)
        return None
    if not 0 <= margin < 0.5:
        raise ParameterError("margin", f"must lie in [0, 0.5), got {margin}")
    a = np.asarray(rgb, np.float32)
    if a.ndim != 3 or a.shape[2] < 3:
        raise ParameterError("rgb", f"expected an (H, W, 3) image, got shape {a.shape}")
    a = np.ascontiguousarray(a[..., :3])
    top = float(np.nanmax(a)) if a.size else 0.0
    if not np.isfinite(top) or top <= 0:
        return None
    if top > 1.0:
        a = a / 255.0 if top <= 255.0 else a / top
    found = detect_colour_checkers_segmentation(a, additional_data=True)
    if not found:
        return None
    h, w = a.shape[:2]
    ww = int(settings["working_width"])
    wh = int(ww / settings["aspect_ratio"])
    rectangle = np.float32([[ww, 0], [ww, wh], [0, wh], [0, 0]])
    to_image = cv2.getPerspectiveTransform(rectangle, np.asarray(found[0].quadrilateral, np.float32))
    scale = max(h, w) / ww  # the detector works on the image turned horizontal, resized to ww wide
    boxes = []
    for i in range(24):
        row, col = divmod(i, 6)
        xs = (np.array([col + margin, col + 1 - margin]) * ww / 6).tolist()
        ys = (np.array([row + margin, row + 1 - margin]) * wh / 4).tolist()
        corners = np.float32([[[x, y] for y in ys for x in xs]])
        xw, yw = (cv2.perspectiveTransform(corners, to_image)[0] * scale).T
        # a portrait image was turned 90 degrees clockwise: (row r, column c) went to (x = h - r, y = c)
        ys_img, xs_img = (h - xw, yw) if h > w else (yw, xw)
        ys_img, xs_img = np.sort(ys_img), np.sort(xs_img)
        box = (int(np.ceil(ys_img[1])), int(np.floor(ys_img[2])), int(np.ceil(xs_img[1])), int(np.floor(xs_img[2])))
        box = (max(box[0], 0), min(box[1], h), max(box[2], 0), min(box[3], w))
        if box[1] <= box[0] or box[3] <= box[2]:
            return None
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


#: Where the patches of a chart come from: the chart generator's known layout, or found in the image.
PATCH_SOURCES = ("layout", "detect")


def macbeth_delta_e(rendered, reference, monitor, *, scene_shape=None, patch_size=16, border=4, margin=0.25,
                    method="CIE 2000", patches="layout"):
    """Per-patch dE (CIEDE2000 by default) of a rendered Macbeth chart against a rendered reference (the ideal image).

    Both are rendered monitor images of one chart, shown on ``monitor``,
    whose white is the CIELAB white. ``patches``: "layout" takes the boxes
    of the chart generator's layout (``scene_shape``, the default
    :func:`~camsim_core.scene.macbeth_scene` unless given, filling the
    image); "detect" finds the chart in the reference image
    (:func:`find_macbeth_patches`) and falls back on the layout where it
    cannot. The result's ``"patches"`` says which was used.
    """
    from ..monitor import load_monitor
    from ..rendering import to_xyz, white_xyz

    if patches not in PATCH_SOURCES:
        raise ParameterError("patches", f"must be one of {PATCH_SOURCES}, got {patches!r}")
    mon = load_monitor(monitor)
    if tuple(rendered.shape) != tuple(reference.shape):
        raise ParameterError("reference", f"is {reference.shape}, the rendered chart {rendered.shape}: render both at one geometry")
    boxes = find_macbeth_patches(getattr(reference, "data", reference)) if patches == "detect" else None
    source = "detected" if boxes is not None else "layout"
    if boxes is None:
        boxes = macbeth_patch_boxes(rendered.shape, scene_shape, patch_size=patch_size, border=border, margin=margin)
    out = chart_delta_e(to_xyz(rendered, mon), to_xyz(reference, mon), boxes, white=white_xyz(mon), method=method)
    out["patches"] = source
    return out


def patch_map(shape, boxes, values):
    """An (H, W) map with each box filled with its value and NaN elsewhere (to draw a patch dE map)."""
    out = np.full(tuple(shape)[:2], np.nan)
    for (y0, y1, x0, x1), v in zip(boxes, np.asarray(values, float)):
        out[y0:y1, x0:x1] = v
    return out
