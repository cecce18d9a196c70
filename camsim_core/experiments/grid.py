"""Parameter grids of the chapter's experiments: validation, exposure and task seeds.

Everything here runs on the client before any task is submitted, so that a
bad grid (alpha outside [0, 1], a negative noise level, an unknown scene,
...) is refused with a :class:`~camsim_core.errors.ParameterError` naming the
option at fault, and no worker ever starts on it.

Seeding (results independent of worker count and task order)
------------------------------------------------------------
A task's noise seed is a pure function of its configuration:
:func:`task_seed` hashes a canonical JSON key with SHA-256 into
:class:`numpy.random.SeedSequence`. The key holds the experiment, the
scene, the noise level and the seed index, and deliberately *not* the
camera design (alpha, or 3 versus 4 sensors): every design of a sweep sees
the same noise field at a given (scene, sigma, seed index), the classic
"common random numbers" design, so that differences between points of a
curve come from the sensors and not from the draw. (The noise arrays of
different designs have the same shape, so the same seed gives the same
noise samples.)
"""

from __future__ import annotations

import hashlib
import json
import math
from numbers import Real
from pathlib import Path

import numpy as np

from ..errors import CamsimError, ParameterError

__all__ = [
    "parse_values",
    "check_unit_interval",
    "check_sigmas",
    "check_seeds",
    "check_distance",
    "check_scenes",
    "check_monitor",
    "check_centers",
    "common_exposure",
    "task_seed",
    "DEFAULT_DISTANCE",
    "DEFAULT_MONITOR",
]

#: Metres: the camera-to-scene distance of the chapter's Figure 1.8 (real and
#: simulated DCS-200 images of Cacaphony), whose spatial structure section 5
#: says the simulated images share (cacaphony290 becomes about 233 x 372 pixels).
DEFAULT_DISTANCE = 3.32

#: The monitor calibration shipped with the original simulator (a Psychtoolbox
#: CRT calibration; the chapter's Apple 20" calibration is not available).
DEFAULT_MONITOR = "simtoolbox-test"


def parse_values(text, name):
    """Numbers from a command-line string: ``"0,2,5"`` or ``"START:STOP:COUNT"`` (evenly spaced, both ends included)."""
    s = str(text).strip()
    try:
        if ":" in s:
            parts = s.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), float(parts[2])
            if count != int(count) or count < 1:
                raise ValueError
            return [round(float(v), 12) for v in np.linspace(start, stop, int(count))]  # 0.3, not 0.30000000000000004
        values = [float(v) for v in s.split(",") if v.strip()]
    except ValueError:
        raise ParameterError(name, f"expected numbers separated by commas (0,2,5) or START:STOP:COUNT (0:1:11), got {text!r}") from None
    if not values:
        raise ParameterError(name, "no values given")
    return values


