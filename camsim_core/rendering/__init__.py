"""Colour balancing and rendering (chapter section 4.2), the ideal image (4.3), and XYZ.

``render(image, monitor, method)`` turns a demosaiced camera image into the
8-bit frame-buffer values of a calibrated monitor:

* ``"baseline"`` - Eq. 1.4 with the camera's own sensitivities
  (:mod:`.baseline`);
* ``"illuminant"`` - Eqs. 1.5-1.7: surface weights in a Munsell linear
  model under the known or estimated illuminant, the cone responses they
  would produce, then the baseline rendering of those with the cones
  (:mod:`.illuminant`).

Both use one display-scale rule fixed by the scene (see :mod:`.baseline`),
shared with :func:`ideal_image`, so renderings of different cameras and the
ideal image are directly comparable.
"""

from __future__ import annotations

import numpy as np

from .._chunks import map_pixels
from ..errors import ParameterError
from ..monitor import Monitor, load_monitor
from ._linear import apply_matrix, cones, per_band
from .baseline import _sensor_planes, baseline_matrix, clipped_pixels, display_scale
from .ideal import ideal_camera, ideal_image
from .illuminant import balance_matrix, matched_luminance, resolve_illuminant, surface_basis
from .xyz import monitor_xyz_matrix, to_xyz, white_xyz

__all__ = ["render", "to_xyz", "ideal_image", "ideal_camera", "monitor_xyz_matrix", "white_xyz", "METHODS"]

METHODS = ("baseline", "illuminant")


def _monitor(monitor):
    if isinstance(monitor, Monitor):
        return monitor
    return load_monitor(monitor)


def _settings(rows, m):
    """Linear monitor settings ``m @ r`` of sensor rows (n, K) -> (n, 3), in the rows' float dtype."""
    return apply_matrix(rows[:, None, :], m)[:, 0, :]


class _Responses:
    """The sensor responses with the gain divided out, computed only if an illuminant estimate asks."""

    def __init__(self, data, gain):
        self._data, self._gain = data, gain

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self._data / self._gain, dtype=dtype)

    @property
    def shape(self):
        return self._data.shape


def render(image, monitor, method="baseline", illuminant=None, dimensions=None, *,
           render_illuminant=None, white=None, scale=None):
    """Render a demosaiced camera image for display on ``monitor``.

    Parameters
    ----------
    image : CameraImage
        Sensor planes (H, W, K), not mosaiced, with sensitivities.
    monitor : Monitor or name
    method : {"baseline", "illuminant"}
    illuminant : None, Spectrum, illuminant name, "gray-world" or "max-rgb"
        For ``method="illuminant"``: None uses the scene illuminant the image
        carries; a string in ``("gray-world", "max-rgb")`` estimates it.
    dimensions : int, optional
        Surface linear-model dimension N_s (default: the number of sensors).
    render_illuminant : None, Spectrum or name
        Re-render the surfaces under this illuminant (scaled to the same
        luminance) instead of the scene's, e.g. ``"D65"``.
    white, scale :
        Override the display scale (see :mod:`camsim_core.rendering.baseline`).

    Returns
    -------
    CameraImage
        ``space="monitor"``, data (H, W, 3) integer frame-buffer values
        0..255 (float array), ``bits=8``, ``quantized=True``. ``extra``
        holds ``display_scale``, ``scale_source``, ``clipped_fraction``
        (the share of pixels shown as clipped) and, for the illuminant
        method, ``illuminant`` (the Spectrum used). Pixels whose raw
        clipped (:func:`~camsim_core.rendering.baseline.clipped_pixels`)
        are the display's white: more light never renders a pixel darker.
        The linear settings are made and gamma corrected by chunks of pixels and not kept (a
        12-megapixel image's would be 137 MiB more);
        ``monitor.frame_buffer_to_linear(data)`` gives them back to 8-bit steps.

    Examples
    --------
    >>> import camsim_core as cs
    >>> scene, camera = cs.load_scene("macbeth"), cs.load_camera("kodak-dcs200")
    >>> raw = cs.simulate(scene, camera, exposure=cs.auto_exposure(scene, camera))
    >>> shown = render(cs.demosaic(raw), "simtoolbox-test")
    >>> shown.space, shown.data.shape, bool(shown.data.min() >= 0 and shown.data.max() <= 255)
    ('monitor', (150, 222, 3), True)
    """
    key = str(method).lower()
    if key not in METHODS:
        raise ParameterError("method", f"unknown rendering method {method!r}; valid: {', '.join(METHODS)}")
    mon = _monitor(monitor)
    data = _sensor_planes(image)  # the gain is divided out in the matrix, not over the pixels
    gain = float(image.gain)
    wls = image.wavelengths
    b_m = mon.primaries_on(wls)
    extra = dict(image.extra)
    white_used = white
    if key == "baseline":
        if illuminant is not None or render_illuminant is not None or dimensions is not None:
            raise ParameterError("method", "illuminant, render_illuminant and dimensions apply to method='illuminant' only")
        m = baseline_matrix(image.sensitivities, b_m) / gain
    else:
        n_s = image.n_sensors if dimensions is None else int(dimensions)
        r = _Responses(data, gain)
        e, spd = resolve_illuminant(image, r, illuminant)
        e_render = None
        if render_illuminant is not None:
            _, rspd = resolve_illuminant(image, r, render_illuminant)
            e_render = matched_luminance(per_band(rspd, wls), e, wls)
            if white_used is None and image.illuminant is not None:
                white_used = matched_luminance(e_render, per_band(image.illuminant, wls), wls)
        t_h = cones(wls)
        to_cones = balance_matrix(image.sensitivities, t_h, e, surface_basis(wls, n_s), e_render)
        m = baseline_matrix(t_h, b_m, "cone-monitor matrix T_H B_M") @ to_cones / gain
        if white_used is None and image.illuminant is None:
            white_used = e  # an estimated or given illuminant stands in for the scene's white
        extra["illuminant"] = spd
        extra["dimensions"] = n_s
    peak = None
    if scale is None and white_used is None and image.illuminant is None:
        # the image-dependent scale: the largest linear setting of each pixel, by chunks
        peak = map_pixels(lambda c: _settings(c, m).max(axis=1), data)[..., None]
    s, source = display_scale(image, mon, white=white_used, scale=scale, linear=peak)
    extra.update(display_scale=s, scale_source=source, monitor=mon.name)

    def frame_buffer(c, out):
        # settings, display scale, clipping and gamma in one compiled pass (Monitor._settings_to_frame_buffer)
        mon._settings_to_frame_buffer(c, m, s, out=out)

    # settings, display scale, clipping and gamma by chunks of pixels: no full-size float temporary
    fb = map_pixels(frame_buffer, data, into=(3, data.dtype))
    clipped = clipped_pixels(image)
    if clipped is not None:
        # a clipped raw value is a lower bound of the light, not a measurement: divided by the gain it would
        # render darker the more light there is (a fully clipped frame rendered at a mean of 2 of 255 at 32 x
        # the chapter's exposure); it is shown as the display's white, which no lower exposure outshines
        fb[clipped] = float(2 ** mon.bits - 1)
    extra.pop("clipped_of", None)  # the demosaiced data: not kept alive by the rendered image
    extra["clipped"] = clipped
    extra["clipped_fraction"] = 0.0 if clipped is None else float(np.mean(clipped))
    return image.then(
        f"render:{key}",
        data=fb,
        space="monitor",
        bits=mon.bits,
        quantized=True,
        unit="frame-buffer values",
        extra=extra,
    )
