"""The ideal comparison image (chapter section 4.3, "Generation of a comparison image").

Two references, chosen by ``reference=``:

``"scene"`` (the default): **the scene seen by an ideal observer** on the
camera image's pixel grid. The scene's radiance L (W/sr/m^2 per band) is
taken to the human cone responses ``T_H L`` (Smith-Pokorny cones,
``camera_preset("human-cones")``, on the DCS-200's common scale: the
:func:`~camsim_core.rendering._linear.cones` that every rendering inverts),
resampled onto the camera's pixel grid by the camera's own resampling stage
(:func:`~camsim_core.simulation.resample`: its angular resolution, distance
and pixel array, so the two images compare pixel by pixel), and rendered by
Eq. 1.4 on the monitor: the linear settings ``w = (T_H B_M)^-1 T_H L / s``
are clipped to [0, 1] and gamma corrected, **not quantized** (frame-buffer
values 0..2**bits - 1 as floating point numbers). Nothing of the camera but
its pixel grid enters: an ideal lens (no blur, no vignetting, no
irradiance fall-off, no transmittance), no noise, no pedestal, no
non-linearity, no exposure. The exposure normalisation is the scene's
white: ``s = max_c [(T_H B_M)^-1 T_H W]_c`` for the radiance ``W`` of a
perfect white reflector under the scene's illuminant (``white=`` or the
scene's own), so the scene's white fills the monitor's strongest channel
(linear setting 1, frame-buffer value 255) whatever the camera's exposure,
f-number, bit depth, noise, black level or optics. A scene without an
illuminant uses its brightest white instead: ``s`` is the 99.5th percentile,
over the scene's own pixels (a regular subsample of at most ~65536), of each
pixel's largest linear setting, the rule a camera image without an
illuminant is rendered by (:func:`~camsim_core.rendering.baseline.display_scale`),
applied to the scene rather than to a picture of it.

``"chapter"``: the chapter's reference, as its experiments used it. A camera
with the human cone sensitivities (``camera_preset("human-cones")``), no
mosaic and no noise, but the given camera's geometry (angular resolution,
distance, pixel array, lens, blur), exposure, f-number and quantization
(8 bits in the chapter), is simulated on the scene and rendered by the
baseline method on the same monitor, with the same display scale rule as
every camera image (integer frame-buffer values). It changes with the
camera's exposure and bit depth: a dim or coarsely quantized camera gets a
dim, posterized reference.

Which command uses which: the explorer (:class:`camsim_core.cache.Pipeline`,
``Processing(reference="scene")``), ``camsim measure``
(:func:`camsim_core.metrics.report.quality_report`) and design reviews use
the scene's; the chapter's experiments (``camsim experiment sensors`` and
``mosaic``, :mod:`camsim_core.experiments`) use the chapter's, so that their
published tables stay reproducible (the pixel-size experiment has a
reference of its own, the scene's XYZ on a fine grid; ``camsim compare-real``
compares a real image with a simulated one and uses no ideal image).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from .._compiled import compiled
from ..camera import camera_preset, load_camera
from ..errors import ParameterError

__all__ = ["ideal_camera", "ideal_image", "render_ideal", "scene_cones", "render_scene_ideal", "scene_display_scale",
           "ideal_xyz", "check_reference", "REFERENCES", "GEOMETRY_FIELDS"]

#: Values of ``reference=``: the scene seen by an ideal observer (the default), or the chapter's cone camera.
REFERENCES = ("scene", "chapter")

#: The camera fields the scene's ideal image reads: those of the resampling stage (its pixel grid).
GEOMETRY_FIELDS = ("angular_resolution", "distance", "height", "width")

#: Percentile of the pixels' largest linear setting that fills the display for a scene without an illuminant.
_BRIGHT_PERCENTILE = 99.5
#: Most scene pixels that percentile is taken over (a regular subsample beyond).
_BRIGHT_SAMPLES = 65536


def check_reference(reference):
    """``reference`` as one of :data:`REFERENCES`, or a ParameterError."""
    key = str(reference).lower() if isinstance(reference, str) else reference
    if key not in REFERENCES:
        raise ParameterError("reference", f"must be one of {', '.join(REFERENCES)}, got {reference!r}")
    return key


def ideal_camera(camera):
    """The chapter's ideal (cone, non-mosaiced, noiseless, pedestal-free, linear) counterpart of ``camera``:
    its geometry, optics, exposure, f-number and bit depth (8 when unquantized) with the cones' sensors."""
    cam = load_camera(camera)
    cones = camera_preset("human-cones").sensors
    return cam.replace(
        name=f"ideal({cam.name})",
        sensors=cones,
        mosaic=None,
        noise_model="gaussian",
        noise_mean=0.0,
        noise_sigma=0.0,
        black_level=0.0,
        read_noise=0.0,
        full_well=None,
        dark_current=0.0,
        dsnu=0.0,
        prnu=0.0,
        analog_gain=1.0,
        nonlinearity=None,
        bits=cam.bits if cam.bits is not None else 8,
    )


