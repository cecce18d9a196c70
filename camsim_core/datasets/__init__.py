"""Spectral datasets shipped with camsim, as plain module-level accessors with references.

Files come from ``assets/simtoolbox`` (BrainardLab/SimToolbox, MIT licence,
see ``assets/simtoolbox/LICENSE``) or from colour-science's own datasets (their
tables shipped in ``assets/colour-science``: :mod:`camsim_core.datasets.colour_science`).
Every path to a shipped file is made by :func:`asset_path`: the folder
``assets/`` of the repository is installed as the package
``camsim_core.assets`` and found with :mod:`importlib.resources`, so an
installed camsim finds its data from any working directory.
"""

from __future__ import annotations

import functools
import importlib.resources
from pathlib import Path

__all__ = ["asset_path", "ASSETS", "SIMTOOLBOX"]


@functools.lru_cache(maxsize=1)
def _assets_folder() -> Path:
    try:
        folder = importlib.resources.files("camsim_core.assets")
    except ModuleNotFoundError:
        # camsim_core imported straight from a checkout that was never installed (no camsim_core.assets):
        # the repository's own assets/ folder beside it
        folder = Path(__file__).resolve().parents[2] / "assets"
        if not (folder / "simtoolbox").is_dir():
            raise RuntimeError("camsim's shipped data (the package camsim_core.assets) is not installed: "
                               "reinstall camsim-spectral") from None
    if not isinstance(folder, Path):  # e.g. imported from a zip file: the readers need files on disk
        raise RuntimeError(f"camsim's shipped data must be files on disk, found {folder!r}: "
                           "install camsim-spectral unzipped (pip install)")
    return folder


def asset_path(*parts: str) -> Path:
    """The path of a file or folder camsim ships (the repository's ``assets/``).

    Parameters
    ----------
    *parts : str
        Path components below ``assets/``, e.g. ``"simtoolbox", "cameras"``.

    Returns
    -------
    pathlib.Path
        The path in the installed package ``camsim_core.assets`` (in an
        editable install or a checkout: the repository's ``assets/``
        folder). Whether it exists is not checked.

    Examples
    --------
    >>> from camsim_core.datasets import asset_path
    >>> asset_path("sensors", "imx174.json").is_file()
    True
    >>> asset_path("simtoolbox", "cameras").name
    'cameras'
    """
    return _assets_folder().joinpath(*parts)


#: The shipped data folder (``assets/``) and its SimToolbox part.
ASSETS = asset_path()
SIMTOOLBOX = asset_path("simtoolbox")
