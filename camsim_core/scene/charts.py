"""Test charts as hyperspectral scenes: slanted edge, zone plate, uniform field, Munsell grid.

Every chart is a reflectance map times an illuminant (a name of
:data:`~camsim_core.datasets.illuminants.ILLUMINANT_NAMES` or a Spectrum),
scaled so that a white reflector has ``luminance`` cd/m^2. By default the
charts are sampled at 410.4 px/deg, four times the Kodak DCS-200's 102.6
px/deg, so that a camera at the chart's distance sees each of its pixels
cover 4 x 4 chart samples: the chart, not its sampling, is then what the
camera blurs. The Macbeth chart is :func:`~camsim_core.scene.macbeth_scene`.
"""

from __future__ import annotations

import numpy as np

from ..datasets.surfaces import munsell
from ..errors import ParameterError
from ..spectra import Spectrum, resample
from .scene import Scene
from .synthetic import DEFAULT_WAVELENGTHS, _illuminant, scale_to_luminance

__all__ = ["slanted_edge_scene", "zone_plate_scene", "uniform_scene", "munsell_scene", "chart", "parse_chart", "chart_name", "chart_shape", "chart_defaults",
           "MAX_CHART_VALUES", "CHART_NAMES",
           "CHART_ANGULAR_RESOLUTION"]

#: Default chart sampling, px/deg: 4 x the DCS-200's 102.6.
CHART_ANGULAR_RESOLUTION = (410.4, 410.4)
CHART_NAMES = ("slanted-edge", "zone-plate", "uniform", "munsell")


def _light(illuminant, luminance, wavelengths):
    if not (np.isfinite(luminance) and luminance > 0):
        raise ParameterError("luminance", f"must be a positive number of cd/m^2, got {luminance!r}")
    w = np.asarray(wavelengths, float)
    spd, e = _illuminant(illuminant, w)
    return w, spd, e * scale_to_luminance(w, e, luminance)


def _size(size, name="size"):
    s = np.broadcast_to(np.asarray(size), (2,))
    if not all(float(v) == int(v) and int(v) >= 8 for v in s):
        raise ParameterError(name, f"must be a whole number of pixels >= 8 (or (height, width)), got {size!r}")
    return int(s[0]), int(s[1])


def _grey_scene(refl, w, spd, e, name, comments, distance, angular_resolution):
    """A scene of spectrally flat reflectances ``refl`` (H, W) under radiance-per-band ``e``."""
    data = refl[:, :, None] * e[None, None, :]
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
    frac = np.clip(x_line[:, None] - cols[None, :], 0.0, 1.0)  # area left of the line within [c, c+1]
    return frac.reshape(h, samples, w).mean(axis=1)


def slanted_edge_scene(size=512, *, angle=5.0, contrast=4.0, light=0.8, illuminant="D65", luminance=100.0,
                       wavelengths=DEFAULT_WAVELENGTHS, distance=1.0, angular_resolution=CHART_ANGULAR_RESOLUTION):
    """An ISO 12233 slanted edge: dark left, light right, ``angle`` degrees from vertical through the centre.

    ``contrast`` is the reflectance ratio light / dark (ISO 12233:2017
    asks for 4:1); ``light`` the light side's (spectrally flat) reflectance.
    Each pixel holds the exact area average of the step (see
    :func:`edge_coverage`), so the chart's own MTF is that of the pixel aperture.
    """
    h, wd = _size(size)
    if not (2.0 <= abs(angle) <= 45.0):
        raise ParameterError("angle", f"must be 2 to 45 degrees from vertical (ISO 12233 uses about 5), got {angle!r}")
    if not (np.isfinite(contrast) and contrast >= 1):
        raise ParameterError("contrast", f"must be a ratio light / dark >= 1, got {contrast!r}")
    if not 0 < light <= 1:
        raise ParameterError("light", f"reflectance must lie in (0, 1], got {light!r}")
    w, spd, e = _light(illuminant, luminance, wavelengths)
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
    if not 0 < max_frequency <= 0.5:
        raise ParameterError("max_frequency", f"must lie in (0, 0.5] cycles per pixel, got {max_frequency!r}")
    if not (0 <= amplitude <= mean and mean + amplitude <= 1):
        raise ParameterError("amplitude", f"mean {mean} +- amplitude {amplitude} must stay within [0, 1]")
    w, spd, e = _light(illuminant, luminance, wavelengths)
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
    w, spd, e = _light(illuminant, luminance, wavelengths)
    return _grey_scene(np.ones((h, wd)), w, spd, e, "uniform", f"uniform field, {luminance:g} cd/m^2", distance,
                       angular_resolution)


