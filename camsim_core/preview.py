"""Small previews of scenes and camera images: sRGB pictures, PNG bytes and an HTML summary.

What a notebook shows of a :class:`~camsim_core.scene.Scene` or a
:class:`~camsim_core.image.CameraImage` (their ``_repr_html_`` and
``_repr_png_``): an sRGB picture at most :data:`PREVIEW_SIDE` pixels on its
long side (block means of the image's pixels, :func:`camsim_core.screen.to_screen`),
written as PNG by Pillow, beside a table of the shape, wavelengths, unit
and name. Every text in the HTML is escaped (:func:`html.escape`): names
come from files and users.

How a camera image is shown depends on its ``space``:

* ``"spectral"``: as a scene (:func:`camsim_core.scene.preview.spectral_srgb`);
* ``"sensor"``: each pixel's value, as a fraction of full scale (of the
  99.5th percentile when unquantized) with display gamma :data:`VIEW_GAMMA`,
  times the colour of its sensor (:func:`sensor_colors`); full sensor planes
  are mixed by those colours;
* ``"monitor"``: the 8-bit monitor settings as they are (divided by 255);
* ``"monitor-linear"``: linear settings in [0, 1] with display gamma.

The explorer's raw and demosaiced views colour camera images the same way
(``camsim_explorer.views``).
"""

from __future__ import annotations

import base64
import html
import io
import math

import numpy as np

from .errors import ParameterError
from .screen import block_size, to_screen

__all__ = ["PREVIEW_SIDE", "VIEW_GAMMA", "sensor_colors", "image_srgb", "png_bytes", "summary_html", "wavelength_text"]

#: Longest side of a notebook preview, pixels.
PREVIEW_SIDE = 256
#: Display gamma for values linear in light (a raw at a fifth of full scale would look black shown linearly).
VIEW_GAMMA = 2.2
#: A preview smaller than this (long side, pixels) is drawn enlarged, pixels kept square and sharp.
SMALL_SIDE = 128

_NAMED = {"R": (1.0, 0.0, 0.0), "G": (0.0, 1.0, 0.0), "B": (0.0, 0.0, 1.0)}


def sensor_colors(sensitivities, wavelengths, names=None):
    """(K, 3) display colour of each sensor class, largest component 1.

    Parameters
    ----------
    sensitivities : array_like (K, N)
        Spectral sensitivities of the K sensor classes on ``wavelengths``.
    wavelengths : array_like (N,)
        nm.
    names : sequence of str, optional
        Sensor names: when every one is ``"R"``, ``"G"`` or ``"B"``, those get pure
        red, green and blue.

    Returns
    -------
    ndarray (K, 3)
        Linear sRGB colour of each sensor's curve seen as a spectrum (its CIE
        1931 XYZ to linear sRGB, negative parts clipped, scaled to a maximum
        of 1); grey (0.6) for a curve that gives no colour (outside the visible range).

    References
    ----------
    IEC 61966-2-1:1999, sRGB.

    Examples
    --------
    >>> import numpy as np
    >>> w = np.arange(400.0, 701.0, 10.0)
    >>> long_wave = np.exp(-0.5 * ((w - 650) / 15) ** 2)
    >>> rgb = sensor_colors([long_wave], w)[0]
    >>> int(np.argmax(rgb)), float(rgb.max())
    (0, 1.0)
    >>> sensor_colors(np.ones((3, w.size)), w, ("R", "G", "B"))[2].tolist()
    [0.0, 0.0, 1.0]
    """
    from .datasets.colour_science import xyz_to_srgb
    from .datasets.sensors import cie1931_xyz

    sens = np.atleast_2d(np.asarray(sensitivities, float))
    if names is not None and len(names) == len(sens) and all(n in _NAMED for n in names):
        return np.array([_NAMED[n] for n in names])
    bar = np.asarray(cie1931_xyz().on(np.asarray(wavelengths, float)), float).T
    out = []
    for row in sens:
        xyz = row @ bar
        rgb = np.clip(xyz_to_srgb(xyz / max(xyz[1], 1e-12) * 0.5, encode=False), 0, None)
        out.append(rgb / rgb.max() if np.isfinite(rgb).all() and rgb.max() > 0 else np.full(3, 0.6))
    return np.array(out)


