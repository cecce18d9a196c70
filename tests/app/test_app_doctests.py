"""The runnable examples in the explorer's docstrings run (modules listed here; more join as they gain examples)."""

import doctest
import importlib

import pytest

MODULES = ["camsim_explorer.quality", "camsim_explorer.physical", "camsim_explorer.views",
           "camsim_explorer.loop_watch", "camsim_explorer.tab", "camsim_explorer.shown", "camsim_explorer.collector",
           "camsim_explorer.compare", "camsim_explorer.curves", "camsim_explorer.experiments", "camsim_explorer.state",
           "camsim_explorer.body_class", "camsim_explorer.serve", "camsim_explorer.compat.early_head",
           "camsim_explorer.main", "camsim_explorer.history"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
