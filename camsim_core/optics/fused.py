"""The lens and the sensor responses in one stage: diffraction blur through a low-rank OTF over wavelength.

The optics stage (:mod:`.stage`) blurs each of the N spectral planes by its
own OTF, then the sensor stage sums the planes with the K sensors' weights:
N forward and N inverse FFTs for K output planes. Both steps are linear, so
they can be taken in the other order, as the chapter notes for chromatic
effects (section 3.1: the stages may be reordered), if the blur's wavelength
dependence is written as a short sum of wavelength-independent blurs:

    OTF(f, lambda) ~= sum_r U_r(f) V(lambda, r),   r = 1..R,

    response_c = sum_lambda S_c(lambda) blur_lambda(L_lambda)
               = sum_r IFFT( U_r(f) FFT( sum_lambda V(lambda, r) S_c(lambda) L_lambda ) ).

The R x K weighted sums are image-domain matrix products (like the sensor
stage's), so the stage costs R x K forward and K inverse FFTs instead of
2 N. The diffraction OTF is a function of f lambda N alone, so over 400-700 nm
it is nearly of rank 1 on the frequencies a coarsely sampled scene holds: the
truncated singular value decomposition picks the smallest R whose largest
error, at any frequency and wavelength, is at most :data:`OTF_TOLERANCE`
(0.1 % of the MTF at zero frequency, twenty times below the 2 % to which the
lens's MTF is checked, and below an 8-bit step). On the default scene
(11 um samples at the sensor) R is 2 from f/1.4 to f/11 and 3 at f/16-22;
where the grid holds the OTF's cutoff (f/32 there, or a physical camera's
sub-micron samples) the cutoff moves with the wavelength and R grows to
10-12. The zero-frequency response stays exactly 1 at every wavelength (the
basis is rescaled so), so the blur still conserves energy. The transforms
run in float32 whatever the image's dtype (their rounding, ~1e-7 of the
image, is far below the OTF's tolerance). When R x K + K transforms would
not beat 2 N, or the camera has no diffraction blur, the stage runs the
optics and sensor stages in turn, exactly.

Its output is the sensor stage's (sensor space, digital units): the spectral
planes at the sensor are never made. The optics stage, which makes them,
stays available for an architecture that needs them (put it explicitly
before ``sensor_responses``). Written by hand: no library fuses a
per-wavelength blur with a spectral projection.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.fft as sfft

from .._compiled import compiled
from .._parallel import CORES, PARALLEL_VALUES
from ..simulation._stage import stage
from ..simulation.sensor import respond, sensor_responses
from .stage import blur_geometry, optics, optics_active, otf_key, otfs_at, padded_grid, photometry, radial_frequency, \
    reflect_margins

__all__ = ["lens_sensor_responses", "otf_factors", "OTF_TOLERANCE"]

#: Largest error of the low-rank OTF, at any frequency and wavelength (the OTF is 1 at zero frequency). Measured
#: on the default scene at f/11, the responses then differ from the per-wavelength blur's by 4e-5 of their maximum.
OTF_TOLERANCE = 1e-3

#: Samples of the radial frequency table the factors are computed on (and interpolated from).
_RADIAL_SAMPLES = 8193


def otf_factors(shape, pitch, wavelengths, f_number, defocus=None, *, tolerance=OTF_TOLERANCE, dtype=np.float64):
    """Low-rank factors of the per-wavelength OTFs on the real-FFT grid of an (H, W) plane.

    Parameters
    ----------
    shape : (int, int)
        The (padded) plane's size.
    pitch : (float, float)
        Sample spacing at the sensor (dy, dx), metres.
    wavelengths : array_like
        nm, one per plane.
    f_number : float
    defocus : array_like or None
        W020 in waves per wavelength.
    tolerance : float
        Largest absolute error of the approximation.
    dtype : float32 or float64
        Of ``U`` (the image's).

    Returns
    -------
    U : ndarray, (H, W//2 + 1, R)
        Wavelength-independent transfer functions, pixel-major like the images.
    V : ndarray, (N, R)
        Their weight at each wavelength: OTF(f, lambda_n) ~= sum_r U[..., r](f) V[n, r].

    Both read-only (cached: a pure function of the arguments).
    """
    return _otf_factors(*otf_key(shape, pitch, wavelengths, f_number, defocus), float(tolerance), np.dtype(dtype).name)


@lru_cache(maxsize=8)
def _otf_factors(shape, pitch, wavelengths, f_number, defocus, tolerance, dtype):
    rho = radial_frequency(shape, pitch)
    waves = None if defocus is None else np.asarray(defocus)
    # the OTF is radial: the decomposition is made on a fine table of radii, then interpolated onto the grid
    # (the optics stage interpolates its defocused OTFs from a table the same way)
    samples = int(max(_RADIAL_SAMPLES, 256 * (np.max(np.abs(waves)) if waves is not None else 0) + 1))
    table = np.linspace(0.0, float(rho.max()), samples)
    exact = otfs_at(table, wavelengths, f_number, waves)  # (N, M), exact[:, 0] = 1 (zero frequency)
    _, _, vt = np.linalg.svd(exact.T, full_matrices=False)
    for rank in range(1, len(wavelengths) + 1):
        basis = vt[:rank].T  # (N, R), orthonormal columns
        radial = basis.T @ exact  # (R, M): the wavelength-independent transfer functions
        weights = basis / (basis @ radial[:, 0])[:, None]  # the zero-frequency response exactly 1 at every wavelength
        if np.max(np.abs(exact - weights @ radial)) <= tolerance:
            break
    u = np.stack([np.interp(rho, table, r) for r in radial], axis=-1).astype(dtype)
    u.flags.writeable = False
    weights.flags.writeable = False
    return u, weights


def _lens_responses(data, weights, factors, pads, spectral, spatial, scalar):
    """(H, W, K) responses of (H, W, N) ``data`` through the lens: see the module docstring.

    ``weights`` (N, K) the sensor weights with the gain; ``factors`` (U, V) from
    :func:`otf_factors` on the padded grid; ``pads`` ((top, bottom), (left, right));
    ``spectral``, ``spatial``, ``scalar`` the lens's photometry (:func:`.stage.photometry`).
    Pixel-major throughout: the weighted sums come out of the matrix product
    as (H, W, R K), the transforms run over the first two axes, and the
    responses come back as (H, W, K) (no transposition of planes, which cost
    as much as the transforms).
    """
    h, w, n = data.shape
    u, v = factors
    rank, k = v.shape[1], weights.shape[1]
    (top, bottom), (left, right) = pads
    hp, wp = h + top + bottom, w + left + right
    if spectral is not None:
        weights = weights * spectral[:, None]  # the transmittance is a per-wavelength gain: fold it into the weights
    # column r * K + c: basis function r's spectral weight times sensor c's
    mixed = (v[:, :, None] * weights[:, None, :]).reshape(n, rank * k).astype(data.dtype)
    # the transforms in float32 whatever the data's dtype: their rounding (~1e-7 of the image) is far below the
    # low-rank OTF's own error, and float64 transforms cost twice as much
    planes = np.empty((hp, wp, rank * k), np.float32)
    planes[top : top + h, left : left + w] = (data.reshape(h * w, n) @ mixed).reshape(h, w, rank * k)
    reflect_margins(planes, pads[0], pads[1], axes=(0, 1))
    # the explorer's scenes (~0.4 M values) on one thread: starting threads costs more than it saves
    # (measured: 4.6 against 5.5 ms a call on the default scene)
    workers = CORES if planes.size >= PARALLEL_VALUES else 1
    spectrum = sfft.rfft2(planes, axes=(0, 1), overwrite_x=True, workers=workers)
    del planes
    summed = np.empty(spectrum.shape[:2] + (k,), spectrum.dtype)
    # complex values as (real, imaginary) pairs: the factors are real, so each multiplies both halves
    _combine_kernel()(spectrum.reshape(-1, rank, k).view(np.float32), u.reshape(-1, rank), summed.reshape(-1, k).view(np.float32))
    del spectrum
    out = sfft.irfft2(summed, s=(hp, wp), axes=(0, 1), overwrite_x=True, workers=workers)
    out = out[top : top + h, left : left + w].astype(data.dtype)  # a float64 image gives float64 responses
    factor = scalar if spatial is None else spatial[:, :, None] * scalar
    if not (np.isscalar(factor) and factor == 1.0):
        out *= np.asarray(factor, out.dtype)
    return out


def _combine(spectrum, u, out):
    """out[p, j] = sum_r u[p, r] spectrum[p, r, j]: the R blurred spectra of each sensor summed.

    Compiled by numba (:func:`_combine_kernel`): numpy would multiply a
    complex array by a real one through a complex copy of the real one and
    a full-size temporary per term (1.1 ms of a 4 ms stage on the default
    scene, against 0.25 ms here).
    """
    for p in range(out.shape[0]):
        for j in range(out.shape[1]):
            out[p, j] = spectrum[p, 0, j] * u[p, 0]
        for r in range(1, u.shape[1]):
            a = u[p, r]
            for j in range(out.shape[1]):
                out[p, j] += spectrum[p, r, j] * a


_combine_kernel = compiled(_combine)


@stage(*dict.fromkeys(optics.uses + sensor_responses.uses))
def lens_sensor_responses(camera, image):
    """The optics and sensor-response stages in one: sensor responses to the light through the lens.

    The same result as ``sensor_responses(camera, optics(camera, image))``
    within :data:`OTF_TOLERANCE` of the blur (see the module docstring), at a
    fraction of its cost; exactly that when the camera has no diffraction blur
    or the fused form would not be cheaper. A camera with no optics: the
    sensor stage alone. Cameras whose optics are on get this stage in place of
    ``sensor_responses`` (see :class:`~camsim_core.camera.Camera`).
    """
    if not optics_active(camera):
        return sensor_responses(camera, image)
    if camera.optics != "diffraction" or image.space != "spectral" or image.mosaiced or np.ndim(image.data) != 3:
        return sensor_responses(camera, optics(camera, image))
    h, w, n = image.data.shape
    k = len(camera.sensors.names)
    wl = np.asarray(image.wavelengths, float)
    pitch, waves, n_w = blur_geometry(camera, image)  # n_w: the working f-number N (1 + m)
    (my, mx), (hp, wp) = padded_grid((h, w), pitch, wl, n_w, waves)
    pads = ((my, hp - h - my), (mx, wp - w - mx))
    if max(pads[0]) > h or max(pads[1]) > w:  # an image smaller than the blur: padding reflects repeatedly
        return sensor_responses(camera, optics(camera, image))
    factors = otf_factors((hp, wp), pitch, wl, n_w, waves, dtype=np.float32)
    if factors[1].shape[1] * k + k >= 2 * n:
        return sensor_responses(camera, optics(camera, image))
    spectral, spatial, scalar = photometry(camera, image)
    return respond(camera, image.then("optics"),
                   lambda data, weights: _lens_responses(data, weights, factors, pads, spectral, spatial, scalar))