def ideal_image(scene, camera, monitor, *, reference="scene", white=None, scale=None, quantize=False,
                **simulate_kwargs):
    """The rendered ideal image of ``scene`` on ``camera``'s pixel grid, on ``monitor``.

    Parameters
    ----------
    scene : Scene or name
    camera : Camera or name
    monitor : Monitor or name
    reference : {"scene", "chapter"}
        See the module docstring. "scene" (default): the scene through the
        cones, an ideal lens, unquantized, normalised by the scene's white;
        "chapter": the chapter's 8-bit cone camera at the camera's exposure.
    white : Spectrum, array or None
        The white that fixes the display scale (radiance per band of a
        perfect white reflector, W/sr/m^2); default the scene's illuminant.
    scale : float or None
        The display scale ``s`` itself (overrides ``white``).
    quantize : bool
        "scene" only: round to the monitor's integer frame-buffer values, as
        a camera image's rendering is (default False: floating point).
    **simulate_kwargs
        ``distance``, ``exposure``, ``f_stop``, ``seed`` as for
        :func:`~camsim_core.simulation.simulate`. The scene's reference reads
        ``distance`` (the pixel grid) and ignores the others; the chapter's
        simulates its cone camera with all of them.

    Returns
    -------
    CameraImage
        ``space="monitor"``, (H, W, 3) frame-buffer values 0..2**bits - 1 of
        the monitor (floating point and ``quantized=False`` for the scene's
        reference unless ``quantize``), the camera image's angular resolution
        and distance; ``extra["reference"]`` says which reference it is,
        ``extra["display_scale"]`` and ``extra["scale_source"]`` how it was
        normalised.

    Examples
    --------
    On the camera's pixel grid, the same size as its rendered images:

    >>> ideal = ideal_image("macbeth", "kodak-dcs200", "simtoolbox-test")
    >>> ideal.space, ideal.data.shape
    ('monitor', (150, 222, 3))
    """
    from ..monitor import load_monitor
    from ..scene import load_scene

    key = check_reference(reference)
    mon = load_monitor(monitor)
    if key == "chapter":
        from ..simulation import simulate

        raw = simulate(scene, ideal_camera(camera), **simulate_kwargs)
        return render_ideal(raw, mon, name=f"ideal {getattr(scene, 'name', scene)}", white=white, scale=scale)
    unknown = set(simulate_kwargs) - {"distance", "exposure", "f_stop", "seed"}
    if unknown:
        raise ParameterError(", ".join(sorted(unknown)), "not a picture setting (distance, exposure, f_stop, seed)")
    scene = load_scene(scene)
    cam = load_camera(camera)
    if simulate_kwargs.get("distance") is not None:
        cam = cam.replace(distance=simulate_kwargs["distance"])
    return render_scene_ideal(scene_cones(scene), cam, mon, name=f"ideal {scene.name}", white=white, scale=scale,
                              quantize=quantize)


def render_ideal(raw, monitor, *, name, white=None, scale=None):
    """The chapter's reference: the ideal camera's simulated image ``raw`` rendered as the ideal image
    (baseline, on ``monitor``), named ``name``: the second half of :func:`ideal_image` with
    ``reference="chapter"``, for a cache that simulated the ideal camera itself."""
    from ..monitor import load_monitor
    from . import render

    out = render(raw, load_monitor(monitor), method="baseline", white=white, scale=scale)
    return out.then("ideal", name=name, extra={**out.extra, "reference": "chapter"})


