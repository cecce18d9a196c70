"""Test charts as hyperspectral scenes: slanted edge, zone plate, uniform field, Munsell grid, Macbeth chart.

Every chart is a reflectance map times an illuminant (a name of
:data:`~camsim_core.datasets.illuminants.ILLUMINANT_NAMES` or a Spectrum),
scaled so that a white reflector has ``luminance`` cd/m^2. By default the
charts are sampled at 410.4 px/deg, four times the Kodak DCS-200's 102.6
px/deg, so that a camera at the chart's distance sees each of its pixels
cover 4 x 4 chart samples: the chart, not its sampling, is then what the
camera blurs. The Macbeth chart is :func:`~camsim_core.scene.macbeth_scene`
(:func:`macbeth_chart` takes its options by name, as the other charts': a
chart fitted to a camera's frame is ``"macbeth:angular_resolution=...,distance=..."``).
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ..datasets.surfaces import munsell
from ..errors import ParameterError
from ..spectra import Spectrum, resample
from ._intake import MAX_SCENE_VALUES
from .scene import WAVELENGTH_RANGE, Scene
from .synthetic import DEFAULT_WAVELENGTHS, _illuminant, macbeth_scene, scale_to_luminance

__all__ = ["slanted_edge_scene", "zone_plate_scene", "uniform_scene", "munsell_scene", "macbeth_chart", "chart", "parse_chart", "chart_name", "chart_shape", "chart_defaults",
           "MAX_CHART_VALUES", "MAX_OPTION_CHARS", "MAX_LUMINANCE", "CHART_NAMES", "fitted_chart_options", "FRAME_FILL",
           "CHART_ANGULAR_RESOLUTION"]

#: Default chart sampling, px/deg: 4 x the DCS-200's 102.6.
CHART_ANGULAR_RESOLUTION = (410.4, 410.4)
CHART_NAMES = ("slanted-edge", "zone-plate", "uniform", "munsell", "macbeth")


#: Longest value (characters) of one option in a chart name: numbers, sizes and illuminant names are short.
MAX_OPTION_CHARS = 64
#: Brightest chart white, cd/m^2 (the sun's disk is about 1.6e9).
MAX_LUMINANCE = 1e10


def _text(value, limit=40):
    """``repr(value)`` cut to ``limit`` characters, for a message (an option may be megabytes long)."""
    try:
        text = repr(value)
    except ValueError:  # an integer of more digits than Python prints
        return f"<{type(value).__name__}>"
    return text if len(text) <= limit else f"{text[: limit - 3]}... ({len(text):,} characters)"


def _real(name, value, what):
    """``value`` (a real number, or its text) as a finite float, else a ParameterError naming option ``name``.

    ``what`` says what the option is ("a number of degrees") for the message.
    """
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, str):
        t = value.strip()
        if not t:
            raise ParameterError(name, f"expected {what}, got an empty value")
        if len(t) > MAX_OPTION_CHARS:
            raise ParameterError(name, f"expected {what}, got a value of {len(t):,} characters")
        try:
            x = float(t) if t.isascii() else None
        except ValueError:
            x = None
        if x is None:
            raise ParameterError(name, f"expected {what}, got {_text(value)}")
    elif isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ParameterError(name, f"expected {what}, got {_text(value)}")
    else:
        try:
            x = float(value)
        except OverflowError:  # an integer beyond the floats
            x = math.inf
    if not math.isfinite(x):
        raise ParameterError(name, f"expected {what}, got {_text(value)}, which is not a finite number")
    return x


def _whole(name, value, what, low):
    """``value`` as a whole number >= ``low`` (a Python int, so that sizes multiply without overflow)."""
    if isinstance(value, (numbers.Integral, np.integer)) and not isinstance(value, (bool, np.bool_)):
        n = int(value)
    else:
        x = _real(name, value, what)
        if x != math.floor(x):
            raise ParameterError(name, f"expected {what}, got {_text(value)}")
        n = int(x)
    if n < low:
        raise ParameterError(name, f"expected {what}, got {_text(value)}")
    return n


def _wavelengths(value):
    """The chart's sampling (nm): finite, within the scene's WAVELENGTH_RANGE, strictly increasing."""
    try:
        w = np.atleast_1d(np.asarray(value, dtype=float))
    except (TypeError, ValueError, OverflowError):
        raise ParameterError("wavelengths", f"expected a list of wavelengths in nm, got {_text(value)}") from None
    low, high = WAVELENGTH_RANGE
    if (w.ndim != 1 or w.size == 0 or not np.all(np.isfinite(w)) or w.min() < low or w.max() > high
            or np.any(np.diff(w) <= 0)):
        raise ParameterError("wavelengths", f"expected strictly increasing wavelengths from {low:g} to {high:g} nm, "
                                            f"got {_text(value)}")
    return w


def _geometry(distance, angular_resolution):
    """``distance`` (m) and ``angular_resolution`` (px/deg, one number or x, y) checked: finite and positive."""
    d = _real("distance", distance, "a distance in metres")
    if d <= 0:
        raise ParameterError("distance", f"must be a positive number of metres, got {_text(distance)}")
    ar = list(angular_resolution) if isinstance(angular_resolution, (list, tuple, np.ndarray)) else [angular_resolution]
    if len(ar) not in (1, 2):
        raise ParameterError("angular_resolution", f"expected one or two numbers of pixels per degree, "
                                                   f"got {_text(angular_resolution)}")
    v = [_real("angular_resolution", a, "pixels per degree") for a in ar]
    if min(v) <= 0:
        raise ParameterError("angular_resolution", f"must be positive pixels per degree, got {_text(angular_resolution)}")
    return d, (v[0], v[-1])


def _light(illuminant, luminance, wavelengths):
    """(wavelengths, illuminant Spectrum, its radiance per band giving a white ``luminance`` cd/m^2), checked."""
    lum = _real("luminance", luminance, "a luminance in cd/m^2")
    if not 0 < lum <= MAX_LUMINANCE:
        raise ParameterError("luminance", f"must be a positive number of cd/m^2 up to {MAX_LUMINANCE:g}, "
                                          f"got {_text(luminance)}")
    if not isinstance(illuminant, Spectrum):
        text = str(illuminant).strip()
        if not text or len(text) > MAX_OPTION_CHARS:
            raise ParameterError("illuminant", f"expected an illuminant's name, got {_text(illuminant)}")
        illuminant = text
    w = _wavelengths(wavelengths)
    spd, e = _illuminant(illuminant, w)
    return w, spd, e * scale_to_luminance(w, e, lum)


def _size(size, name="size"):
    """(height, width) of ``size``: one whole number of pixels >= 8, two of them, or their text ``"HxW"``."""
    what = "a whole number of pixels >= 8 (or HEIGHTxWIDTH)"
    if isinstance(size, str) and "x" in size.lower():
        if len(size) > MAX_OPTION_CHARS:
            raise ParameterError(name, f"expected {what}, got a value of {len(size):,} characters")
        parts = size.lower().split("x")
        try:
            if len(parts) != 2:
                raise ParameterError(name, "")
            hw = [_whole(name, v, what, 8) for v in parts]
        except ParameterError:
            raise ParameterError(name, f"expected {what}, got {_text(size)}") from None
        return hw[0], hw[1]
    s = list(size) if isinstance(size, (list, tuple, np.ndarray)) else [size]
    if len(s) not in (1, 2):
        raise ParameterError(name, f"expected {what}, got {_text(size)}")
    hw = [_whole(name, v, what, 8) for v in s]
    return hw[0], hw[-1]


def _count(n):
    """A whole number for a message: in full, or its order of magnitude when it has too many digits to print."""
    return f"{n}" if n < 10**30 else f"about 1e{int(n.bit_length() * math.log10(2))}"


def _check_values(h, w, planes, limit=MAX_SCENE_VALUES, what="a scene may have"):
    """Refuse a chart of more than ``limit`` values before anything is allocated."""
    if h * w * planes > limit:
        raise ParameterError("size", f"{_count(h)} x {_count(w)} pixels x {planes} wavelengths is more than the "
                                     f"{limit:,} values {what}")


def _grey_scene(refl, w, spd, e, name, comments, distance, angular_resolution):
    """A scene of spectrally flat reflectances ``refl`` (H, W) under radiance-per-band ``e``.

    The radiance is float32, as the shipped scenes' (every stage then runs in single precision): a chart
    that fills the default camera's frame holds 34.5 M values, 138 MB instead of 276 MB per session.
    """
    data = np.asarray(refl, np.float32)[:, :, None] * np.asarray(e, np.float32)[None, None, :]
    return Scene(data, w, distance, angular_resolution, "W/sr/m^2 per band", Spectrum(w, e, spd.name), name, comments)


def edge_coverage(shape, angle, offset=0.0, samples=32):
    """Fraction of each pixel's area to the left of a line through the image centre, ``angle`` degrees from vertical.

    Exact along x (the line's x-intercept within each pixel row is
    clipped to the pixel), ``samples`` points per pixel along y. Positive
    angles lean the top of the edge to the left (clockwise).
    """
    h, w = shape
    t = np.tan(np.radians(angle))
    ys = (np.arange(h * samples) + 0.5) / samples  # sub-row centres
    x_line = w / 2 + offset + (ys - h / 2) * t  # x of the edge at each sub-row
    cols = np.arange(w)
    out = np.empty((h, w))
    rows = max(1, 2**20 // max(1, samples * w))  # blocks of rows: a frame-sized chart's sub-rows would take 285 MB
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        frac = np.clip(x_line[r0 * samples : r1 * samples, None] - cols[None, :], 0.0, 1.0)  # area left of the line
        out[r0:r1] = frac.reshape(r1 - r0, samples, w).mean(axis=1)
    return out


def slanted_edge_scene(size=512, *, angle=5.0, contrast=4.0, light=0.8, illuminant="D65", luminance=100.0,
                       wavelengths=DEFAULT_WAVELENGTHS, distance=1.0, angular_resolution=CHART_ANGULAR_RESOLUTION):
    """An ISO 12233 slanted edge: dark left, light right, ``angle`` degrees from vertical through the centre.

    ``contrast`` is the reflectance ratio light / dark (ISO 12233:2017
    asks for 4:1); ``light`` the light side's (spectrally flat) reflectance.
    Each pixel holds the exact area average of the step (see
    :func:`edge_coverage`), so the chart's own MTF is that of the pixel aperture.
    """
    h, wd = _size(size)
    _check_values(h, wd, _wavelengths(wavelengths).size)
    angle = _real("angle", angle, "a number of degrees")
    if not (2.0 <= abs(angle) <= 45.0):
        raise ParameterError("angle", f"must be 2 to 45 degrees from vertical (ISO 12233 uses about 5), got {angle!r}")
    contrast = _real("contrast", contrast, "a ratio light / dark")
    if not contrast >= 1:
        raise ParameterError("contrast", f"must be a ratio light / dark >= 1, got {contrast!r}")
    light = _real("light", light, "a reflectance")
    if not 0 < light <= 1:
        raise ParameterError("light", f"reflectance must lie in (0, 1], got {light!r}")
    w, spd, e = _light(illuminant, luminance, wavelengths)
    distance, angular_resolution = _geometry(distance, angular_resolution)
    dark = light / contrast
    left = edge_coverage((h, wd), angle)
    refl = dark * left + light * (1.0 - left)
    return _grey_scene(refl, w, spd, e, "slanted-edge", f"slanted edge {angle:g} deg, contrast {contrast:g}:1",
                       distance, angular_resolution)


def zone_plate_scene(size=512, *, max_frequency=0.5, mean=0.5, amplitude=0.4, illuminant="D65", luminance=100.0,
                     wavelengths=DEFAULT_WAVELENGTHS, distance=1.0, angular_resolution=CHART_ANGULAR_RESOLUTION):
    """A circular zone plate: reflectance ``mean + amplitude cos(pi k r^2)``, r in pixels from the centre.

    The local frequency k r rises linearly from 0 at the centre to
    ``max_frequency`` cycles per pixel at the middle of each side.
    """
    h, wd = _size(size)
    _check_values(h, wd, _wavelengths(wavelengths).size)
    max_frequency = _real("max_frequency", max_frequency, "a number of cycles per pixel")
    if not 0 < max_frequency <= 0.5:
        raise ParameterError("max_frequency", f"must lie in (0, 0.5] cycles per pixel, got {max_frequency!r}")
    mean = _real("mean", mean, "a reflectance")
    if not 0 <= mean <= 1:
        raise ParameterError("mean", f"reflectance must lie in [0, 1], got {mean!r}")
    amplitude = _real("amplitude", amplitude, "a reflectance amplitude")
    if not (0 <= amplitude <= mean and mean + amplitude <= 1):
        raise ParameterError("amplitude", f"mean {mean} +- amplitude {amplitude} must stay within [0, 1]")
    w, spd, e = _light(illuminant, luminance, wavelengths)
    distance, angular_resolution = _geometry(distance, angular_resolution)
    y, x = np.mgrid[0:h, 0:wd]
    r2 = (x - (wd - 1) / 2) ** 2 + (y - (h - 1) / 2) ** 2
    k = max_frequency / (min(h, wd) / 2)
    refl = mean + amplitude * np.cos(np.pi * k * r2)
    return _grey_scene(refl, w, spd, e, "zone-plate", f"zone plate up to {max_frequency:g} cycles/px", distance,
                       angular_resolution)


def uniform_scene(size=128, *, luminance=100.0, illuminant="D65", wavelengths=DEFAULT_WAVELENGTHS, distance=1.0,
                  angular_resolution=CHART_ANGULAR_RESOLUTION):
    """A uniform field of ``luminance`` cd/m^2: a white reflector under the illuminant (for SNR)."""
    h, wd = _size(size)
    _check_values(h, wd, _wavelengths(wavelengths).size)
    w, spd, e = _light(illuminant, luminance, wavelengths)
    distance, angular_resolution = _geometry(distance, angular_resolution)
    luminance = _real("luminance", luminance, "a luminance in cd/m^2")  # checked by _light: a float for the comment
    return _grey_scene(np.ones((h, wd)), w, spd, e, "uniform", f"uniform field, {luminance:g} cd/m^2", distance,
                       angular_resolution)


def munsell_scene(rows=4, cols=6, *, patch_size=32, border=8, chips=None, illuminant="D65", luminance=100.0,
                  wavelengths=DEFAULT_WAVELENGTHS, distance=1.0, angular_resolution=CHART_ANGULAR_RESOLUTION):
    """A grid of Munsell chips (Parkkinen et al. 1989 reflectances) on black gaps.

    ``chips``: indices into the 1269 chips; by default ``rows x cols`` evenly spaced ones.
    """
    rows, cols, patch_size, border = _grid(rows, cols, patch_size, border)
    step = patch_size + border
    _check_values(border + rows * step, border + cols * step, _wavelengths(wavelengths).size)
    w, spd, e = _light(illuminant, luminance, wavelengths)
    distance, angular_resolution = _geometry(distance, angular_resolution)
    mw, refl = munsell()
    idx = np.linspace(0, refl.shape[0] - 1, rows * cols).round().astype(int) if chips is None else _chips(chips)
    if idx.size != rows * cols or idx.min() < 0 or idx.max() >= refl.shape[0]:
        raise ParameterError("chips", f"need {rows * cols} indices in 0..{refl.shape[0] - 1}")
    r = resample(mw, refl[idx], w)
    data = np.zeros((border + rows * step, border + cols * step, w.size))
    for i in range(idx.size):
        row, col = divmod(i, cols)
        y0, x0 = border + row * step, border + col * step
        data[y0 : y0 + patch_size, x0 : x0 + patch_size] = r[i] * e
    return Scene(data, w, distance, angular_resolution, "W/sr/m^2 per band", Spectrum(w, e, spd.name), "munsell",
                 f"{rows} x {cols} Munsell chips {idx.tolist()}")


def macbeth_chart(patch_size=16, border=4, *, illuminant="D65", luminance=100.0, wavelengths=DEFAULT_WAVELENGTHS,
                  distance=1.0, angular_resolution=(57.3, 57.3)):
    """The Macbeth ColorChecker of :func:`~camsim_core.scene.macbeth_scene` (4 x 6 patches of ``patch_size``
    pixels, ``border`` pixels of black gaps), its options checked by name like the other charts'.

    At its defaults it is the shipped ``"macbeth"`` scene (57.3 px/deg, 1 m away); ``luminance`` is the
    white reflector's cd/m^2 (``white_luminance`` of :func:`~camsim_core.scene.macbeth_scene`).
    """
    patch_size = _whole("patch_size", patch_size, "a whole number of pixels >= 1", 1)
    border = _whole("border", border, "a whole number of pixels >= 0", 0)
    step = patch_size + border
    w = _wavelengths(wavelengths)
    _check_values(border + 4 * step, border + 6 * step, w.size)
    _light(illuminant, luminance, w)  # checked here, by name
    distance, angular_resolution = _geometry(distance, angular_resolution)
    return macbeth_scene(illuminant if isinstance(illuminant, Spectrum) else str(illuminant).strip(),
                         patch_size=patch_size, border=border, wavelengths=w,
                         white_luminance=_real("luminance", luminance, "a luminance in cd/m^2"), distance=distance,
                         angular_resolution=angular_resolution)


def _grid(rows, cols, patch_size, border):
    """The Munsell grid's whole numbers, checked: rows, cols and patch_size >= 1, border >= 0."""
    note = "(rows, cols, patch_size and border are whole numbers)"
    return (_whole("rows", rows, f"a whole number >= 1 {note}", 1), _whole("cols", cols, f"a whole number >= 1 {note}", 1),
            _whole("patch_size", patch_size, f"a whole number of pixels >= 1 {note}", 1),
            _whole("border", border, f"a whole number of pixels >= 0 {note}", 0))


