"""The optics stage: scene radiance to the light that reaches the sensor, per spectral plane.

An optional stage of the architecture, before ``sensor_responses`` (it
needs the spectral planes). It does nothing when the camera asks for no
optics (``optics="none"``, no transmittance, no relative illumination, no
vignetting): the chapter's five-stage camera is unchanged by default. A
camera that asks for any of them gets this stage at the head of its
architecture (see :class:`~camsim_core.camera.Camera`).

What it does, in this order:

1. **Blur** (``optics="diffraction"``): each plane is multiplied, in the
   frequency domain, by the diffraction-limited OTF of the camera's pupil
   at that plane's wavelength (with ``defocus`` in dioptres: the defocused
   pupil's OTF) and the working f-number N (1 + m) of the lens focused at
   the camera's distance (:func:`working_f_number`: 2 N at unit
   magnification), on the frequency grid of the plane's own sampling at the
   sensor (:func:`~camsim_core.optics.irradiance.sample_pitch`). Blue planes
   get a higher cutoff than red ones; a larger f-number a lower one. The
   planes are padded by mirror reflection (no wrap-around), and the OTF is
   1 at zero frequency, so the blur conserves the image's energy.
2. **Photometry**: the lens transmittance T(lambda), the cos^4 relative
   illumination at each pixel's field angle and the optional vignetting.
   For quantal sensors also the (1 + m)^-2 of the working f-number: their
   sensor stage applies pi / (4 N^2) (see
   :func:`~camsim_core.simulation.sensor.quantal_gain`), so that the sensor
   receives E = pi L T cos^4 V / (4 N^2 (1 + m)^2) W/m^2 per band.
   Calibrated ("Watts") sensitivities already include their lens's absolute
   throughput at calibration, so only the relative factors apply.

The data stay in radiance-equivalent units (W/sr/m^2 per band): the light
that, through an ideal lens of the same f-number, would give the same
irradiance. :func:`sensor_irradiance` converts to W/m^2.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.fft as sfft

from .._parallel import CORES
from ..errors import ParameterError
from ..simulation._stage import stage
from ..spectra import Spectrum
from .diffraction import defocus_otf, defocus_waves, diffraction_mtf
from .irradiance import cos4, field_angles, image_distance, image_irradiance, magnification, sample_pitch

__all__ = ["optics", "optics_active", "working_f_number", "blur_planes", "plane_otfs", "relative_illumination_map", "sensor_irradiance", "OPTICS"]

#: Values of ``Camera.optics``.
OPTICS = ("none", "diffraction")


def optics_active(camera):
    """Whether the camera asks the optics stage to do anything."""
    return (camera.optics != "none" or camera.lens_transmittance is not None or bool(camera.relative_illumination)
            or camera.vignetting > 0)


def plane_otfs(shape, pitch, wavelengths, f_number, defocus=None, dtype=np.float64):
    """(N, H, W//2 + 1) OTFs on the real-FFT grid of an (H, W) plane sampled every ``pitch`` (dy, dx) m.

    ``defocus``: W020 in waves per wavelength (array), or None. ``dtype``:
    of the result (float32 for a float32 image). Cached (a pure function of
    its arguments; read-only result): moving another parameter of the camera
    does not recompute them.
    """
    return _plane_otfs(*otf_key(shape, pitch, wavelengths, f_number, defocus), np.dtype(dtype).name)


def otf_key(shape, pitch, wavelengths, f_number, defocus):
    """The OTF's arguments as hashable values (the key of the OTF caches)."""
    return (tuple(int(v) for v in shape), tuple(float(v) for v in pitch), tuple(np.asarray(wavelengths, float).tolist()),
            float(f_number), None if defocus is None else tuple(np.asarray(defocus, float).tolist()))


@lru_cache(maxsize=8)
def _plane_otfs(shape, pitch, wavelengths, f_number, defocus, dtype):
    out = _compute_otfs(shape, pitch, wavelengths, f_number, None if defocus is None else np.asarray(defocus))
    out = out.astype(dtype, copy=False)
    out.flags.writeable = False
    return out


def radial_frequency(shape, pitch):
    """(H, W//2 + 1) radial frequency, cycles/mm, of the real-FFT grid of an (H, W) plane sampled every ``pitch`` m."""
    h, w = shape
    fy = sfft.fftfreq(h, d=pitch[0] * 1e3)  # cycles/mm
    fx = sfft.rfftfreq(w, d=pitch[1] * 1e3)
    return np.hypot(fy[:, None], fx[None, :])


def _compute_otfs(shape, pitch, wavelengths, f_number, defocus):
    return otfs_at(radial_frequency(shape, pitch), wavelengths, f_number, defocus)


def otfs_at(rho, wavelengths, f_number, defocus=None):
    """(N,) + rho.shape: the OTF at radial frequencies ``rho`` (cycles/mm) for each wavelength (nm);
    ``defocus`` W020 in waves per wavelength, or None."""
    wl = np.asarray(wavelengths, float)
    if defocus is None or not np.any(defocus):
        return np.stack([diffraction_mtf(rho, lam, f_number) for lam in wl])
    out = np.empty((wl.size,) + rho.shape)
    for k in range(wl.size):
        # a radial table, fine enough for the OTF's oscillation (period 1 / (4 w) in v), interpolated onto the grid
        table_v = np.linspace(0.0, 1.0, int(max(1025, 64 * abs(defocus[k]))))
        out[k] = np.interp(rho * (wl[k] * 1e-6) * f_number, table_v, defocus_otf(table_v, defocus[k]), right=0.0)
    return out


def _margin(n, pitch_mm, wavelength_mm, f_number, waves):
    # the PSF's reach: ~8 lambda N for the Airy pattern (>99 % of the energy), plus the geometric blur circle
    reach = (8.0 + 8.0 * abs(waves)) * wavelength_mm * f_number
    return int(min(n, np.ceil(reach / pitch_mm) + 2))


def padded_grid(shape, pitch, wavelengths, f_number, defocus=None):
    """((my, mx), (hp, wp)): the margins and padded size of an (H, W) image blurred in the frequency domain.

    The margins reach as far as the widest PSF (the longest wavelength's,
    with the largest defocus), so that the mirror padding, not a wrap-around,
    is what the blur sees past the edges; the padded sizes are fast real-FFT lengths.
    """
    h, w = shape
    wl_mm = float(np.max(wavelengths)) * 1e-6
    wmax = float(np.max(np.abs(defocus))) if defocus is not None else 0.0
    my = _margin(h, pitch[0] * 1e3, wl_mm, f_number, wmax)
    mx = _margin(w, pitch[1] * 1e3, wl_mm, f_number, wmax)
    return (my, mx), (sfft.next_fast_len(h + 2 * my, real=True), sfft.next_fast_len(w + 2 * mx, real=True))


def blur_planes(data, wavelengths, pitch, f_number, defocus=None):
    """Each plane of ``data`` (H, W, N) blurred by its wavelength's OTF, in the frequency domain.

    ``pitch`` (dy, dx) is the sample spacing at the sensor in metres,
    ``wavelengths`` nm, ``defocus`` W020 in waves per plane (or None).
    Mirror padding against wrap-around; sizes rounded up to fast FFT lengths.
    Works in the data's dtype: float32 stays float32 (half the time, relative
    error ~1e-6); anything else is computed in float64.
    """
    data = np.asarray(data)
    dtype = np.float32 if data.dtype == np.float32 else np.float64
    h, w, n = data.shape
    wl = np.asarray(wavelengths, float)
    (my, mx), (hp, wp) = padded_grid((h, w), pitch, wl, f_number, defocus)
    planes = _mirror_padded(data, dtype, (my, hp - h - my), (mx, wp - w - mx))
    otf = plane_otfs((hp, wp), pitch, wl, f_number, defocus, dtype)
    spectrum = sfft.rfft2(planes, axes=(1, 2), overwrite_x=True, workers=CORES)
    spectrum *= otf
    out = sfft.irfft2(spectrum, s=(hp, wp), axes=(1, 2), overwrite_x=True, workers=CORES)[:, my : my + h, mx : mx + w]
    return np.ascontiguousarray(np.moveaxis(out, 0, 2))


#: Pixels per block of the cube's transposition into planes.
_TRANSPOSE_PIXELS = 4096


def _mirror_padded(data, dtype, pad_y, pad_x):
    """(N, H + pads, W + pads) planes of (H, W, N) ``data``, padded by mirror reflection (edge sample repeated).

    ``np.pad(..., mode="symmetric")`` of the transposed planes, written with
    slices into one buffer: no transposed copy, no intermediate arrays
    (padding took a fifth of the stage's time). Pads wider than the image
    (tiny images) go through ``np.pad``, which reflects repeatedly.
    """
    h, w, n = data.shape
    (top, bottom), (left, right) = pad_y, pad_x
    if max(top, bottom) > h or max(left, right) > w:
        return np.pad(np.moveaxis(data, 2, 0).astype(dtype, copy=False), ((0, 0), pad_y, pad_x), mode="symmetric")
    out = np.empty((n, h + top + bottom, w + left + right), dtype)
    # transposed by blocks of rows (~4096 pixels, whose N planes fit in the cache): 4x faster than one
    # strided copy of the whole cube, whose writes stride across N planes for every pixel read
    rows = max(1, _TRANSPOSE_PIXELS // w)
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        out[:, top + r0 : top + r1, left : left + w] = np.moveaxis(data[r0:r1], 2, 0)
    return reflect_margins(out, pad_y, pad_x)


def reflect_margins(out, pad_y, pad_x, axes=(1, 2)):
    """Fill the margins of ``out``, whose interior holds the planes, by mirror reflection (edge sample
    repeated), in place; ``axes`` the (y, x) axes (planes first, (N, H, W), by default); pads no wider
    than the interior. Returns ``out``."""
    (top, bottom), (left, right) = pad_y, pad_x
    ay, ax = axes
    h = out.shape[ay] - top - bottom
    w = out.shape[ax] - left - right

    def at(axis, start, stop, step=None):
        index = [slice(None)] * out.ndim
        index[axis] = slice(start, stop, step)
        return tuple(index)

    if top:
        out[at(ay, None, top)] = out[at(ay, top, 2 * top)][at(ay, None, None, -1)]
    if bottom:
        out[at(ay, top + h, None)] = out[at(ay, top + h - bottom, top + h)][at(ay, None, None, -1)]
    if left:
        out[at(ax, None, left)] = out[at(ax, left, 2 * left)][at(ax, None, None, -1)]
    if right:
        out[at(ax, left + w, None)] = out[at(ax, left + w - right, left + w)][at(ax, None, None, -1)]
    return out


def relative_illumination_map(camera, image):
    """(H, W) factor cos^4(theta) x vignetting at each pixel of ``image`` (1 where switched off)."""
    h, w = image.data.shape[:2]
    d = camera.distance if camera.distance is not None else image.distance
    theta = field_angles((h, w), image.angular_resolution, image.distance, d)
    ri = cos4(theta) if camera.relative_illumination else np.ones((h, w))
    if camera.vignetting > 0:
        s = image_distance(camera.focal_length, d)
        r = np.tan(theta) * s  # image height, m
        corner = 0.5 * np.hypot(camera.height * camera.pixel_size[0], camera.width * camera.pixel_size[1])
        ri = ri * np.clip(1.0 - camera.vignetting * (r / corner) ** 2, 0.0, None)
    return ri


def working_f_number(camera, distance):
    """The working f-number N (1 + m) of the camera's lens focused at ``distance`` m (m = f / (d - f)).

    The image-side cone of a lens focused at a finite distance is narrower
    than at infinity: the exit pupil is seen from the image distance
    s' = f (1 + m), not from f. The irradiance falls as 1 / (N (1 + m))^2
    (:func:`photometry`) and the diffraction cutoff is 1 / (lambda N (1 + m))
    (ISETCam's dlMTF uses the same effective f-number). At infinity
    focus m -> 0 and N_w -> N; at unit magnification (a 50 mm lens at 0.1 m) N_w = 2 N.
    """
    return float(camera.f_stop) * (1.0 + magnification(camera.focal_length, distance))


def blur_geometry(camera, image):
    """(pitch, defocus, f_number): the image's sample spacing at the sensor (dy, dx) in m, W020 in waves per
    plane (None when in focus), and the working f-number N (1 + m) (:func:`working_f_number`) of the
    camera's diffraction blur at its focus distance."""
    d = camera.distance if camera.distance is not None else image.distance
    pitch = sample_pitch(image.angular_resolution, image.distance, d, camera.focal_length)
    wl = np.asarray(image.wavelengths, float)
    waves = defocus_waves(camera.defocus, wl, camera.f_stop, camera.focal_length) if camera.defocus else None
    return pitch, waves, working_f_number(camera, d)


def photometry(camera, image):
    """The lens's factors on the light, apart from the blur: (spectral, spatial, scalar).

    ``spectral`` (N,): the lens transmittance at the image's wavelengths, or
    None; ``spatial`` (H, W): cos^4 relative illumination times vignetting at
    each pixel, or None; ``scalar``: (1 + m)^-2 of the working f-number for
    quantal sensors (see the module docstring), else 1. Their product is what
    the optics stage multiplies the blurred planes by; the fused lens stage
    (:mod:`.fused`) folds ``spectral`` into the sensor weights instead.
    """
    spectral, scalar = on_axis(camera, image)
    spatial = relative_illumination_map(camera, image) if camera.relative_illumination or camera.vignetting > 0 else None
    return spectral, spatial, scalar


def on_axis(camera, image):
    """The lens's factors on the light at the centre of the field: ``(spectral, scalar)`` of :func:`photometry`.

    What a lens does to an on-axis pixel's light whatever the scene's content: its transmittance (N,) at the
    image's (or scene's) wavelengths, or None, and (1 + m)^-2 of the working f-number for quantal sensors (1
    otherwise). Auto exposure takes them into account (a lens focused at 0.1 m on imx174 passes 1 / 1.29 of
    the light its f-number says).

    Examples
    --------
    >>> import camsim_core as cs
    >>> cam = cs.load_camera("imx174").replace(distance=0.1)
    >>> spectral, scalar = on_axis(cam, cs.load_scene("uniform"))
    >>> spectral is None, round(scalar, 3)  # m = 12 mm / (100 - 12) mm
    (True, 0.774)
    """
    d = camera.distance if camera.distance is not None else image.distance
    spectral = None if camera.lens_transmittance is None else camera.lens_transmittance.on(np.asarray(image.wavelengths, float))
    scalar = 1.0 / (1.0 + magnification(camera.focal_length, d)) ** 2 if camera.sensors.unit == "Quanta" else 1.0
    return spectral, scalar


@stage("optics", "defocus", "f_stop", "focal_length", "distance", "lens_transmittance", "relative_illumination",
       "vignetting", "height", "width", "pixel_size", "sensors")
def optics(camera, image):
    """The lens: diffraction (and defocus) blur per wavelength, transmittance, relative illumination.

    See the module docstring. Needs spectral planes; returns them in
    radiance-equivalent units. A camera without optics: the image passes unchanged.
    """
    if not optics_active(camera):
        return image
    if image.space != "spectral" or image.mosaiced:
        raise ParameterError("optics", f"acts on the spectral planes of the scene: put it before sensor_responses (got a {image.space} image)")
    data = image.data if image.data.dtype == np.float32 else np.asarray(image.data, float)  # float32 stays float32
    squeeze = data.ndim == 2
    if squeeze:
        data = data[:, :, None]
    wl = np.asarray(image.wavelengths, float)
    if camera.optics == "diffraction":
        pitch, waves, n_w = blur_geometry(camera, image)
        data = blur_planes(data, wl, pitch, n_w, waves)
    spectral, spatial, scalar = photometry(camera, image)
    factor = scalar
    if spectral is not None:
        factor = factor * spectral[None, None, :]
    if spatial is not None:
        factor = factor * spatial[:, :, None]
    if not (np.isscalar(factor) and factor == 1.0):
        data = data * np.asarray(factor, data.dtype)  # in the data's dtype: float32 stays float32
    if squeeze:
        data = data[:, :, 0]
    return image.then("optics", data=data)


def sensor_irradiance(camera, image):
    """Irradiance at the sensor (W/m^2 per band) of the optics stage's output: pi L' / (4 N^2)."""
    return image_irradiance(image.data, camera.f_stop)


def check_optics_fields(camera):
    """Validate the optics fields of a camera (called by ``Camera.__post_init__``)."""
    if camera.optics not in OPTICS:
        raise ParameterError("optics", f"must be one of {OPTICS}, got {camera.optics!r}")
    if not (np.isfinite(camera.defocus)):
        raise ParameterError("defocus", f"must be a finite number of dioptres, got {camera.defocus!r}")
    if camera.defocus != 0 and camera.optics != "diffraction":
        raise ParameterError("defocus", 'acts on the pupil: it needs optics="diffraction"')
    if camera.lens_transmittance is not None:
        t = camera.lens_transmittance
        if not isinstance(t, Spectrum) or np.any(t.values < 0) or np.any(t.values > 1):
            raise ParameterError("lens_transmittance", "must be a Spectrum of fractions in [0, 1], or None")
    if not (np.isfinite(camera.vignetting) and 0 <= camera.vignetting <= 1):
        raise ParameterError("vignetting", f"must be a fraction of light lost at the sensor corner in [0, 1], got {camera.vignetting!r}")
