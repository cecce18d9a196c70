"""camsim explorer: a Panel web app over the camsim engine.

``create_app()`` builds one session's page; ``camsim serve`` serves it.
"""

from .main import create_app

__all__ = ["create_app"]