def _chips(chips):
    """Chip indices: one whole number or a list of them."""
    items = list(chips) if isinstance(chips, (list, tuple, np.ndarray)) else [chips]
    return np.array([_whole("chips", c, "whole chip indices", 0) for c in items], dtype=np.int64)


_CHARTS = {"slanted-edge": slanted_edge_scene, "zone-plate": zone_plate_scene, "uniform": uniform_scene,
           "munsell": munsell_scene, "macbeth": macbeth_chart}


def _option_value(key, v):
    """An option's text as a number where it is one (``size`` may be ``HxW``), else the text itself."""
    if key == "size" and "x" in v.lower():
        parts = v.lower().split("x")
        if len(parts) == 2 and all(p.strip().isascii() and p.strip().isdigit() for p in parts):
            return tuple(int(p) for p in parts)
        return v  # refused by the chart, naming the option
    if not v.isascii():
        return v
    try:
        return int(v)
    except ValueError:
        pass
    try:
        return float(v)
    except ValueError:
        return v


def parse_chart(text):
    """``"NAME:key=value,key=value"`` (e.g. ``"slanted-edge:angle=10,contrast=2"``) -> (name, options).

    Values are numbers where they parse as numbers (``size`` may be
    ``HxW``), else strings (an illuminant name); the chart checks each.
    An option without ``=`` or a name, given twice, empty, or longer than
    :data:`MAX_OPTION_CHARS` is refused here with a
    :class:`~camsim_core.errors.ParameterError` naming it.
    """
    text = str(text)
    name, _, rest = text.partition(":")
    options = {}
    for item in filter(None, (t.strip() for t in rest.split(","))):
        key, eq, value = item.partition("=")
        key, v = key.strip(), value.strip()
        if not eq or not key:
            raise ParameterError("chart", f"option {_text(item)} of {_text(text)} must be key=value")
        if len(key) > MAX_OPTION_CHARS:
            raise ParameterError("chart", f"option name {_text(key)} is longer than {MAX_OPTION_CHARS} characters")
        if key in options:
            raise ParameterError(key, f"given more than once in {_text(text)}")
        if not v:
            raise ParameterError(key, "has no value (expected key=value)")
        if len(v) > MAX_OPTION_CHARS:
            raise ParameterError(key, f"value of {len(v):,} characters is longer than the {MAX_OPTION_CHARS} allowed")
        options[key] = _option_value(key, v)
    return name.strip().lower(), options


