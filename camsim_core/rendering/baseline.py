"""Baseline rendering (chapter section 4.2, Eqs. 1.3-1.4) and the display scale.

The monitor settings that give the camera the same responses as the scene:
``w = (T_C B_M)^-1 r_C`` (Eq. 1.4), with T_C the camera sensitivities and B_M
the phosphor spectra on the image's wavelengths (per band). With more or
fewer than three sensors the pseudo-inverse gives the least-squares
settings. Then gamma correction by table lookup from the monitor
calibration, and the monitor's 8-bit frame-buffer values.

Display scale (one rule for every camera and the ideal image)
-------------------------------------------------------------
``r_C`` is first divided by ``image.gain`` (so exposure and f-stop do not
change the rendered image), giving ``T_C c`` for the radiance ``c``. Eq. 1.4
then gives the absolute phosphor intensities that reproduce ``c`` for the
camera; these are divided by one number ``s`` fixed by the *scene*:

* ``scale=`` given: ``s = scale``;
* else the white ``W`` (``white=`` argument, or the image's carried scene
  illuminant, which in camsim's scenes is the radiance of a perfect white
  reflector): ``s = max_c [(T_H B_M)^-1 T_H W]_c`` - the ideal (cone)
  rendering of a perfect white reflector just fills the monitor's strongest
  channel. ``s`` uses the human cones, not the camera, so the renderings of
  different cameras and the ideal image share it;
* neither (a real raw of an unknown scene): ``s`` is the 99.5th percentile
  of the image's largest linear setting (image-dependent; say so when used).

Linear settings ``w / s`` are clipped to [0, 1] before gamma correction.

Clipped raw values
------------------
Dividing by the gain makes an unclipped pixel render the same at every
exposure. A raw value at the ADC's full scale is only a lower bound of
the light: divided by a gain that grows with the exposure, it would render
darker the more light there is (on the chapter's setting, 32 x its exposure
clipped every value and rendered at a mean of 2 of 255, a dark purple). So
the pixels whose raw clipped (:func:`clipped_pixels`: the clipped samples,
widened by the demosaicing method's reach) are shown as the display's
white, the brightest colour it has: more light never renders a pixel
darker, and the rendered luminance never falls as the exposure grows.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..image import subtract_black_level
from ._linear import apply_matrix, cones, per_band, solve_matrix

__all__ = ["baseline_matrix", "display_scale", "to_frame_buffer", "check_renderable", "clipped_pixels"]


def check_renderable(image):
    """The sensor planes (H, W, K) in units of sensitivities @ radiance (gain divided out).

    A pedestal the image still carries (``black_level``, e.g. a full-colour
    camera's, which no demosaicing removed) is subtracted first.
    """
    return _sensor_planes(image) / float(image.gain)


def _sensor_planes(image):
    """The sensor planes (H, W, K) as they are (float32 stays float32; pedestal subtracted), after the
    checks of :func:`check_renderable`."""
    if image.space != "sensor":
        raise ParameterError("render", f"needs sensor planes, the image is in {image.space!r} space")
    if image.mosaiced:
        raise ParameterError("render", "the image is still mosaiced: demosaic it first (camsim_core.demosaic)")
    if image.sensitivities is None or np.size(image.wavelengths) == 0:
        raise ParameterError("render", "the image carries no sensor sensitivities (give raw_from_array sensitivities=...)")
    data = np.asarray(subtract_black_level(image).data)
    if data.dtype not in (np.float32, np.float64):
        data = data.astype(np.float64)
    if data.ndim != 3 or data.shape[2] != image.n_sensors:
        raise ParameterError("render", f"expected (H, W, {image.n_sensors}) sensor planes, got {data.shape}")
    if not image.gain > 0:
        raise ParameterError("gain", f"must be > 0, got {image.gain}")
    return data


def clipped_pixels(image):
    """(H, W) boolean: the pixels of a camera image whose raw clipped (at the ADC's full scale or a full well), or ``None``.

    A demosaiced image carries them (``extra["clipped"]``, set by
    :func:`camsim_core.demosaic`: the clipped samples widened by the
    method's reach), for the data it was made with only: an image whose
    data were replaced since (``image.replace(data=...)``) has none known.
    A full-colour image straight from the camera is measured here, a pixel
    counting as clipped when any of its sensors is at full scale
    (:func:`camsim_core.demosaicing.clipped_samples`). An unquantized image
    has no ADC to clip it; a simulated electron-level sensor's full well
    clips it all the same (:func:`camsim_core.demosaicing.saturation_level`).
    """
    if "clipped" in image.extra or "demosaic" in image.extra:
        return image.extra.get("clipped") if image.extra.get("clipped_of") is image.data else None
    if image.mosaiced:
        return None
    from ..demosaicing import clipped_samples

    return clipped_samples(image)


def baseline_matrix(sensitivities, primaries, what="camera-monitor matrix T_C B_M"):
    """(3, K) matrix ``(T_C B_M)^-1`` (pseudo-inverse for K != 3) of Eq. 1.4."""
    a = np.asarray(sensitivities, float) @ np.asarray(primaries, float)
    return solve_matrix(a, what, "the sensors cannot tell the monitor's primaries apart, so Eq. 1.4 has no unique solution")


def display_scale(image, monitor, *, white=None, scale=None, linear=None):
    """The number ``s`` that linear settings are divided by (see the module docstring); and its source."""
    if scale is not None:
        s = float(scale)
        if not s > 0:
            raise ParameterError("scale", f"must be > 0, got {scale}")
        return s, "scale"
    W = white if white is not None else image.illuminant
    if W is not None:
        wls = image.wavelengths
        th = cones(wls)
        w_white = baseline_matrix(th, monitor.primaries_on(wls), "cone-monitor matrix T_H B_M") @ (th @ per_band(W, wls))
        s = float(np.max(w_white))
        if not s > 0:
            raise ParameterError("white", "gives no monitor output (is it zero in the visible range?)")
        return s, "white" if white is not None else "scene illuminant"
    if linear is None:
        raise ParameterError("scale", "no white, scale or scene illuminant to fix the display scale")
    s = float(np.percentile(np.max(linear, axis=-1), 99.5))
    return (s if s > 0 else 1.0), "image 99.5th percentile"


def to_frame_buffer(linear, monitor):
    """Linear settings in [0, 1] (clipped) -> gamma-corrected integer frame-buffer values 0..2**bits-1."""
    return monitor.linear_to_frame_buffer(linear)


def render_baseline(image, monitor, *, white=None, scale=None):
    """Linear monitor settings (H, W, 3) of Eq. 1.4 divided by the display scale; and the scale."""
    r = check_renderable(image)
    wls = image.wavelengths
    m = baseline_matrix(image.sensitivities, monitor.primaries_on(wls))
    w = apply_matrix(r, m)
    s, source = display_scale(image, monitor, white=white, scale=scale, linear=w)
    return w / s, s, source
