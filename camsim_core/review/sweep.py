"""A parameter sweep over several designs: one parameter over a list of values, points as they arrive.

Each design runs its values in order in one worker thread with its own
:class:`~camsim_core.cache.Pipeline`, so a sweep of noise sigma re-runs only
the noise stage and what follows it (the sensor responses, the resampling
and the ideal image are computed once per design). Designs run in parallel
on at most ``max_workers`` threads (numpy releases the GIL in the heavy
steps). Every point equals :func:`~camsim_core.review.design.evaluate_design`
of the design with that value, run alone: the cache never approximates and
each design keeps its own noise seed.

Memory is bounded: a point keeps only its measures (no images), and a sweep
has at most :data:`MAX_SWEEP_VALUES` values and :data:`MAX_SWEEP_DESIGNS` designs.

No GUI imports: this module is engine code.
"""

from __future__ import annotations

import math
import queue
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from .._parallel import background

from ..cache import Pipeline
from ..errors import CamsimError, ParameterError
from ..camera.physical import PHYSICAL_NAMES
from .design import DESIGN_PARAMETERS, GAUSSIAN_DEFAULTS, check_params, evaluate_design, parse_numbers, with_defaults

__all__ = ["not_applicable", "SWEEP_PARAMETERS", "MAX_SWEEP_VALUES", "MAX_SWEEP_DESIGNS", "SweepPoint", "check_sweep", "design_at",
           "iter_sweep", "run_sweep"]

#: Parameters a sweep can vary, with a label (units) for plots. ``gaussian_center_K`` is the
#: K-th (1-based) centre of a Gaussian camera's sensors.
SWEEP_PARAMETERS = {
    "noise_sigma": "noise sigma (digital units)",
    "alpha": "alpha (0 cones, 1 DCS-200)",
    "exposure": "exposure (s)",
    "distance": "distance (m)",
    "f_stop": "f-stop",
    "bits": "bits",
    **{f"gaussian_center_{k}": f"Gaussian centre {k} (nm)" for k in range(1, 5)},
}
MAX_SWEEP_VALUES = 25
MAX_SWEEP_DESIGNS = 5


@dataclass(frozen=True)
class SweepPoint:
    """One design at one value: its measures (``{"cielab": {...}, "scielab": {...}}``) or an error message."""

    design: int
    name: str
    value: float
    params: dict = field(repr=False)
    measures: dict | None = None
    error: str | None = None

    def measure(self, metric="CIELAB", statistic="mean"):
        m = (self.measures or {}).get("scielab" if metric == "S-CIELAB" else "cielab")
        return None if m is None else m[statistic]


def check_sweep(sweep, where="sweep"):
    """A validated sweep definition ``{"parameter": name, "values": [numbers]}`` (ParameterError otherwise)."""
    if not isinstance(sweep, dict) or set(sweep) - {"parameter", "values"}:
        raise ParameterError(where, "expected an object {parameter, values}")
    parameter = sweep.get("parameter")
    if parameter not in SWEEP_PARAMETERS:
        raise ParameterError(f"{where}: parameter", f"expected one of {', '.join(SWEEP_PARAMETERS)}, got {parameter!r}")
    values = sweep.get("values")
    if isinstance(values, str):
        values = parse_numbers(values, f"{where}: values", max_count=MAX_SWEEP_VALUES, counted="values")
    if not isinstance(values, (list, tuple)) or not values:
        raise ParameterError(f"{where}: values", "expected a non-empty list of numbers")
    if len(values) > MAX_SWEEP_VALUES:
        raise ParameterError(f"{where}: values", f"at most {MAX_SWEEP_VALUES} values, got {len(values)}")
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ParameterError(f"{where}: values", f"expected numbers, got {v!r}")
        out.append(float(v))
    return {"parameter": parameter, "values": out}


def design_at(params, parameter, value, where="design"):
    """The design's parameters with ``parameter`` set to ``value`` (validated; ParameterError if it does not apply)."""
    p = with_defaults(params)
    if parameter.startswith("gaussian_center_"):
        k = int(parameter.rsplit("_", 1)[1])
        if p["camera"] not in GAUSSIAN_DEFAULTS:
            raise ParameterError(f"{where}: {parameter}", f"applies to Gaussian cameras only, not {p['camera']!r}")
        centers = parse_numbers(p["gaussian_centers"], "gaussian_centers")
        if k > len(centers):
            raise ParameterError(f"{where}: {parameter}", f"the camera has {len(centers)} Gaussian sensors")
        centers[k - 1] = float(value)
        p["gaussian_centers"] = ", ".join(f"{c:g}" for c in centers)
        return check_params(p, where)
    if parameter == "alpha" and p["camera"] != "mixture":
        raise ParameterError(f"{where}: alpha", f"applies to the mixture camera only, not {p['camera']!r}")
    if parameter not in SWEEP_PARAMETERS:
        raise ParameterError(f"{where}: sweep parameter", f"expected one of {', '.join(SWEEP_PARAMETERS)}")
    kind = DESIGN_PARAMETERS[parameter][1]
    p[parameter] = int(value) if kind == "integer" and float(value) == int(value) else value
    return check_params(p, where)