#: The most values (pixels x wavelengths) a chart may have unless the caller allows more:
#: a 2048 x 2048 x 31 cube (1 GiB in float64).
MAX_CHART_VALUES = 2048 * 2048 * 31


def _generator(name, options):
    """The chart's generator and its options (those in ``name`` and ``options``), unknown ones refused."""
    import inspect

    key, parsed = parse_chart(name)
    options = {**parsed, **options}
    if key not in _CHARTS:
        raise ParameterError("chart", f"unknown chart {_text(key)}; known: {', '.join(CHART_NAMES)}")
    fn = _CHARTS[key]
    params = inspect.signature(fn).parameters
    unknown = sorted(str(k) for k in set(options) - set(params))
    if unknown:
        names = ", ".join(k if len(k) <= 40 else _text(k) for k in unknown)
        raise ParameterError("chart", f"{key} has no option {names}; valid: {', '.join(params)}")
    return key, fn, options, {k: p.default for k, p in params.items()}


def chart_defaults(name):
    """The options a user sets on chart ``name`` and their defaults (its sampling and wavelengths left out)."""
    _, _, _, defaults = _generator(name, {})
    return {k: v for k, v in defaults.items() if k not in ("wavelengths", "angular_resolution", "chips")}


def chart_shape(name, **options):
    """``(height, width, planes)`` of the chart ``chart(name, **options)`` would make, without making it."""
    key, _, options, defaults = _generator(name, options)
    o = {**defaults, **options}
    if key == "munsell":
        rows, cols, patch, border = _grid(*(o[k] for k in ("rows", "cols", "patch_size", "border")))
        step = patch + border
        return border + rows * step, border + cols * step, _wavelengths(o["wavelengths"]).size
    if key == "macbeth":
        patch = _whole("patch_size", o["patch_size"], "a whole number of pixels >= 1", 1)
        border = _whole("border", o["border"], "a whole number of pixels >= 0", 0)
        return border + 4 * (patch + border), border + 6 * (patch + border), _wavelengths(o["wavelengths"]).size
    return (*_size(o["size"]), _wavelengths(o["wavelengths"]).size)