def scene_cones(scene):
    """The scene's cone responses at its own sampling: the first half of the scene's reference.

    A CameraImage (``space="sensor"``, (H, W, 3) L, M, S in the scene's float
    dtype) holding ``T_H L``: the cones' sensitivities (the DCS-200's common
    scale, digital units per W/sr/m^2 per band at its 1 s, f/5.6
    calibration) times the scene's radiance, summed over its planes, at
    ``gain`` 1 (no exposure: an ideal observer's responses scale with the
    light, which the display scale divides out). ``sensitivities`` are the
    cones on the scene's wavelengths, as Eq. 1.4 inverts them. Depends on
    the scene alone: a cache keeps it while only the camera moves.
    """
    from ..image import image_from_scene
    from ..simulation import sensor
    from ..spectra import check_overlap
    from ._linear import cones

    image = image_from_scene(scene)
    if image.space != "spectral":
        raise ParameterError("scene", f"needs spectral planes, got {image.space!r}")
    cone_sensors = camera_preset("human-cones").sensors
    check_overlap(cone_sensors.wavelengths, image.wavelengths, "cone sensitivities of the ideal observer")
    data = image.data if image.data.dtype == np.float32 else np.asarray(image.data, np.float64)
    t_h = cones(image.wavelengths)  # (3, N), the cones on the scene's wavelengths
    sums = sensor.weighted_sum(data, np.ascontiguousarray(t_h.T))
    return image.then("ideal:cones", data=sums, sensitivities=t_h, sensor_names=cone_sensors.names, gain=1.0,
                      exposure=1.0, f_stop=1.0, bits=None, quantized=False, space="sensor",
                      unit="cone responses (DCS-200 common scale)")


def scene_display_scale(cones_image, monitor, *, white=None, scale=None):
    """The scene reference's display scale ``s`` and where it comes from (see the module docstring).

    ``cones_image``: :func:`scene_cones` (the scene's own sampling, not a
    camera's frame, so ``s`` is the scene's). Returns ``(s, source)``: ``s``
    in cone-monitor linear-setting units of ``T_H L`` (the settings are
    divided by it), ``source`` "scale", "white", "scene illuminant" or
    "scene's brightest white (99.5th percentile)".
    """
    from .._chunks import map_pixels
    from .baseline import baseline_matrix, display_scale

    if scale is not None or white is not None or cones_image.illuminant is not None:
        return display_scale(cones_image, monitor, white=white, scale=scale)
    data = np.asarray(cones_image.data)
    h, w = data.shape[:2]
    step = max(1, int(np.sqrt(h * w / _BRIGHT_SAMPLES)))
    sample = np.ascontiguousarray(data[::step, ::step])
    m = baseline_matrix(cones_image.sensitivities, monitor.primaries_on(cones_image.wavelengths),
                        "cone-monitor matrix T_H B_M")
    peak = map_pixels(lambda rows: (rows @ m.T.astype(rows.dtype)).max(axis=1), sample)
    s = float(np.percentile(peak, _BRIGHT_PERCENTILE))
    if not (np.isfinite(s) and s > 0):
        raise ParameterError("scene", "has no light the cones see: the ideal image has no white to be rendered by")
    return s, f"scene's brightest white ({_BRIGHT_PERCENTILE:g}th percentile)"


def render_scene_ideal(cones_image, camera, monitor, *, name, white=None, scale=None, quantize=False):
    """The scene's reference from its cone responses (:func:`scene_cones`): resampled onto ``camera``'s
    pixel grid (only :data:`GEOMETRY_FIELDS` are read) and rendered, unquantized unless ``quantize``.

    The second half of :func:`ideal_image` with ``reference="scene"``, for a
    cache that keeps the cone responses while the camera moves. The linear
    settings ``(T_H B_M)^-1 T_H L / s`` (``s``: :func:`scene_display_scale`,
    from the scene's sampling) are clipped to [0, 1] and gamma corrected by
    the monitor's table (``Monitor.linear_to_settings``, interpolated), then
    times ``2**bits - 1``: floating point frame-buffer values that
    :func:`~camsim_core.rendering.to_xyz` takes back to the same linear
    settings (its table interpolated the other way).
    """
    from .._chunks import map_pixels
    from ..monitor import load_monitor
    from ..simulation import resample
    from . import render
    from .baseline import baseline_matrix

    mon = load_monitor(monitor)
    s, source = scene_display_scale(cones_image, mon, white=white, scale=scale)
    on_grid = resample(camera, cones_image)
    extra = dict(on_grid.extra, reference="scene", display_scale=s, scale_source=source, monitor=mon.name)
    if quantize:
        out = render(on_grid, mon, method="baseline", scale=s)
        return out.then("ideal", name=name, extra={**out.extra, **extra})
    data = np.asarray(on_grid.data)
    m = baseline_matrix(on_grid.sensitivities, mon.primaries_on(on_grid.wavelengths), "cone-monitor matrix T_H B_M")
    full = float(2**mon.bits - 1)
    dtype = data.dtype
    tables = _gamma_tables(mon, inverse=True)
    m = np.ascontiguousarray(m, np.float64)

    def frame_buffer(rows, out):
        # linear settings in float64, clipped, gamma corrected by Monitor.linear_to_settings's interpolation
        if tables is None:
            out[...] = mon.linear_to_settings(np.clip((np.asarray(rows, np.float64) @ m.T) / s, 0.0, 1.0)) * full
        else:
            _render_kernel()(np.ascontiguousarray(rows), m, float(s), *tables, float(_GRID), full, out)

    values = map_pixels(frame_buffer, data, into=(3, dtype))
    return on_grid.then("render:ideal", data=values, space="monitor", bits=mon.bits, quantized=False,
                        unit="frame-buffer values (unquantized)", extra=extra).then("ideal", name=name)


