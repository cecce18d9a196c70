"""The electron-level sensor: from mean photo-electrons to digital values, with EMVA 1288's noise model.

Used by the noise stage for ``noise_model="photon"``. The sensor stage has
put the mean number of photo-electrons of each pixel, mu_e = eta mu_p
(quantum efficiency x fill factor x photons on the pixel area in the
exposure), divided by ``electrons_per_dn``, in the image. This module
follows the linear camera model of EMVA Standard 1288 (Release 4.0,
section 2; symbols in brackets):

* photo response non-uniformity (PRNU_1288, ``prnu``, a fraction rms): each
  pixel's gain is 1 + prnu x g, g a fixed standard normal pattern;
* dark signal (mu_d): ``dark_current`` (mu_I, e-/s) x exposure time;
* photon and dark-current shot noise: a Poisson draw of mean
  mu_e (1 + prnu g) + mu_d (sigma_e^2 = mu_e);
* saturation (mu_e.sat, ``full_well``): the charge is clipped at the full well;
* dark signal non-uniformity (DSNU_1288, ``dsnu``, e- rms): a fixed
  offset pattern dsnu x o, o standard normal, of either sign (an offset of
  the read-out, as the read noise);
* temporal dark noise (sigma_d, ``read_noise``, e- rms): Gaussian;
* overall system gain (K, DN/e-) = ``analog_gain`` / ``electrons_per_dn``:
  ``electrons_per_dn`` is the conversion gain's inverse at unit analog gain;
* an offset in DN (``noise_mean``); the black level and the ADC (``bits``)
  are the digitize stage's.

The fixed patterns g and o come from ``pattern_seed`` (the sensor's own
identity): the same in every frame. The temporal noise comes from
``seed``. Drawing order (Poisson, then the read noise, from one
generator seeded with ``seed``) is that of the plain photon model, so with
every sensor imperfection switched off the result is the same draw.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..errors import ParameterError

__all__ = ["electron_sensor", "fixed_patterns", "system_gain", "full_well_level", "check_sensor_fields", "photon_transfer"]


def system_gain(camera):
    """Overall system gain K, DN per electron: ``analog_gain / electrons_per_dn``."""
    return float(camera.analog_gain) / float(camera.electrons_per_dn)


def full_well_level(camera):
    """The raw value of a pixel at the full well: K x ``full_well`` (DN above the black level), or None.

    Parameters
    ----------
    camera : Camera or None
        An electron-level camera (``noise_model="photon"``) with a ``full_well`` (e-) has one; a camera in
        digital units (the chapter's), one without a full well, or None has none.

    Returns
    -------
    float or None
        ``full_well`` (e-) x the system gain K (:func:`system_gain`, DN/e-): the noiseless level the charge
        saturates at, in the raw's digital units above its black level, before the ``noise_mean`` offset,
        the ADC's non-linearity, rounding and clipping. It is the top of an unquantized electron-level
        sensor's range: auto exposure aims below it
        (:func:`camsim_core.simulation.exposure.recordable_level`) and the exposure measures count
        saturated pixels and the signal against it (:func:`camsim_core.metrics.exposure.saturation_level`).

    Examples
    --------
    imx174's ADC spans its 32,000 e- full well at 12 bits; unquantized, the level stays that of the 12-bit
    conversion (7.81 e-/DN):

    >>> import camsim_core as cs
    >>> cam = cs.load_camera("imx174")
    >>> round(full_well_level(cam)), round(full_well_level(cam.replace(bits=None)))
    (4095, 4095)
    >>> full_well_level(cs.load_camera("kodak-dcs200")) is None
    True
    """
    if camera is None or getattr(camera, "noise_model", None) != "photon" or getattr(camera, "full_well", None) is None:
        return None
    return float(camera.full_well) * system_gain(camera)


@lru_cache(maxsize=16)
def _patterns(seed, shape):
    rng = np.random.default_rng([int(seed), 1288])
    g = rng.standard_normal(shape)
    o = rng.standard_normal(shape)
    g.flags.writeable = False
    o.flags.writeable = False
    return g, o


def fixed_patterns(pattern_seed, shape):
    """The PRNU and DSNU patterns (standard normal, read-only) of a sensor of ``shape``: the same for every frame."""
    return _patterns(int(pattern_seed), tuple(int(s) for s in shape))


def electron_sensor(camera, image):
    """Mean photo-electrons (``image.data x electrons_per_dn``) to noisy digital values (not yet quantized)."""
    rng = np.random.default_rng(camera.seed)
    data = np.asarray(image.data, float)
    mu_e = np.clip(data, 0, None) * camera.electrons_per_dn
    prnu_on = camera.prnu > 0
    dsnu_on = camera.dsnu > 0
    if prnu_on or dsnu_on:
        g, o = fixed_patterns(camera.pattern_seed, data.shape)
    if prnu_on:
        mu_e = mu_e * np.clip(1.0 + camera.prnu * g, 0.0, None)
    mu_d = camera.dark_current * camera.exposure
    electrons = rng.poisson(mu_e + mu_d if mu_d > 0 else mu_e).astype(float)
    if camera.full_well is not None:
        np.minimum(electrons, camera.full_well, out=electrons)
    if dsnu_on:
        electrons += camera.dsnu * o
    if camera.read_noise > 0:
        electrons += rng.normal(0.0, camera.read_noise, size=data.shape)
    k = system_gain(camera)
    out = electrons * k + camera.noise_mean
    sigma = float(np.sqrt(camera.read_noise**2 + float(mu_e.mean()) + mu_d) * k)
    extra = image.extra
    if camera.full_well is not None:
        from ..metrics.exposure import saturation_level

        # where the charge saturates, above the black level: processing counts such pixels as clipped whether or
        # not the ADC clipped them too (imx174's well sits 3 DN below its 12-bit top: read noise decided, pixel by
        # pixel, whether a saturated patch rendered white or orange, and 12 bits scored 8.36 against 3.47 at 0)
        extra = dict(extra, sensor_saturation=float(saturation_level(camera)))
    # the analog gain scales the signal like exposure: the image's gain carries it, so rendering divides it out
    return image.then("noise", data=out, noise_sigma=sigma, gain=image.gain * float(camera.analog_gain), extra=extra)


def _positive_or_zero(camera, name, unit):
    v = getattr(camera, name)
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not np.isfinite(v) or v < 0:
        raise ParameterError(name, f"must be a non-negative number of {unit}, got {v!r}")


def check_sensor_fields(camera):
    """Validate the electron-level sensor fields of a camera (called by ``Camera.__post_init__``)."""
    ff = camera.fill_factor
    if isinstance(ff, bool) or not isinstance(ff, (int, float, np.integer, np.floating)) or not (np.isfinite(ff) and 0 < ff <= 1):
        raise ParameterError("fill_factor", f"must be a fraction in (0, 1] of the pixel area that collects light, got {ff!r}")
    _positive_or_zero(camera, "dark_current", "electrons per second")
    _positive_or_zero(camera, "dsnu", "electrons rms")
    _positive_or_zero(camera, "prnu", "fraction rms (0.01 = 1 %)")
    g = camera.analog_gain
    if isinstance(g, bool) or not isinstance(g, (int, float, np.integer, np.floating)) or not (np.isfinite(g) and g > 0):
        raise ParameterError("analog_gain", f"must be a positive number, got {g!r}")
    if camera.full_well is not None:
        fw = camera.full_well
        if isinstance(fw, bool) or not isinstance(fw, (int, float, np.integer, np.floating)) or not (np.isfinite(fw) and fw > 0):
            raise ParameterError("full_well", f"must be a positive number of electrons or None (no saturation), got {fw!r}")
        if fw <= camera.read_noise:
            raise ParameterError("full_well", f"{fw:g} e- is not above the read noise ({camera.read_noise:g} e- rms): no signal could be told from noise")
    if isinstance(camera.pattern_seed, bool) or not isinstance(camera.pattern_seed, (int, np.integer)) or camera.pattern_seed < 0:
        raise ParameterError("pattern_seed", f"must be a whole number >= 0, got {camera.pattern_seed!r}")
    physical = (camera.full_well is not None or camera.dark_current > 0 or camera.dsnu > 0 or camera.prnu > 0
                or camera.analog_gain != 1)
    if physical and camera.noise_model != "photon":
        raise ParameterError("noise_model", 'full_well, dark_current, dsnu, prnu and analog_gain belong to the electron-level sensor: '
                             'use noise_model="photon" (with sensitivities in quanta)')


def photon_transfer(camera, exposures, *, radiance=None, size=64, seeds=(0, 1)):
    """EMVA 1288's photon transfer of a camera's sensor: flat-field mean and temporal variance per exposure.

    Two frames (``seeds``) of a flat field (the same radiance in every band)
    per exposure time, with the camera's sensor but no lens effects and no
    mosaic (each sensor class at every pixel). ``radiance`` (W/sr/m^2 per
    band) defaults to the level that brings the most sensitive class to 1.2x
    its saturation at the longest exposure. Per EMVA 1288: mu_y = mean of the
    two frames less the black level; sigma_y^2 = mean((y_A - y_B)^2) / 2 -
    (mu_A - mu_B)^2 / 2.

    Returns a dict: ``exposure`` (E,), ``mean`` and ``variance`` (E, K) in DN,
    ``names`` of the classes, ``radiance``, ``gain`` (K, DN/e-).
    """
    from .pipeline import run_stages
    from .sensor import sensor_weights

    if camera.noise_model != "photon":
        raise ParameterError("noise_model", 'photon transfer needs the electron-level sensor (noise_model="photon")')
    t = np.asarray(exposures, float).ravel()
    if t.size < 2 or not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise ParameterError("exposures", f"need at least two positive exposure times (s), got {exposures!r}")
    n = int(size)
    if not 8 <= n <= 1024:
        raise ParameterError("size", f"must be 8 to 1024 pixels, got {size!r}")
    cam = camera.replace(mosaic=None, optics="none", defocus=0.0, lens_transmittance=None, relative_illumination=False,
                         vignetting=0.0, height=n, width=n, distance=None)
    wl = cam.sensors.wavelengths
    if radiance is None:
        per_radiance = sensor_weights(cam.replace(exposure=float(t.max())), wl)[0].sum(axis=0).max()  # e- / epd
        limit = (cam.full_well / cam.electrons_per_dn if cam.full_well is not None
                 else (cam.full_scale or 2.0**16) / system_gain(cam) / cam.electrons_per_dn)
        radiance = 1.2 * limit / per_radiance
    image = image_from_scene_data(np.full((n, n, wl.size), float(radiance)), wl, cam.angular_resolution)
    means, variances = [], []
    for ti in t:
        a, b = (run_stages(cam.replace(exposure=float(ti), seed=int(s)), image).data - cam.black_level for s in seeds[:2])
        ma, mb = a.mean(axis=(0, 1)), b.mean(axis=(0, 1))
        means.append((ma + mb) / 2)
        variances.append(np.mean((a - b) ** 2, axis=(0, 1)) / 2 - (ma - mb) ** 2 / 2)
    return {"exposure": t, "mean": np.array(means), "variance": np.array(variances), "names": cam.sensors.names,
            "radiance": float(radiance), "gain": system_gain(cam)}


def image_from_scene_data(data, wavelengths, angular_resolution):
    """A spectral CameraImage of ``data`` seen from 1 m (the flat fields of :func:`photon_transfer`)."""
    from ..image import CameraImage

    return CameraImage(data=data, wavelengths=np.asarray(wavelengths, float), distance=1.0,
                       angular_resolution=angular_resolution, space="spectral", history=("flat field",))
