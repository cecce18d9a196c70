"""Fixtures shared across the suite (areas keep their own fixtures in their test files)."""

import numpy as np
import pytest

import camsim_core as cs


@pytest.fixture(scope="session")
def cacaphony():
    return cs.load_scene("cacaphony290")


@pytest.fixture(scope="session")
def dcs200_ir():
    return cs.load_camera("kodak-dcs200-ir")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