def ideal_xyz(image, monitor):
    """XYZ (cd/m^2) of an ideal image on ``monitor``: :func:`~camsim_core.rendering.to_xyz`, in one compiled pass
    for an unquantized one.

    ``to_xyz`` takes frame-buffer values that are not whole numbers through
    ``Monitor.frame_buffer_to_linear`` (``np.interp`` over the gamma table,
    a binary search per value, then a matrix product in numpy: many times
    its table lookup for whole numbers). Here one compiled pass
    (:func:`_xyz_rows`) interpolates each value's linear phosphor intensity
    in the same gamma table (``Monitor.settings_to_linear``'s numbers) and
    takes the three to XYZ by the monitor's matrix in float64, stored in the
    image's float dtype: within float32 rounding (3e-7 relative) of
    ``to_xyz``, whose product is in float32. A chunk of whole numbers (a
    quantized image, a black region) goes through ``to_xyz``'s own table
    lookup. Returns (H, W, 3) in the image's float dtype.
    """
    from .._chunks import map_pixels
    from ..monitor import load_monitor
    from .xyz import monitor_xyz_matrix, xyz_converter

    mon = load_monitor(monitor)
    data, convert = xyz_converter(image, mon)
    tables = _gamma_tables(mon, inverse=False)
    if (image.bits or mon.bits) != mon.bits or tables is None:
        return map_pixels(convert, data, into=(3, data.dtype))
    m = np.ascontiguousarray(monitor_xyz_matrix(mon), np.float64)
    full = 2**mon.bits - 1

    def rows_to_xyz(values, out):
        values = np.ascontiguousarray(values)
        with np.errstate(invalid="ignore"):  # NaN: not a table index (the converter's own test)
            idx = values.astype(np.int32)
        if np.array_equal(idx, values) and idx.min(initial=0) >= 0 and idx.max(initial=0) <= full:
            convert(values, out=out)  # whole numbers: to_xyz's table lookup
        else:
            _xyz_kernel()(values, *tables, float(_GRID), float(full), m, out)

    return map_pixels(rows_to_xyz, data, into=(3, data.dtype))


#: Buckets of the uniform grid over [0, 1] that finds a value's interval in a gamma table (a power of 2, so that
#: x * 4096 is exact; 16 KiB a channel, in the cache; the darkest bucket of the inverse table holds 10 knots).
_GRID = 1 << 12


@lru_cache(maxsize=16)
def _gamma_tables(monitor, inverse):
    """The monitor's gamma interpolation, packed for the compiled loops: ``(xp, fp, slopes, first, count)``, or
    None when a table is not strictly increasing (``np.interp`` is then used itself). Read-only.

    ``inverse=False``: ``Monitor.settings_to_linear`` (xp the gamma table's
    inputs, fp its outputs normalised per channel); ``inverse=True``:
    ``Monitor.linear_to_settings`` (xp those outputs, flat steps dropped,
    fp the inputs). Per channel c: ``xp[c, :count[c]]``, ``fp[c, :count[c]]``,
    ``slopes[c, j] = (fp[c, j+1] - fp[c, j]) / (xp[c, j+1] - xp[c, j])`` as
    ``np.interp`` computes them, ``first[c, b]`` the last interval starting
    at or below ``b / _GRID``.
    """
    parts = []
    for c in range(3):
        table = monitor.gamma_table[:, c] / monitor.gamma_table[-1, c]
        if inverse:
            keep = np.concatenate([[True], np.diff(table) > 0])
            xp, fp = table[keep], monitor.gamma_input[keep]
        else:
            xp, fp = monitor.gamma_input, table
        xp, fp = np.asarray(xp, np.float64), np.asarray(fp, np.float64)
        if xp.size < 2 or not np.all(np.diff(xp) > 0):
            return None
        parts.append((xp, fp))
    size = max(xp.size for xp, _ in parts)
    xp, fp = np.full((3, size), np.inf), np.zeros((3, size))
    slopes, first = np.zeros((3, size - 1)), np.zeros((3, _GRID + 1), np.int32)
    count = np.array([x.size for x, _ in parts], np.int64)
    for c, (x, f) in enumerate(parts):
        xp[c, : x.size], fp[c, : x.size] = x, f
        slopes[c, : x.size - 1] = (f[1:] - f[:-1]) / (x[1:] - x[:-1])
        first[c] = np.clip(np.searchsorted(x, np.arange(_GRID + 1) / _GRID, side="right") - 1, 0, x.size - 2)
    out = (xp, fp, slopes, first, count)
    for a in out:
        a.flags.writeable = False
    return out


