"""An incremental pipeline: re-run only the steps downstream of a change.

The explorer re-computes the camera image after every slider move.
:class:`Pipeline` remembers, for each step, a key made of its parameters and
of the token of the step that fed it, and re-runs a step only when that key
changed. Simulation stages declare the camera fields they read (``stage.uses``,
see :mod:`camsim_core.simulation`), so changing ``noise_sigma`` re-runs the
noise stage and what follows it, never the sensor responses or the
resampling (chapter section 3.1: the stages are independent operators).

The steps, in order:

* one per stage of ``camera.architecture`` (by default ``sensor_responses``,
  ``resample``, ``mosaic``, ``noise``, ``digitize``);
* ``demosaic`` (skipped for a full-colour image: nothing to demosaic), ``render``, ``ideal`` (the ideal image of section 4.3),
  ``xyz`` and ``ideal_xyz`` (both on the monitor), ``delta_e`` (CIELAB) and
  ``scielab`` (S-CIELAB) error maps.

A stage made in two parts (``prepare`` of :func:`camsim_core.simulation._stage.stage`:
the sensor stage's sums over the spectral planes, then the exposure's gain)
keeps its first part while the fields that part reads stay the same, so an
exposure or f-stop move scales the kept sums instead of summing the cube
again, for the camera (and for the chapter's ideal camera's cones); a fresh
run makes the same two parts, so the numbers are the same.

The ideal image (``Processing.reference``, :func:`camsim_core.ideal_image`)
is by default the scene's: it depends on the scene, the camera's pixel grid
(angular resolution, distance, array size) and the monitor only, so an
exposure, f-number, bit depth, noise, pedestal, sensor or optics move never
recomputes it; the scene's cone responses are kept while the scene stays, so
a distance move only resamples and renders them. The chapter's reference
(the cone camera at the camera's exposure and bits) is recomputed when its
ideal camera changes.

The ideal image's side (``ideal``, ``ideal_xyz`` and the ideal image's
L*a*b* for each error map) needs nothing of the camera's image: when it must
be recomputed (a new scene, geometry or monitor) it runs on a
thread of its own beside the camera's side, on the core the camera's mostly
unsplit small steps leave idle (an exposure move on the default scene, when
the chapter's reference made the ideal image move with it: ~28 -> ~22 ms); on one core, and when it is cached, it runs in the calling thread.
Meanwhile the camera's side makes its own image's L*a*b* for the error maps,
so that only the differences wait for the join.

Each call to :meth:`Pipeline.run` records which steps ran and how long each
took (``Result.ran``, in the order of a serial run) and its wall-clock time
(``Result.elapsed``). A step the engine refuses (a
:class:`~camsim_core.errors.CamsimError`: a bad parameter combination, a
method the camera cannot use) is reported in ``Result.errors`` and the
steps that need its output are skipped; nothing is cached for it. Any other
exception is a fault and is raised. Results are exactly those of a fresh run (no approximation:
the cache only skips work whose inputs are unchanged).

Scenes and monitors are shared read-only between pipelines (one process
serves many explorer sessions); a pipeline never modifies its inputs.

No GUI imports: this module is engine code.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import itertools
import time
from concurrent.futures import Future
from dataclasses import dataclass, field

import numpy as np

from ._chunks import map_pixels
from ._parallel import CORES, ThreadPool
from .datasets.sensors import Sensors
from .errors import CamsimError
from .image import image_from_scene
from .spectra import Spectrum

__all__ = ["Processing", "Pipeline", "Result", "fingerprint", "PROCESSING_STEPS"]

#: The steps after the simulation stages, in order.
PROCESSING_STEPS = ("demosaic", "render", "ideal", "xyz", "ideal_xyz", "delta_e", "scielab")

_tokens = itertools.count(1)


@dataclass(frozen=True)
class Processing:
    """What happens to the camera image after the simulation.

    Attributes
    ----------
    demosaic : str
        Method of :func:`camsim_core.demosaic`.
    render : str
        "baseline" or "illuminant" (:func:`camsim_core.render`).
    illuminant : str or None
        For "illuminant" rendering: ``None`` uses the known illuminant the
        image carries; "gray-world" or "max-rgb" estimate it.
    monitor : str
        A shipped monitor name (:data:`camsim_core.MONITOR_NAMES`).
    metrics : tuple of str
        Which error maps to compute: "cielab" and/or "scielab".
    viewing : str
        How the rendered image is viewed, which fixes S-CIELAB's samples per
        degree (:func:`camsim_core.metrics.parse_viewing`): "camera" (the
        chapter's: the camera's angular resolution), "camera/10" (the
        original's example), "spd:S", "display:PITCHmm@DISTANCEm".
    reference : str
        The ideal image the error maps compare with
        (:func:`camsim_core.ideal_image`): "scene" (the default: the scene
        through the cones on the camera's pixel grid, an ideal lens,
        unquantized, normalised by the scene's white; it depends on the
        scene, the camera's pixel grid and the monitor only) or "chapter"
        (section 4.3: the cone camera at the camera's exposure, f-number,
        optics and bit depth).
    """

    demosaic: str = "bilinear"
    render: str = "baseline"
    illuminant: str | None = None
    monitor: str = "simtoolbox-test"
    metrics: tuple = ("cielab", "scielab")
    viewing: str = "camera"
    reference: str = "scene"


@dataclass
class Result:
    """The outputs of one :meth:`Pipeline.run`. Missing outputs are ``None``.

    ``raw`` is the simulated camera image; ``delta_e`` and ``scielab`` are
    (H, W) error maps in CIELAB Delta E units against the ideal image;
    ``ran`` lists ``(step, seconds)`` for the steps that were (re-)computed
    (:attr:`seconds` is their sum); ``elapsed`` is the run's wall-clock time
    in seconds, less than that sum when the ideal image's side ran beside the
    camera's;
    ``errors`` maps a failed step to its message; ``skipped`` maps a step
    that was not needed to the reason (a full-colour image is not
    demosaiced: ``demosaiced`` is then ``raw`` itself).
    """

    scene: object = None
    camera: object = None
    raw: object = None
    demosaiced: object = None
    rendered: object = None
    ideal: object = None
    xyz: object = None
    ideal_xyz: object = None
    delta_e: object = None
    scielab: object = None
    samples_per_degree: float | None = None
    white: object = None
    elapsed: float = 0.0
    ran: list = field(default_factory=list)
    errors: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)

    @property
    def ran_steps(self):
        """Names of the steps that ran, in order."""
        return [name for name, _ in self.ran]

    @property
    def seconds(self):
        """Total time of the steps that ran."""
        return float(sum(t for _, t in self.ran))

    @property
    def exposure(self):
        """How the raw frame is exposed (:func:`camsim_core.metrics.exposure.exposure_measures`: the shares of
        pixels clipped and at the black level, the mean signal) and its ``flags``, the warnings a score of it
        must carry (a black, empty or clipped frame); ``None`` without a raw image. Measured once per raw."""
        from .metrics.exposure import exposure_measures

        if self.raw is None:
            return None
        held = self.__dict__.get("_exposure")
        if held is None or held[0] is not self.raw:
            held = self.__dict__["_exposure"] = (self.raw, exposure_measures(self.raw, getattr(self, "camera", None)))
        return held[1]


def fingerprint(value):
    """A hashable, value-based summary of a camera field (arrays by content)."""
    if value is None or isinstance(value, (bool, int, float, str, np.integer, np.floating)):
        return value
    if isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        return ("array", a.shape, a.dtype.str, hashlib.blake2b(a.tobytes(), digest_size=16).hexdigest())
    if isinstance(value, (tuple, list)):
        return tuple(fingerprint(v) for v in value)
    if isinstance(value, dict):
        return tuple(sorted((k, fingerprint(v)) for k, v in value.items()))
    if isinstance(value, Sensors):
        return ("sensors", fingerprint(value.wavelengths), fingerprint(value.values), value.names, value.unit)
    if isinstance(value, Spectrum):
        return ("spectrum", fingerprint(value.wavelengths), fingerprint(value.values))
    if callable(value):
        return ("callable", getattr(value, "__module__", ""), getattr(value, "__qualname__", repr(value)), id(value))
    return ("object", id(value))


def _camera_key(camera, fields):
    return tuple((f, fingerprint(getattr(camera, f))) for f in fields)


def _all_fields(camera):
    return tuple(f.name for f in dataclasses.fields(camera))


class Pipeline:
    """Cached simulation and processing for one user (one explorer session).

    Not thread-safe: give each session its own pipeline. The cache holds one
    entry per step (the last inputs), which is what an interactive user needs.
    """

    def __init__(self):
        self._memo = {}
        self._ideal_lab = {}

    def snapshot(self):
        """What this pipeline remembers, to start another from (:meth:`start_from`).

        The arrays are shared, not copied: a pipeline never modifies a step's
        output, it replaces its own entry when the step re-runs.
        """
        return dict(self._memo), dict(self._ideal_lab)

    def start_from(self, snapshot):
        """Remember what another pipeline computed (a :meth:`snapshot`); steps whose inputs differ re-run as usual."""
        memo, ideal_lab = snapshot
        self._memo.update(memo)
        self._ideal_lab.update(ideal_lab)

    def clear(self):
        """Forget every cached step."""
        self._memo.clear()
        self._ideal_lab.clear()

    def _ideal_side(self, key, compute):
        """The ideal image's side of an error map (its L*a*b*, plain or S-CIELAB filtered), kept while
        the ideal image stays the same: a noise or processing move then converts only the camera image."""
        if key not in self._ideal_lab:
            self._ideal_lab = {k: v for k, v in self._ideal_lab.items() if k[1] == key[1]}
            self._ideal_lab[key] = compute()
        return self._ideal_lab[key]

    def _ideal_step_key(self, camera, proc):
        """The ideal step's key: what the ideal image depends on. The scene's reference: the scene (its
        token: a new light level is a new scene), the camera's pixel grid (the fields of the resampling
        stage, :data:`~camsim_core.rendering.ideal.GEOMETRY_FIELDS`) and the monitor, so that an exposure,
        f-number, bit depth, noise, pedestal, sensor or optics move keeps it. The chapter's: the camera's
        ideal counterpart (cones, no mosaic, no noise, same geometry, exposure and bits). Raises CamsimError."""
        from .rendering import ideal

        reference = ideal.check_reference(proc.reference)
        if reference == "scene":
            return ("scene", self._memo["scene"][1], _camera_key(camera, ideal.GEOMETRY_FIELDS), proc.monitor)
        return ("chapter", self._memo["scene"][1], _ideal_key(ideal.ideal_camera(camera)), proc.monitor)

    def _ideal_branch(self, scene, camera, proc, ideal_key, refused, result):
        """The ideal image (step key ``ideal_key``, or ``refused``: why there is none), its XYZ and the
        L*a*b* of each error map's ideal side, into ``result``; returns the tokens ``(t_ideal, t_ixyz)``
        (``None`` for a step that failed)."""
        from . import load_monitor, metrics
        from .rendering import ideal, white_xyz

        if refused is not None:
            result.errors["ideal"] = refused
            return None, None
        monitor = load_monitor(proc.monitor)
        t_ideal, result.ideal = self._step("ideal", ideal_key, lambda: self._ideal_image(scene, camera, monitor, ideal_key[0]),
                                           result)
        if t_ideal is None:
            return None, None
        t_ixyz, result.ideal_xyz = self._step(  # to_xyz's numbers, in a compiled pass for an unquantized ideal image
            "ideal_xyz", (t_ideal, proc.monitor), lambda: ideal.ideal_xyz(result.ideal, monitor), result
        )
        if t_ixyz is None:
            return t_ideal, None
        white = np.asarray(white_xyz(monitor), float)
        if "cielab" in proc.metrics:
            self._ideal_side(("cielab", t_ixyz), lambda: _lab_map(_data(result.ideal_xyz), white))
        if "scielab" in proc.metrics:
            try:  # the camera's image has the ideal image's geometry: the same samples per degree (else a miss later)
                spd = _samples_per_degree(result.ideal, proc.viewing)
            except CamsimError:
                return t_ideal, t_ixyz
            self._ideal_side(("scielab", t_ixyz, spd), lambda: metrics.filtered_lab(_data(result.ideal_xyz), spd, white))
        return t_ideal, t_ixyz

    def _ideal_image(self, scene, camera, monitor, reference="scene"):
        """:func:`camsim_core.ideal_image` of ``scene`` for ``camera`` (the same numbers). The scene's reference:
        the scene's cone responses kept while the scene stays (a distance or frame move only resamples and
        renders them). The chapter's: the ideal camera's first stage's first part (the cone sums over the
        scene's planes) kept, so that an exposure move re-scales them."""
        from .rendering import ideal

        if reference == "scene":
            cones = self._kept("ideal:cones", self._memo["scene"][1], lambda: ideal.scene_cones(scene))
            return ideal.render_scene_ideal(cones, camera, monitor, name=f"ideal {scene.name}")
        cam = ideal.ideal_camera(camera)
        image = image_from_scene(scene)
        for i, stage in enumerate(cam.architecture):
            # only the first stage's input is known by a token (the scene's): the later ones are not kept
            image = self._apply(stage, cam, image, self._memo["scene"][1], "ideal:prepare") if i == 0 else stage(cam, image)
        return ideal.render_ideal(image, monitor, name=f"ideal {scene.name}")

    def _apply(self, stage, camera, source, source_token, kept_name):
        """``stage(camera, source)``; for a stage in two parts (:func:`camsim_core.simulation._stage.stage`),
        its first part kept under ``kept_name`` while ``source`` (known by ``source_token``) and the fields
        that part reads stay the same, and the second part run on it (the same numbers)."""
        parts = getattr(stage, "prepare", None)
        if parts is None:
            return stage(camera, source)
        first, first_uses, finish = parts
        key = (source_token, fingerprint(stage), _camera_key(camera, first_uses))
        return finish(camera, self._kept(kept_name, key, lambda: first(camera, source)), reuse=False)

    def _step(self, name, key, compute, result):
        """The cached output of ``name`` for ``key``, or compute, time and remember it.

        Returns ``(token, value)``; ``(None, None)`` when the step failed
        (its message is put in ``result.errors``).
        """
        memo = self._memo.get(name)
        if memo is not None and memo[0] == key:
            return memo[1], memo[2]
        t0 = time.perf_counter()
        try:
            value = compute()
        except CamsimError as exc:  # bad input, said by the engine; any other exception is a fault, and raised
            self._memo.pop(name, None)
            result.ran.append((name, time.perf_counter() - t0))
            result.errors[name] = str(exc)
            return None, None
        result.ran.append((name, time.perf_counter() - t0))
        token = next(_tokens)
        self._memo[name] = (key, token, value)
        return token, value

    def _kept(self, name, key, compute):
        """The value of a step's part that is not reported on its own (a stage's first part, :func:`stage`):
        the cached one for ``key``, or ``compute()`` remembered under ``name``. A failure leaves nothing."""
        memo = self._memo.get(name)
        if memo is not None and memo[0] == key:
            return memo[2]
        self._memo.pop(name, None)
        value = compute()
        self._memo[name] = (key, None, value)
        return value

    def run(self, scene, camera, processing=None):
        """Simulate ``camera`` on ``scene`` and process the result, re-using what has not changed.

        Parameters
        ----------
        scene : Scene
            Compared by identity: pass the same (shared, read-only) object to re-use work.
        camera : Camera
        processing : Processing, optional

        Returns
        -------
        Result
        """
        t0 = time.perf_counter()
        proc = processing or Processing()
        result = Result(scene=scene, camera=camera)
        # the scene: compared by identity (shared objects), never copied
        memo = self._memo.get("scene")
        if memo is None or memo[2] is not scene:
            self._memo["scene"] = (id(scene), next(_tokens), scene)
        # the ideal image's side (ideal image, its XYZ, its L*a*b*) needs nothing of the camera's image: when it
        # must be recomputed (a new scene, geometry or monitor) it runs beside the camera's side
        branch = Result(scene=scene, camera=camera)
        try:
            ideal_key, refused = self._ideal_step_key(camera, proc), None
        except CamsimError as exc:
            ideal_key, refused = None, str(exc)
        memo = self._memo.get("ideal")
        stale = ideal_key is not None and (memo is None or memo[0] != ideal_key)
        ideal = _start(lambda: self._ideal_branch(scene, camera, proc, ideal_key, refused, branch), parallel=stale)
        try:
            self._camera_side(scene, camera, proc, result, branch, ideal)
        except BaseException:
            # the ideal side ends before the error leaves: nothing of this run keeps writing to the pipeline
            with contextlib.suppress(BaseException):
                ideal.result()
            raise
        result.ran = _merged(result.ran)
        result.elapsed = time.perf_counter() - t0
        return result

    def _camera_side(self, scene, camera, proc, result, branch, ideal):
        """The camera's steps and the error maps, into ``result``; the ideal side (``ideal``, writing into
        ``branch``) is joined once the camera's image is rendered and taken to XYZ."""
        from . import demosaic, load_monitor, metrics, render, to_xyz
        from .rendering import white_xyz

        token, image = self._memo["scene"][1], None
        for stage in camera.architecture:
            uses = getattr(stage, "uses", None)
            fields = _all_fields(camera) if uses is None else uses
            key = (token, fingerprint(stage), _camera_key(camera, fields))
            name = getattr(stage, "__name__", repr(stage))
            upstream, upstream_token = image, token

            def compute(stage=stage, upstream=upstream, upstream_token=upstream_token, name=name):
                source = image_from_scene(scene) if upstream is None else upstream
                return self._apply(stage, camera, source, upstream_token, f"stage:{name}:prepare")

            token, image = self._step(f"stage:{name}", key, compute, result)
            if token is None:
                _join(result, branch, ideal.result(), camera)
                return
        result.raw = image
        sim_token = token

        monitor = load_monitor(proc.monitor)
        if getattr(result.raw, "mosaiced", True):
            t_dem, result.demosaiced = self._step(
                "demosaic", (sim_token, proc.demosaic), lambda: demosaic(result.raw, proc.demosaic), result
            )
        else:
            # a full-colour image (no mosaic): every pixel has every sensor, so
            # processing starts from the camera image itself (section 4.1 applies
            # to mosaiced images only), whatever demosaicing method is chosen
            self._memo.pop("demosaic", None)
            t_dem, result.demosaiced = sim_token, result.raw
            result.skipped["demosaic"] = "not needed: the image is not mosaiced (every pixel has every sensor)"
        t_ren = None
        if t_dem is not None:
            illum = proc.illuminant if proc.render == "illuminant" else None
            t_ren, result.rendered = self._step(
                "render",
                (t_dem, proc.render, illum, proc.monitor),
                lambda: render(result.demosaiced, monitor, method=proc.render, illuminant=illum),
                result,
            )
        t_xyz = None
        if t_ren is not None:
            t_xyz, result.xyz = self._step("xyz", (t_ren, proc.monitor), lambda: to_xyz(result.rendered, monitor), result)
        # while the ideal side still runs beside this one, the camera image's own L*a*b* (the larger half of each
        # error map) is made here, and after the join only the differences remain. A large image's S-CIELAB
        # bands then share the block pool with the ideal side's: on a 1024^2 scene's exposure move with
        # S-CIELAB, medians of 40 interleaved moves 221 -> 212, 219 -> 201 and 187 -> 189 ms (CIELAB 129 -> 127,
        # 114 -> 113); an earlier filter, whose bands made XYZ and Lab in separate passes, had lost 1-10 % here
        early = self._camera_lab(result, proc, monitor, t_xyz) if t_xyz is not None and not ideal.done() else {}
        t_ideal, t_ixyz = _join(result, branch, ideal.result(), camera)
        if t_xyz is None or t_ixyz is None:
            return
        result.white = np.asarray(white_xyz(monitor), float)
        white = result.white
        if "cielab" in proc.metrics:

            def cielab():
                # metrics.delta_e, with the ideal image's L*a*b* kept between moves; by chunks of pixels (cache
                # sized, on the machine's cores for a large image)
                xyz, ideal = metrics.cielab.check_pair(_data(result.xyz), _data(result.ideal_xyz))
                ideal_lab = self._ideal_side(("cielab", t_ixyz), lambda: _lab_map(ideal, white))
                if "cielab" in early:  # the same chunks, the same numbers
                    return map_pixels(lambda x, ref: metrics.delta_e_lab(x, ref)[:, None], early["cielab"], ideal_lab)[..., 0]
                return map_pixels(lambda x, ref: metrics.delta_e_lab(metrics.xyz_to_lab(x, white, checked=True), ref)[:, None],
                                  xyz, ideal_lab)[..., 0]

            _, result.delta_e = self._step("delta_e", (t_xyz, t_ixyz), cielab, result)
        if "scielab" in proc.metrics:
            try:
                result.samples_per_degree = _samples_per_degree(result.rendered, proc.viewing)
            except CamsimError as exc:
                result.errors["scielab"] = str(exc)
                return
            spd = result.samples_per_degree

            def scielab():
                # metrics.scielab, with the ideal image's filtered L*a*b* kept between moves; each image checked
                # once, where its filtered L*a*b* is made (the ideal's beside or here, the camera's before the
                # join when made then: not in this last step, which runs alone), not again by every step
                lab = early["scielab"][1] if early.get("scielab", (None,))[0] == spd else None
                xyz, ideal = metrics.cielab.check_pair(_data(result.xyz), _data(result.ideal_xyz),
                                                       check_first=lab is None, check_second=False)
                ideal_lab = self._ideal_side(("scielab", t_ixyz, spd), lambda: metrics.filtered_lab(ideal, spd, white))
                if lab is None:
                    lab = metrics.filtered_lab(xyz, spd, white, checked=True)
                return metrics.delta_e_lab(lab, ideal_lab)

            _, result.scielab = self._step("scielab", (t_xyz, t_ixyz, spd), scielab, result)

    def _camera_lab(self, result, proc, monitor, t_xyz):
        """The camera image's L*a*b* for each error map that must be made again (its XYZ changed):
        ``{"cielab": lab, "scielab": (samples per degree, filtered lab)}``, the same arrays the error map
        steps would make. Their time is reported under those steps. A failure is left to the step to report."""
        from . import metrics
        from .rendering import white_xyz

        early = {}
        white = np.asarray(white_xyz(monitor), float)
        # to_xyz's float image. For the plain L*a*b*, not checked here: the error-map step that takes it checks
        # its values (check_pair) and reports what it finds. For S-CIELAB's, checked here (in the step, after
        # the join, the check would run alone on one core): a failure leaves it to the step, which checks
        # again and reports. Either way each image is checked once per move
        xyz = np.asarray(_data(result.xyz))
        for metric, step in (("cielab", "delta_e"), ("scielab", "scielab")):
            memo = self._memo.get(step)
            if metric not in proc.metrics or (memo is not None and memo[0][0] == t_xyz):
                continue
            t0 = time.perf_counter()
            try:
                if metric == "cielab":
                    early[metric] = _lab_map(xyz, white)
                else:
                    spd = _samples_per_degree(result.rendered, proc.viewing)
                    checked = metrics.cielab.check_xyz(xyz, "xyz1")
                    early[metric] = (spd, metrics.filtered_lab(checked, spd, white, checked=True))
            except CamsimError:
                continue
            result.ran.append((step, time.perf_counter() - t0))
        return early


