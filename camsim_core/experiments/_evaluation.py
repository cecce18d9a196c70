"""Private: the measurement shared by both experiments (rendered image -> XYZ -> S-CIELAB)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["xyz_of", "monitor_white", "samples_per_degree", "mean_scielab", "check_viewing", "viewing_rate"]


def xyz_of(rendered, monitor):
    """(H, W, 3) XYZ of a rendered monitor image (:func:`camsim_core.to_xyz`)."""
    from ..rendering import to_xyz

    return np.asarray(to_xyz(rendered, monitor), float)


def monitor_white(monitor):
    """XYZ (cd/m^2) of the monitor at full settings: the white point of the CIELAB comparison."""
    from ..rendering import white_xyz

    return np.asarray(white_xyz(monitor), float).reshape(3)


def samples_per_degree(image):
    """Samples per degree of visual angle of a camera image: its angular resolution (pixels per degree).

    The viewer sees the rendered image under the visual angle at which the
    camera saw the scene (the chapter neglects image size, section 4.3);
    see :func:`camsim_core.metrics.samples_per_degree`.
    """
    from ..metrics import samples_per_degree as spd

    return spd(image)


def check_viewing(viewing, name="viewing"):
    """The canonical text of a viewing (:func:`camsim_core.metrics.parse_viewing`), validated before any task runs."""
    from ..metrics.viewing import parse_viewing

    return parse_viewing(viewing).spec


def viewing_rate(viewing, camera_rate):
    """S-CIELAB samples per degree under ``viewing`` for an image at ``camera_rate`` px/deg; and its description."""
    from ..metrics.viewing import parse_viewing

    v = parse_viewing(viewing)
    return v.rate(camera_rate), v.describe(camera_rate)


def mean_scielab(xyz, reference, samples_per_degree, white):
    """Mean S-CIELAB dE*ab (CIE 1976) between two XYZ images."""
    from ..metrics import scielab

    return float(np.mean(scielab(xyz, reference, samples_per_degree, white, method="CIE 1976"), dtype=np.float64))


@lru_cache(maxsize=8)
def monitor(name):
    """The monitor by name or path, read once per worker process."""
    from ..monitor import load_monitor

    return load_monitor(name)


def ideal_reference(scene_name, camera, monitor_name, distance, exposure):
    """XYZ of the ideal image of ``camera``'s geometry, the monitor white, and samples per degree.

    The chapter's reference (section 4.3, ``reference="chapter"`` of
    :func:`camsim_core.ideal_image`): the cone camera with ``camera``'s
    geometry, 8-bit quantization and the experiment's ``exposure``, as the
    chapter's experiments compared with it, so that their published tables
    (``docs/``) stay reproducible. The explorer's default is the scene's.
    """
    from ..rendering import ideal_image
    from ..scene import load_scene

    mon = monitor(monitor_name)
    ideal = ideal_image(load_scene(scene_name), camera, mon, distance=distance, exposure=exposure, reference="chapter")
    return xyz_of(ideal, mon), monitor_white(mon), samples_per_degree(ideal)