def not_applicable(params, parameter):
    """Why sweeping ``parameter`` cannot change the design ``params``; None when it can.

    An electron-level camera (``camsim_core.camera.physical``) draws its own
    shot and read noise from its sensor's parameters: the chapter's added
    noise sigma is not used, and a sweep of it would draw a flat line that
    looks like a finding. Such a design is left out of the sweep, with this
    reason as each of its points' ``error``.

    Parameters
    ----------
    params : dict
        A design's parameters (``DESIGN_PARAMETERS`` names).
    parameter : str
        One of :data:`SWEEP_PARAMETERS`.

    Returns
    -------
    str or None

    Examples
    --------
    >>> print(not_applicable({"camera": "imx174"}, "noise_sigma"))
    noise sigma does not apply to imx174, an electron-level camera (its noise is its sensor's own): not swept
    >>> not_applicable({"camera": "kodak-dcs200"}, "noise_sigma") is None
    True
    """
    camera = with_defaults(params).get("camera")
    if parameter == "noise_sigma" and camera in PHYSICAL_NAMES:
        return (f"noise sigma does not apply to {camera}, an electron-level camera (its noise is its sensor's own): "
                "not swept")
    return None


def _check(designs, parameter, values):
    sweep = check_sweep({"parameter": parameter, "values": list(values)})
    designs = list(designs)
    if not designs:
        raise ParameterError("designs", "a sweep needs at least one design")
    if len(designs) > MAX_SWEEP_DESIGNS:
        raise ParameterError("designs", f"at most {MAX_SWEEP_DESIGNS} designs in one sweep, got {len(designs)}")
    for name, params in designs:  # refuse up front a parameter that does not apply to a design
        for v in sweep["values"]:
            design_at(params, parameter, v, where=name)
    return designs, sweep["values"]


def iter_sweep(designs, parameter, values, *, scene=None, max_workers=2, cancel=None, metrics=("cielab", "scielab")):
    """Run the sweep; yield :class:`SweepPoint` objects in the order they are computed.

    Parameters
    ----------
    designs : list of (name, params)
    parameter : str
        One of :data:`SWEEP_PARAMETERS`.
    values : sequence of float
    scene : Scene, optional
        A scene object shared by all designs (else each design's ``scene`` is loaded).
    max_workers : int
        Threads (one design at a time per thread).
    cancel : threading.Event, optional
        Set it to stop after the points under way.
    metrics : tuple
        Error maps per point ("cielab", "scielab"); S-CIELAB is most of a point's time, leave it out
        when only CIELAB is plotted.

    A value the engine refuses for a design gives a point with ``error`` set;
    a parameter that does not apply to a design raises ParameterError before anything runs.
    """
    designs, values = _check(designs, parameter, values)
    return _points(designs, parameter, values, scene, max_workers, cancel or threading.Event(), metrics)


def _points(designs, parameter, values, scene, max_workers, cancel, metrics):
    """The generator behind :func:`iter_sweep` (arguments already checked)."""
    out = queue.Queue()
    done = object()

    def work(index, name, params):
        pipeline = Pipeline()
        reason = not_applicable(params, parameter)
        if reason is not None:  # every point refused with the reason, nothing computed
            for v in values:
                out.put(SweepPoint(index, name, v, dict(params), error=f"{name}: {reason}"))
            out.put(done)
            return
        try:
            for v in values:
                if cancel.is_set():
                    break
                p = design_at(params, parameter, v, where=name)
                try:
                    with background():  # one point at a time in the whole process, below interactive work
                        r = evaluate_design(p, name, scene=scene, pipeline=pipeline, metrics=metrics, quality=False)
                    out.put(SweepPoint(index, name, v, p, measures=r.measures))
                except CamsimError as exc:
                    out.put(SweepPoint(index, name, v, p, error=str(exc)))
        except Exception as exc:  # a bug must not hang the reader
            out.put(SweepPoint(index, name, float("nan"), dict(params), error=f"{type(exc).__name__}: {exc}"))
        finally:
            out.put(done)

    workers = max(1, min(int(max_workers), len(designs)))
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="camsim-sweep")
    try:
        for i, (name, params) in enumerate(designs):
            pool.submit(work, i, name, params)
        remaining = len(designs)
        while remaining:
            item = out.get()
            if item is done:
                remaining -= 1
            else:
                yield item
    finally:
        cancel.set()
        pool.shutdown(wait=False)


def run_sweep(designs, parameter, values, **kw):
    """Every point of the sweep, ordered by design then value (see :func:`iter_sweep`)."""
    order = {float(v): i for i, v in enumerate(check_sweep({"parameter": parameter, "values": list(values)})["values"])}
    points = list(iter_sweep(designs, parameter, values, **kw))
    return sorted(points, key=lambda p: (p.design, order.get(p.value, 0)))