def _render_rows(rows, m, scale, xp, fp, slopes, first, count, grid, full, out):
    """The unquantized rendering of sensor rows (n, K): per channel the linear setting ``w = (m @ r) / scale``
    (float64), clipped to [0, 1], gamma corrected as ``Monitor.linear_to_settings`` (``np.interp`` in the
    gamma table with flat steps dropped: the same numbers, given ``w``) and times ``full``; written into
    ``out`` (n, 3) in its dtype. NaN stays NaN. ``np.interp`` bisects the table for every value; here the
    interval ``xp[c, j] <= w < xp[c, j + 1]`` is found from the value's bucket of a uniform grid over [0, 1]
    (``first``) and a step or two, and the value is ``slopes[c, j] * (w - xp[c, j]) + fp[c, j]`` (a knot's own
    value at a knot, the end values beyond the ends), as ``np.interp`` computes it. Compiled by numba
    (:func:`_render_kernel`): numpy took ~5x the time (a matrix product, a clip, a search per channel)."""
    k = rows.shape[1]
    for i in range(rows.shape[0]):
        for c in range(3):
            w = 0.0
            for t in range(k):
                w += m[c, t] * rows[i, t]
            w = w / scale
            if w < 0.0:
                w = 0.0
            elif w > 1.0:
                w = 1.0
            n = count[c]
            if not w == w:  # NaN
                out[i, c] = w
                continue
            if w < xp[c, 0]:
                v = fp[c, 0]
            elif w >= xp[c, n - 1]:
                v = fp[c, n - 1]
            else:
                j = first[c, int(w * grid)]
                while j < n - 2 and xp[c, j + 1] <= w:
                    j += 1
                while j > 0 and xp[c, j] > w:
                    j -= 1
                if xp[c, j] == w:
                    v = fp[c, j]
                else:
                    v = slopes[c, j] * (w - xp[c, j]) + fp[c, j]
            out[i, c] = v * full


def _xyz_rows(values, xp, fp, slopes, first, count, grid, full, m, out):
    """XYZ of frame-buffer rows (n, 3): each value's linear intensity ``settings_to_linear(clip(v / full, 0, 1))``
    (``np.interp`` in the gamma table, found and computed as in :func:`_render_rows`, whose lines are repeated:
    each kernel is compiled alone), then ``m`` (3, 3) times the three, in float64, written into ``out`` in its
    dtype. NaN stays NaN. Compiled by numba (:func:`_xyz_kernel`)."""
    lin = np.empty(3)
    for i in range(values.shape[0]):
        for c in range(3):
            v = values[i, c] / full
            if v < 0.0:
                v = 0.0
            elif v > 1.0:
                v = 1.0
            n = count[c]
            if not v == v:  # NaN
                lin[c] = v
            elif v < xp[c, 0]:
                lin[c] = fp[c, 0]
            elif v >= xp[c, n - 1]:
                lin[c] = fp[c, n - 1]
            else:
                j = first[c, int(v * grid)]
                while j < n - 2 and xp[c, j + 1] <= v:
                    j += 1
                while j > 0 and xp[c, j] > v:
                    j -= 1
                if xp[c, j] == v:
                    lin[c] = fp[c, j]
                else:
                    lin[c] = slopes[c, j] * (v - xp[c, j]) + fp[c, j]
        for r in range(3):
            out[i, r] = m[r, 0] * lin[0] + m[r, 1] * lin[1] + m[r, 2] * lin[2]


_render_kernel = compiled(_render_rows)
_xyz_kernel = compiled(_xyz_rows)
