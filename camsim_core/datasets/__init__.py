"""Spectral datasets shipped with camsim, as plain module-level accessors with references.

Files come from ``assets/simtoolbox`` (BrainardLab/SimToolbox, MIT licence,
see ``assets/simtoolbox/LICENSE``) or from colour-science's own datasets.
"""

from pathlib import Path

ASSETS = Path(__file__).resolve().parents[2] / "assets"
SIMTOOLBOX = ASSETS / "simtoolbox"
