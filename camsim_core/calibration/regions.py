"""Image regions for calibration: the chart's patches, the reference region, the white reference.

``REGIONS.json`` (coordinates in pixels of the registered frame, i.e. of the
reference-wavelength plane; boxes are ``[top, left, bottom, right]``,
half-open, and should lie inside the patch away from its edges)::

    {
      "patches": {"1": [t, l, b, r], "white 9.5": [t, l, b, r], ...},  # or a list of 24 boxes/null
      "reference": [t, l, b, r],        # where the spectroradiometer measured
      "white": [t, l, b, r] | "mcc",    # optional white reference ("mcc": the chart's white patch)
      "white_reflectance": 0.99,        # optional: a number or one value per plane
      "measured": [{"name": "pink panel", "box": [t, l, b, r], "spectrum": "pink.csv"}]
    }

``measured`` (optional) lists further regions with spectroradiometer
readings (CSV as the reference, path relative to the regions file): they
are compared with the calibrated image in Figures 1.4 and 1.5, together with
the reference region.

Patch keys are chart numbers 1-24 (row by row from dark skin) or the
colour-science names. Without ``white_reflectance`` a white given by box is
taken as a perfect reflector (1.0) and the chart's white patch as its
BabelColor reflectance.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import FileFormatError

__all__ = ["Regions", "read_regions", "check_inside"]


@dataclass(frozen=True)
class Regions:
    """Parsed regions: ``patches`` {0-based chart index: box}, ``reference`` box or None,
    ``white`` box or None, ``white_reflectance`` (None, a number or a list), ``source`` path."""

    patches: dict
    reference: tuple | None = None
    white: tuple | None = None
    white_patch: int | None = None
    white_reflectance: object = None
    source: str = "regions"
    measured: tuple = ()  # of (name, box, spectrum path)


def _box(source, where, value):
    if not isinstance(value, (list, tuple)) or len(value) != 4:
        raise FileFormatError(source, f"{where} must be a box [top, left, bottom, right] in pixels, got {value!r}")
    try:
        t, l, b, r = (int(round(float(v))) for v in value)
    except (TypeError, ValueError):
        raise FileFormatError(source, f"{where} must hold four numbers, got {value!r}") from None
    if b <= t or r <= l:
        raise FileFormatError(source, f"{where} {list(value)} is empty: bottom must exceed top and right exceed left")
    return (t, l, b, r)


def _patch_index(source, key, names):
    if isinstance(key, int) or (isinstance(key, str) and key.strip().isdigit()):
        k = int(key)
        if not 1 <= k <= 24:
            raise FileFormatError(source, f"patch number {k} is not a chart patch (1-24)")
        return k - 1
    low = [n.lower() for n in names]
    if isinstance(key, str) and key.strip().lower() in low:
        return low.index(key.strip().lower())
    raise FileFormatError(source, f"unknown patch {key!r}: use a number 1-24 or one of {', '.join(names)}")


def read_regions(path):
    """Read ``REGIONS.json`` into :class:`Regions` (see the module docstring)."""
    from .scatter import macbeth_names

    path = Path(path)
    try:
        spec = json.loads(path.read_text())
    except OSError as exc:
        raise FileFormatError(path, f"cannot read the regions file: {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(path, f"not valid JSON: {exc}") from None
    if not isinstance(spec, dict):
        raise FileFormatError(path, "must hold a JSON object with 'patches' and 'reference'")
    names = macbeth_names()
    patches = {}
    raw = spec.get("patches", {})
    if isinstance(raw, list):
        if len(raw) != 24:
            raise FileFormatError(path, f"'patches' as a list must have 24 entries (a box or null per chart patch), got {len(raw)}")
        items = [(i + 1, b) for i, b in enumerate(raw) if b is not None]
    elif isinstance(raw, dict):
        items = list(raw.items())
    else:
        raise FileFormatError(path, "'patches' must map chart patches to boxes")
    for key, box in items:
        k = _patch_index(path, key, names)
        patches[k] = _box(path, f"patch {names[k]!r} ({k + 1})", box)
    ref = spec.get("reference")
    ref = None if ref is None else _box(path, "'reference'", ref)
    white = spec.get("white")
    white_patch = None
    if isinstance(white, str):
        if white.lower() != "mcc":
            raise FileFormatError(path, f"'white' must be a box or \"mcc\", got {white!r}")
        white_patch = names.index("white 9.5") if "white 9.5" in names else 18
        if white_patch not in patches:
            raise FileFormatError(path, "'white' is \"mcc\" but the chart's white patch (19) has no box in 'patches'")
        white = patches[white_patch]
    elif white is not None:
        white = _box(path, "'white'", white)
    wr = spec.get("white_reflectance")
    if wr is not None:
        arr = np.asarray(wr, dtype=float) if isinstance(wr, (int, float, list)) else None
        if arr is None or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
            raise FileFormatError(path, f"'white_reflectance' must be a positive number or list, got {wr!r}")
    measured = []
    raw_m = spec.get("measured", [])
    if not isinstance(raw_m, list):
        raise FileFormatError(path, "'measured' must be a list of {name, box, spectrum}")
    for i, e in enumerate(raw_m):
        if not isinstance(e, dict) or not isinstance(e.get("spectrum"), str):
            raise FileFormatError(path, f"measured[{i}] must be an object with 'name', 'box' and 'spectrum' (a CSV file)")
        name = str(e.get("name", f"region {i + 1}"))
        measured.append((name, _box(path, f"measured[{i}] ({name}) box", e.get("box")), path.parent / e["spectrum"]))
    return Regions(patches, ref, white, white_patch, wr, str(path), tuple(measured))


def check_inside(regions, shape):
    """Raise a :class:`FileFormatError` naming any region that is not wholly inside an image of ``shape``."""
    from .scatter import macbeth_names

    h, w = shape[:2]
    names = macbeth_names()
    boxes = [(f"patch {names[k]!r} ({k + 1})", b) for k, b in sorted(regions.patches.items())]
    boxes += [(n, b) for n, b in (("'reference'", regions.reference), ("'white'", regions.white)) if b is not None]
    boxes += [(f"measured region {n!r}", b) for n, b, _ in regions.measured]
    for name, (t, l, b, r) in boxes:
        if t < 0 or l < 0 or b > h or r > w:
            raise FileFormatError(regions.source, f"{name} box [{t}, {l}, {b}, {r}] lies outside the {h} x {w} image")
