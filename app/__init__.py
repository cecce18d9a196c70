"""camsim explorer: a Panel web app over the camsim engine.

Installed as ``camsim_explorer`` (its folder in the repository is ``app/``).
``create_app()`` builds one session's page; ``camsim serve``
(:mod:`camsim_explorer.serve`) serves it. The explorer imports the engine;
the engine never imports the explorer.
"""

from .main import create_app

__all__ = ["create_app"]
