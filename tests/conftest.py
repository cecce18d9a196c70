"""Fixtures shared across the suite (areas keep their own fixtures in their test files)."""

import dataclasses

import numpy as np
import pytest

import camsim_core as cs


@pytest.fixture(scope="session")
def cacaphony():
    return cs.load_scene("cacaphony290")


@pytest.fixture(scope="session")
def cacaphony64(cacaphony):
    """The default scene in float64: for checks of the engine's arithmetic to float64 precision (shipped
    scenes load as float32, which holds their 16-bit samples)."""
    return dataclasses.replace(cacaphony, data=cacaphony.data.astype(np.float64))


@pytest.fixture(scope="session")
def dcs200_ir():
    return cs.load_camera("kodak-dcs200-ir")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
