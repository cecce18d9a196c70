"""Private: the measurement shared by both experiments (rendered image -> XYZ -> S-CIELAB)."""

from __future__ import annotations

import numpy as np

__all__ = ["xyz_of", "monitor_white", "samples_per_degree", "mean_scielab"]


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


def mean_scielab(xyz, reference, samples_per_degree, white):
    """Mean S-CIELAB dE*ab (CIE 1976) between two XYZ images."""
    from ..metrics import scielab

    return float(np.mean(scielab(xyz, reference, samples_per_degree, white, method="CIE 1976")))
