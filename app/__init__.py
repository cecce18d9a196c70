"""camsim explorer: a Panel web app over the camsim engine.

Installed as ``camsim_explorer`` (its folder in the repository is ``app/``).
``create_app()`` builds one session's page; ``camsim serve``
(:mod:`camsim_explorer.serve`) serves it; ``show(scene=..., camera=...)``
(:mod:`camsim_explorer.notebook`) shows it inline in a Jupyter notebook. The explorer imports the engine;
the engine never imports the explorer.
"""

from .main import create_app
from .notebook import show

__all__ = ["create_app", "show"]