def _encoded(data, full_scale):
    """Values as fractions of ``full_scale`` (of their 99.5th percentile without one), display-encoded."""
    data = np.asarray(data, np.float32)
    finite = data[np.isfinite(data)]
    top = full_scale if full_scale else (float(np.percentile(finite, 99.5)) if finite.size else 1.0)
    top = top if np.isfinite(top) and top > 0 else 1.0
    x = np.nan_to_num(data / np.float32(top))
    return np.power(np.clip(x, 0, 1), np.float32(1.0 / VIEW_GAMMA))


def _fit(data, max_side):
    if max_side is None:
        return np.asarray(data, float)
    side = int(max_side)
    if side < 1:
        raise ParameterError("max_side", f"must be a positive number of pixels, got {max_side!r}")
    return to_screen(data, (side, side))[0]


def _fit_mosaic(rgb, period, max_side):
    """Block means of a coloured mosaic over blocks of whole tiles (a block of part of a tile would
    stripe the preview with the tile's colours)."""
    if max_side is None:
        return np.asarray(rgb, float)
    side = int(max_side)
    if side < 1:
        raise ParameterError("max_side", f"must be a positive number of pixels, got {max_side!r}")
    h, w = rgb.shape[:2]
    block = block_size((h, w), (side, side))
    if block == 1:
        return np.asarray(rgb, float)
    step = math.lcm(*(int(v) for v in period))
    block = -(-block // step) * step
    ny, nx = max(1, h // block), max(1, w // block)
    if h < block or w < block:  # smaller than one whole block of tiles: plain block means
        return to_screen(rgb, (side, side))[0].astype(float)
    part = np.asarray(rgb[: ny * block, : nx * block], float)
    return part.reshape(ny, block, nx, block, 3).mean(axis=(1, 3))


def image_srgb(image, *, max_side=PREVIEW_SIDE):
    """sRGB preview (h, w, 3) in [0, 1] of a :class:`~camsim_core.image.CameraImage` (see the module docstring).

    Parameters
    ----------
    image : CameraImage
        An image at any stage of the pipeline.
    max_side : int or None
        Longest side of the preview, pixels (block means of the image's
        pixels); ``None``: the image's own size.

    Returns
    -------
    ndarray (h, w, 3)
        Display values in [0, 1].

    Examples
    --------
    A quantized RGB mosaic (Bayer tile G R / B G) at full scale is pure red,
    green and blue where its sensors are:

    >>> import numpy as np
    >>> from camsim_core.image import CameraImage
    >>> w = np.arange(400.0, 701.0, 10.0)
    >>> raw = CameraImage(np.full((4, 4), 255.0), w, np.ones((3, w.size)), ("R", "G", "B"),
    ...                   tile=np.array([[1, 0], [2, 1]]), bits=8, mosaiced=True)
    >>> rgb = image_srgb(raw, max_side=None)
    >>> rgb[0, 1].tolist(), rgb[1, 0].tolist()
    ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    """
    data = np.asarray(image.data)
    if image.space == "spectral":
        return _srgb_spectral(data, image.wavelengths, max_side)
    if image.space == "monitor":
        return np.clip(_fit(data, max_side) / 255.0, 0.0, 1.0)
    if image.space == "monitor-linear":
        return _encoded(_fit(data, max_side), 1.0).astype(float)
    # sensor values: coloured by sensor
    black = np.asarray(image.black_level, float)
    if np.any(black):
        from .image import subtract_black_level

        image = subtract_black_level(image)
        data = np.asarray(image.data)
    full = image.full_scale
    if full is not None and np.any(black):
        full = full - float(np.max(black))
    k = max(image.n_sensors, data.shape[2] if data.ndim == 3 else 1)
    if image.sensitivities is not None:
        colors = sensor_colors(image.sensitivities, image.wavelengths, image.sensor_names)
    else:
        colors = np.full((k, 3), 0.6) if k != 3 else np.eye(3)
    colors = colors.astype(np.float32)
    if image.mosaiced and image.tile is not None:
        from .simulation import tile_index_map

        idx = tile_index_map(image.tile, data.shape[:2])
        plane = data if data.ndim == 2 else data[..., 0]
        if idx.ndim == 3:
            idx = idx[..., 0]
        rgb = colors[idx] * _encoded(plane, full)[..., None]
        return _fit_mosaic(rgb, np.shape(image.tile)[:2], max_side)
    planes = data[..., None] if data.ndim == 2 else data
    planes = _fit(planes, max_side)
    if planes.shape[2] != colors.shape[0]:
        colors = np.full((planes.shape[2], 3), 0.6, np.float32)
    weights = colors / np.clip(colors.sum(axis=0, keepdims=True), 1e-9, None)
    return _encoded(planes.astype(np.float32) @ weights, full).astype(float)


def _srgb_spectral(data, wavelengths, max_side):
    from .scene.preview import spectral_srgb

    return spectral_srgb(_fit(data, max_side), wavelengths)


def png_bytes(rgb):
    """PNG file bytes (8-bit RGB, written by Pillow) of an (H, W, 3) picture in [0, 1].

    Parameters
    ----------
    rgb : array_like (H, W, 3)
        Display values in [0, 1] (clipped; NaN becomes 0).

    Returns
    -------
    bytes
        A PNG file.

    Examples
    --------
    >>> import io, numpy as np
    >>> from PIL import Image
    >>> data = png_bytes(np.ones((2, 5, 3)))
    >>> data[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
    True
    >>> im = Image.open(io.BytesIO(data)); im.size, im.getpixel((0, 0))
    ((5, 2), (255, 255, 255))
    """
    from PIL import Image

    a = np.asarray(rgb, float)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise ParameterError("rgb", f"must be an (H, W, 3) picture, got shape {a.shape}")
    u8 = np.rint(np.clip(np.nan_to_num(a), 0.0, 1.0) * 255.0).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(u8, "RGB").save(buf, format="PNG")
    return buf.getvalue()


def summary_html(title, rgb, rows):
    """HTML of a preview picture (inline base64 PNG) beside a table of ``rows``, every text escaped.

    Parameters
    ----------
    title : str
        Shown above the table (e.g. ``"Scene 'macbeth'"``).
    rgb : array_like (h, w, 3) or None
        The picture in [0, 1] (:func:`png_bytes`); ``None``: the table alone.
    rows : sequence of (str, object)
        Label and value of each row (values shown with ``str``).

    Returns
    -------
    str
        An HTML fragment (a ``<div>``), for Jupyter's ``_repr_html_``.

    Examples
    --------
    >>> import numpy as np
    >>> out = summary_html("Scene <b>", np.zeros((2, 2, 3)), [("name", "<script>")])
    >>> "<script>" in out, "&lt;script&gt;" in out, out.count("data:image/png;base64,")
    (False, True, 1)
    """
    cells = "".join(
        f"<tr><th style='text-align:left;padding-right:1em'>{html.escape(str(k))}</th>"
        f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>"
        for k, v in rows
    )
    picture = ""
    if rgb is not None:
        a = np.asarray(rgb)
        h, w = a.shape[:2]
        zoom = max(1, SMALL_SIDE // max(h, w))
        encoded = base64.b64encode(png_bytes(a)).decode("ascii")
        picture = (f"<img src='data:image/png;base64,{encoded}' width='{w * zoom}' height='{h * zoom}' "
                   f"style='image-rendering:pixelated;margin-right:1em' alt='{html.escape(str(title), quote=True)}'>")
    return (f"<div style='display:flex;align-items:flex-start'>{picture}"
            f"<div><b>{html.escape(str(title))}</b><table>{cells}</table></div></div>")


def wavelength_text(wavelengths):
    """Wavelength sampling as text, e.g. ``"400-700 nm, 31 samples"``.

    Examples
    --------
    >>> import numpy as np
    >>> wavelength_text(np.arange(400.0, 701.0, 10.0))
    '400-700 nm, 31 samples (step 10 nm)'
    >>> wavelength_text([])
    'none'
    """
    w = np.asarray(wavelengths, float).ravel()
    if w.size == 0:
        return "none"
    text = f"{w[0]:g}-{w[-1]:g} nm, {w.size} samples"
    steps = np.diff(w)
    if steps.size and np.allclose(steps, steps[0]):
        text += f" (step {steps[0]:g} nm)"
    return text