def _numbers(values, name):
    if isinstance(values, (Real, np.integer, np.floating)) or isinstance(values, str):
        values = [values]
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (Real, np.integer, np.floating)):
            raise ParameterError(name, f"must be numbers, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise ParameterError(name, f"must be finite numbers, got {v!r}")
        out.append(v)
    if not out:
        raise ParameterError(name, "no values given")
    if len(set(out)) != len(out):
        raise ParameterError(name, f"values are repeated: {out}")
    return out


def check_unit_interval(values, name="alphas"):
    """Mixture weights: distinct finite numbers in [0, 1]."""
    out = _numbers(values, name)
    bad = [v for v in out if not 0.0 <= v <= 1.0]
    if bad:
        raise ParameterError(name, f"must lie in [0, 1] (0 = human cones, 1 = Kodak DCS-200), got {bad}")
    return out


def check_sigmas(values, name="sigmas"):
    """Noise standard deviations, digital units of the 8-bit camera range 0-255: distinct, finite, >= 0."""
    out = _numbers(values, name)
    bad = [v for v in out if v < 0]
    if bad:
        raise ParameterError(name, f"noise standard deviations must be >= 0 (digital units, camera range 0-255), got {bad}")
    return out


def check_seeds(seeds, name="seeds"):
    """Number of noise seeds per configuration: a whole number >= 1."""
    if isinstance(seeds, bool) or not isinstance(seeds, (int, np.integer)) or seeds < 1:
        raise ParameterError(name, f"must be a whole number of seeds >= 1, got {seeds!r}")
    return int(seeds)


def check_distance(distance, name="distance"):
    """Metres from the scene, or None for each scene's own distance."""
    if distance is None:
        return None
    if isinstance(distance, bool) or not isinstance(distance, (Real, np.integer, np.floating)) or not (
        math.isfinite(distance) and distance > 0
    ):
        raise ParameterError(name, f"must be a positive number of metres (or None for the scene's own), got {distance!r}")
    return float(distance)


def check_scenes(scenes, name="scenes"):
    """Load every scene once (shipped name or file path); an unknown one is refused.

    Returns ``{name: Scene}`` in the given order. A scene without an
    illuminant is refused too: the illuminant-based rendering needs it.
    """
    from ..scene import SCENE_NAMES, load_scene

    if isinstance(scenes, str):
        scenes = [scenes]
    scenes = list(scenes)
    if not scenes:
        raise ParameterError(name, "no scene given")
    if len(set(scenes)) != len(scenes):
        raise ParameterError(name, f"scenes are repeated: {scenes}")
    out = {}
    for s in scenes:
        if not isinstance(s, str):
            raise ParameterError(name, f"give scenes by name or path, got {type(s).__name__}")
        try:
            scene = load_scene(s)
        except CamsimError as exc:
            if not Path(s).exists():
                raise ParameterError(name, f"unknown scene {s!r}: neither a shipped scene ({', '.join(SCENE_NAMES)}) "
                                           "nor an existing .Simg/.npz file") from None
            raise ParameterError(name, f"cannot load scene {s!r}: {exc}") from None
        if scene.illuminant is None:
            raise ParameterError(name, f"scene {s!r} has no illuminant; the illuminant-based rendering needs one")
        out[s] = scene
    return out


def check_monitor(monitor, name="monitor"):
    """A monitor name or calibration path that loads."""
    from ..monitor import MONITOR_NAMES, load_monitor

    try:
        load_monitor(monitor)
    except CamsimError as exc:
        raise ParameterError(name, f"unknown monitor {monitor!r} (shipped: {', '.join(MONITOR_NAMES)}): {exc}") from None
    return str(monitor)


def check_centers(centers, name="centers", count=4):
    """Peak wavelengths of the Gaussian sensors, nm: ``count`` distinct values in (380, 780), increasing."""
    out = _numbers(centers, name)
    if len(out) != count:
        raise ParameterError(name, f"need {count} sensor centres (nm), got {len(out)}: {out}")
    if any(not 380 < v < 780 for v in out):
        raise ParameterError(name, f"sensor centres must lie inside 380-780 nm, got {out}")
    if sorted(out) != out:
        raise ParameterError(name, f"give the sensor centres in increasing order, got {out}")
    return out


def common_exposure(scene, cameras, distance=None, *, target=0.9):
    """One exposure time (s) for every camera of an experiment on ``scene``.

    The smallest of :func:`~camsim_core.simulation.auto_exposure` over
    ``cameras`` (its 99.5th percentile at ``target`` x the 8-bit range, by
    default 90 %): the longest exposure at which none of them clips, leaving
    25 digital units of head-room for the noise. The same light then reaches
    every camera and the ideal image. A lower ``target`` is a darker exposure,
    against which a noise sigma in digital units is larger.
    """
    from ..simulation import auto_exposure

    return float(min(auto_exposure(scene, c if distance is None else c.replace(distance=distance), target=target)
                     for c in cameras))


def task_seed(*key):
    """A 64-bit seed from a key of JSON-able values (SHA-256 -> SeedSequence).

    Independent of the process, the platform and Python's hash salt.
    """
    text = json.dumps([float(k) if isinstance(k, (float, np.floating)) else k for k in key], sort_keys=True)
    entropy = int.from_bytes(hashlib.sha256(text.encode()).digest()[:16], "little")
    return int(np.random.SeedSequence(entropy).generate_state(1, np.uint64)[0])
