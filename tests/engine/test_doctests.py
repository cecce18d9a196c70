"""The runnable examples in the engine's docstrings run (modules listed here; more join as they gain examples)."""

import doctest
import importlib

import pytest

MODULES = ["camsim_core.io.guard", "camsim_core.io.matv5", "camsim_core.io.hdf5", "camsim_core.io.isolated",
           "camsim_core.review.sweep", "camsim_core.review.report", "camsim_core.datasets",
           "camsim_core.metrics.cielab", "camsim_core.metrics.s_cielab",
           "camsim_core._parallel", "camsim_core.scene.matlab",
           "camsim_core.scene.scene", "camsim_core.scene.preview", "camsim_core.image", "camsim_core.preview",
           "camsim_core.spectra", "camsim_core.errors", "camsim_core.screen", "camsim_core.simulation.mosaic",
           "camsim_core.optics.diffraction", "camsim_core.metrics.snr", "camsim_core.scene.synthetic",
           "camsim_core.metrics.viewing", "camsim_core.rendering.xyz", "camsim_core.monitor",
           "camsim_core.scene.load", "camsim_core.camera.load", "camsim_core.simulation.pipeline",
           "camsim_core.simulation.exposure", "camsim_core.demosaicing", "camsim_core.io.raw",
           "camsim_core.rendering", "camsim_core.rendering.ideal", "camsim_core.metrics.sharpness",
           "camsim_core.datasets.colour_science", "camsim_core.review.design",
           "camsim_core.metrics.exposure", "camsim_core.camera.physical", "camsim_core.simulation.electrons",
           "camsim_core.io.upload", "camsim_core.optics.stage"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