def chart_name(name, options):
    """The name that :func:`parse_chart` reads back as ``(name, options)``: ``"slanted-edge:angle=10,size=64x96"``."""

    def text(v):
        if isinstance(v, tuple):
            return "x".join(str(int(p)) for p in v)
        return f"{v:g}" if isinstance(v, float) else str(v)

    return name + (":" + ",".join(f"{k}={text(v)}" for k, v in options.items()) if options else "")


def chart(name, max_values=MAX_CHART_VALUES, **options):
    """A chart by name (:data:`CHART_NAMES`) with ``options`` for its generator.

    ``name`` may carry options itself, ``"zone-plate:max_frequency=0.4"``
    (see :func:`parse_chart`); unknown options are refused by name. A chart
    of more than ``max_values`` values (pixels x wavelengths) is refused
    before anything is allocated.
    """
    h, w, planes = chart_shape(name, **options)
    _check_values(h, w, planes, max_values, "a chart may have here")
    _, fn, options, _ = _generator(name, options)
    return fn(**options)


#: Share of a camera's frame (each side) that :func:`fitted_chart_options` makes a chart cover.
FRAME_FILL = 0.85


def _tidy(v):
    """``v`` as :func:`chart_name` writes it (6 significant digits): the chart a name makes is the one fitted."""
    return float(f"{v:g}")