def munsell_scene(rows=4, cols=6, *, patch_size=32, border=8, chips=None, illuminant="D65", luminance=100.0,
                  wavelengths=DEFAULT_WAVELENGTHS, distance=1.0, angular_resolution=CHART_ANGULAR_RESOLUTION):
    """A grid of Munsell chips (Parkkinen et al. 1989 reflectances) on black gaps.

    ``chips``: indices into the 1269 chips; by default ``rows x cols`` evenly spaced ones.
    """
    if rows < 1 or cols < 1 or patch_size < 1 or border < 0:
        raise ParameterError("rows", "rows, cols and patch_size must be >= 1, border >= 0")
    mw, refl = munsell()
    idx = np.linspace(0, refl.shape[0] - 1, rows * cols).round().astype(int) if chips is None else np.asarray(chips, int)
    if idx.size != rows * cols or idx.min() < 0 or idx.max() >= refl.shape[0]:
        raise ParameterError("chips", f"need {rows * cols} indices in 0..{refl.shape[0] - 1}")
    w, spd, e = _light(illuminant, luminance, wavelengths)
    r = resample(mw, refl[idx], w)
    step = patch_size + border
    data = np.zeros((border + rows * step, border + cols * step, w.size))
    for i in range(idx.size):
        row, col = divmod(i, cols)
        y0, x0 = border + row * step, border + col * step
        data[y0 : y0 + patch_size, x0 : x0 + patch_size] = r[i] * e
    return Scene(data, w, distance, angular_resolution, "W/sr/m^2 per band", Spectrum(w, e, spd.name), "munsell",
                 f"{rows} x {cols} Munsell chips {idx.tolist()}")


_CHARTS = {"slanted-edge": slanted_edge_scene, "zone-plate": zone_plate_scene, "uniform": uniform_scene,
           "munsell": munsell_scene}


def parse_chart(text):
    """``"NAME:key=value,key=value"`` (e.g. ``"slanted-edge:angle=10,contrast=2"``) -> (name, options).

    Values are numbers where they parse as numbers (``size`` may be ``HxW``),
    else strings (an illuminant name).
    """
    name, _, rest = str(text).partition(":")
    options = {}
    for item in filter(None, (t.strip() for t in rest.split(","))):
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise ParameterError("chart", f"option {item!r} of {text!r} must be key=value")
        v = value.strip()
        if key.strip() == "size" and "x" in v.lower():
            v = tuple(int(p) for p in v.lower().split("x"))
        else:
            try:
                v = float(v) if any(c in v for c in ".eE") else int(v)
            except ValueError:
                pass
        options[key.strip()] = v
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
        raise ParameterError("chart", f"unknown chart {name!r}; known: {', '.join(CHART_NAMES)}")
    fn = _CHARTS[key]
    params = inspect.signature(fn).parameters
    unknown = sorted(set(options) - set(params))
    if unknown:
        raise ParameterError("chart", f"{key} has no option {', '.join(unknown)}; valid: {', '.join(params)}")
    return key, fn, options, {k: p.default for k, p in params.items()}


def chart_defaults(name):
    """The options a user sets on chart ``name`` and their defaults (its sampling and wavelengths left out)."""
    _, _, _, defaults = _generator(name, {})
    return {k: v for k, v in defaults.items() if k not in ("wavelengths", "angular_resolution", "chips")}


def chart_shape(name, **options):
    """``(height, width, planes)`` of the chart ``chart(name, **options)`` would make, without making it."""
    key, _, options, defaults = _generator(name, options)
    o = {**defaults, **options}
    planes = np.size(o["wavelengths"])
    if key == "munsell":
        rows, cols, patch, border = (o[k] for k in ("rows", "cols", "patch_size", "border"))
        if not all(isinstance(v, (int, np.integer)) for v in (rows, cols, patch, border)):
            raise ParameterError("rows", "rows, cols, patch_size and border must be whole numbers")
        step = patch + border
        return border + rows * step, border + cols * step, planes
    return (*_size(o["size"]), planes)


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
    if h * w * planes > max_values:
        raise ParameterError("size", f"{h} x {w} pixels x {planes} wavelengths is more than the "
                                     f"{max_values:,} values a chart may have here")
    _, fn, options, _ = _generator(name, options)
    return fn(**options)