def _merged(ran):
    """``ran`` with the entries of one step (a step made in parts) summed into its first."""
    out = {}
    for name, seconds in ran:
        out[name] = out.get(name, 0.0) + seconds
    return list(out.items())


def _lab_map(xyz, white):
    """L*a*b* of an XYZ image by chunks of pixels (cache sized, on the machine's cores for a large image). Its
    values are not checked here: the error-map step checks each image once (:func:`~.metrics.cielab.check_pair`)."""
    from .metrics import xyz_to_lab

    return map_pixels(lambda x: xyz_to_lab(x, white, checked=True), xyz)


def _join(result, branch, tokens, camera):
    """Put the ideal side's outputs, steps and errors (``branch``) into ``result``; returns ``tokens``.
    The steps keep the order of a serial run, whichever thread ran them."""
    result.ran.extend(branch.ran)
    result.ran.sort(key=lambda item: _step_order(item[0], camera))
    result.errors.update(branch.errors)
    result.ideal, result.ideal_xyz = branch.ideal, branch.ideal_xyz
    return tokens


def _step_order(name, camera):
    """Where step ``name`` comes in a serial run: the camera's stages, then :data:`PROCESSING_STEPS`."""
    stages = [f"stage:{getattr(s, '__name__', repr(s))}" for s in camera.architecture]
    if name in stages:
        return stages.index(name)
    return len(stages) + (PROCESSING_STEPS.index(name) if name in PROCESSING_STEPS else len(PROCESSING_STEPS))