def fitted_chart_options(name, frame, angular_resolution, distance, *, fill=FRAME_FILL, max_values=None, **given):
    """Options that make chart ``name`` cover ``fill`` of a camera's frame, seen from ``distance`` m.

    ``frame`` is the camera's (height, width) in pixels, ``angular_resolution``
    its (x, y) pixels per degree; ``given`` the options a user chose (kept).
    The chart is placed at the camera's distance (so it is seen at its own
    sampling) and sampled so that its larger side relative to the frame spans
    ``fill`` of it:

    * slanted edge and zone plate: at the camera's own angular resolution
      (one chart sample per pixel: the camera, not the chart's sampling, is
      what the edge measures, and the zone plate's samples reach the camera's
      Nyquist), ``size`` the frame's; the zone plate's ``max_frequency`` such
      that its corners reach 0.5 cycles per sample and nothing in the chart is
      above its own Nyquist (aliasing in the chart itself);
    * uniform field: 8 x coarser (a flat field interpolates to itself): few values;
    * Munsell grid and Macbeth chart (and any chart of a given ``size``): its own pixels, at the
      angular resolution that makes the side that fills first span ``fill``
      of the frame (and more, up to the whole side, if the other then spans
      less than 80 %: a chart of another shape than the frame).

    ``max_values`` (pixels x wavelengths): a slanted edge or zone plate that
    would hold more covers less of the frame, still at the camera's own
    sampling (a coarser chart is what the MTF would then measure: phone-1.4um's
    MTF50 at f/2 read 0.17 cycles/px on a chart of 1.54 px samples, 0.25 on
    its own); a uniform field is sampled more coarsely.
    Returns the options (``size`` as (H, W), one ``angular_resolution``, ``distance``).
    """
    key, _, _, defaults = _generator(name, given)
    h_cam, w_cam = (int(v) for v in frame)
    phi_x, phi_y = (float(v) for v in np.broadcast_to(np.asarray(angular_resolution, float), (2,)))
    fill = _real("fill", fill, "a fraction of the frame")
    if not 0 < fill <= 1:
        raise ParameterError("fill", f"must lie in (0, 1], got {fill!r}")
    out = dict(given)
    out["distance"] = _tidy(_real("distance", distance, "a distance in metres"))
    planes = _wavelengths(given.get("wavelengths", defaults.get("wavelengths", DEFAULT_WAVELENGTHS))).size
    if key in ("munsell", "macbeth") or "size" in given:
        h, w, _ = chart_shape(key, **given)
        sides = np.array([h / (h_cam * phi_x / phi_y), w / w_cam])  # chart pixels per camera pixel at a full side
        # the axis the chart fills first at ``fill``; if the other then spans less than 80 %, as much more as
        # takes it there without the first leaving the frame
        ratio = sides.max() / fill
        if sides.min() / ratio < 0.81:  # (0.81: 80 % after the rounding of the name and of the resampling)
            ratio = max(sides.max(), sides.min() / 0.81)
        out["angular_resolution"] = _tidy(phi_x * ratio)
        return out
    step = 8.0 if key == "uniform" else 1.0
    if max_values is not None:
        needed = (fill * h_cam) * (fill * w_cam) * planes / step**2
        if needed > max_values:
            shrink = math.sqrt(needed / max_values) * 1.001  # (and the sizes rounded down: within max_values)
            if key == "uniform":
                step *= shrink
            else:  # the edge and the zone plate stay at the camera's own sampling: they cover less of the frame
                fill /= shrink
    phi = _tidy(phi_x / step)
    h = max(8, int(fill * h_cam * phi / phi_y))
    w = max(8, int(fill * w_cam * phi / phi_x))
    out.update(size=(h, w), angular_resolution=phi)
    if key == "zone-plate" and "max_frequency" not in given:
        # local frequency k r, k = max_frequency / (min(h, w) / 2): 0.5 at the farthest corner
        corner = math.hypot((h - 1) / 2, (w - 1) / 2)
        out["max_frequency"] = math.floor(0.5 * (min(h, w) / 2) / corner * 1e6) / 1e6
    return out
