"""Sweeps and pinned designs on charts with options: accepted and computed; bad option names or sizes refused first."""

import numpy as np
import pytest

from camsim_core.errors import ParameterError
from camsim_core.review.design import check_params
from camsim_core.review.sweep import run_sweep


def test_a_sweep_on_a_chart_with_options_runs():
    points = run_sweep([("edge", {"scene": "slanted-edge:angle=10,size=64", "camera": "kodak-dcs200"})],
                       "noise_sigma", [0.0, 4.0], metrics=("cielab",))
    assert [p.error for p in points] == [None, None]
    quiet, noisy = (p.measures["cielab"]["mean"] for p in sorted(points, key=lambda p: p.value))
    assert np.isfinite(quiet) and noisy > quiet  # noise adds colour error on the same chart


@pytest.mark.parametrize("scene,words", [("slanted-edge:colour=red", "has no option colour"),
                                          ("zone-plate:size=99999", "more than the"),
                                          ("slanted-edge:angle", "angle")])
def test_bad_chart_options_are_refused_before_anything_runs(scene, words):
    with pytest.raises(ParameterError, match=words):
        check_params({"scene": scene})