#: The ideal side's threads (:func:`_start`).
_branches = ThreadPool("camsim-ideal")


def _start(fn, *, parallel):
    """``fn()`` on a thread of its own when ``parallel`` (and the machine has more than one core), else here;
    returns an object whose ``result()`` gives its value (raising what it raised).

    The ideal image's side runs on these threads: numpy and the engine's compiled kernels release the GIL,
    so it uses the core the camera's side leaves (most of the explorer's steps on its images are too small
    to be split). The pool is not the block pool of :mod:`._parallel` (whose tasks never wait on it), so a
    branch that splits its own work into blocks cannot deadlock.
    """
    if parallel and CORES > 1:
        return _branches.executor().submit(fn)
    done = Future()
    try:
        done.set_result(fn())
    except BaseException as exc:  # raised again by result(), as from a thread
        done.set_exception(exc)
    return done


def _ideal_key(ideal_cam):
    """What the ideal image depends on: every field of the ideal camera but its name (and
    its seed, since it is noiseless)."""
    skip = {"name", "comments"}
    if ideal_cam.noise_model == "gaussian" and ideal_cam.noise_sigma == 0 and ideal_cam.noise_mean == 0:
        skip.add("seed")  # a noiseless camera draws no random numbers
    return _camera_key(ideal_cam, tuple(f for f in _all_fields(ideal_cam) if f not in skip))


def _demosaic(raw, method, demosaic):
    """Demosaic a mosaiced raw image; a full-colour one (no mosaic) passes through unchanged."""
    return demosaic(raw, method) if raw.mosaiced else raw


def _data(x):
    """The array of a CameraImage, or the array itself."""
    return np.asarray(getattr(x, "data", x))


def _samples_per_degree(image, viewing="camera"):
    """Samples per degree of visual angle for S-CIELAB under ``viewing`` (see :class:`Processing`)."""
    from .metrics.viewing import viewing_samples_per_degree

    return viewing_samples_per_degree(viewing, image)
