"""A design that leaves parameters out takes their defaults, a Gaussian camera's sensors its own.

The explorer sets a Gaussian camera's centres and widths when the camera is chosen; a parameters file written
by hand, or a design given to the API, may name the camera alone. ``gaussian-4`` then got the three-sensor
preset's centres and was refused with "tile names sensor index 3, but the camera has 3 sensors".
"""

import json

import numpy as np
import pytest

from camsim_core.errors import ParameterError
from camsim_core.review.design import camera_from_params, check_params, read_design_file, with_defaults

#: The chapter's section 5 sensors: four Gaussians peaking at these wavelengths (nm), 27 nm wide.
FOUR_PEAKS = [460.0, 520.0, 580.0, 640.0]


def _peaks(camera):
    """The wavelength of each sensor's largest sensitivity (nm), read from its curve."""
    s = camera.sensors
    return [float(s.wavelengths[int(np.argmax(curve))]) for curve in np.asarray(s.values)]


def test_gaussian_4_named_alone_has_its_four_sensors_under_its_own_tile():
    camera = camera_from_params({"camera": "gaussian-4"})
    assert _peaks(camera) == FOUR_PEAKS
    assert sorted(np.unique(camera.mosaic)) == [0, 1, 2, 3]  # every sensor in the tile, none missing


def test_gaussian_3_named_alone_keeps_its_three_sensors():
    assert sorted(_peaks(camera_from_params({"camera": "gaussian-3"}))) == [460.0, 520.0, 640.0]


def test_centres_given_are_kept_and_widths_left_out_are_the_cameras_own():
    p = with_defaults({"camera": "gaussian-4", "gaussian_centers": "450, 530, 590, 650"})
    assert (p["gaussian_centers"], p["gaussian_widths"]) == ("450, 530, 590, 650", "27")
    assert _peaks(camera_from_params(p)) == [450.0, 530.0, 590.0, 650.0]
    # two centres under the four-sensor tile: refused by name, not quietly changed
    with pytest.raises(ParameterError, match="mosaic"):
        camera_from_params({"camera": "gaussian-4", "gaussian_centers": "500, 600"})


def test_a_parameters_file_naming_gaussian_4_alone_reads_and_builds(tmp_path):
    path = tmp_path / "four.json"
    path.write_text(json.dumps({"camera": "gaussian-4", "noise_sigma": 2}))
    (name, params), = read_design_file(path)[0]
    assert name == "four" and params["gaussian_centers"] == "460, 520, 580, 640"
    assert check_params({"camera": "gaussian-4"}) == params | {"noise_sigma": 0.0}
    assert _peaks(camera_from_params(params)) == FOUR_PEAKS
