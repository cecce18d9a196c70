"""Signal-to-noise ratio on uniform regions, per channel and for luminance, and its curve against light level.

SNR = mean / standard deviation of a uniform region, in dB as 20 log10(SNR)
(the ratio of amplitudes; ISO 15739 reports the same ratio). The pedestal
(``black_level``) is subtracted first, as a raw converter does, and the
values stay signed: the noise around black is measured as the sensor gave
it, never clipped at 0 (which would raise the mean and lower the noise of a
dim field, and so its SNR). A raw
mosaic is measured per sensor class on that class's own samples, before any
demosaicing mixes neighbours (which would lower the noise); luminance then
needs a full-colour image.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = ["snr", "snr_db", "region_snr", "snr_vs_light"]


def snr(values):
    """mean / standard deviation (ddof 1) of an array of samples; ``inf`` for a noiseless region.

    Examples
    --------
    Mean 10, standard deviation 1:

    >>> snr([9.0, 10.0, 11.0])
    10.0
    """
    v = np.asarray(values, float).ravel()
    if v.size < 2:
        raise ParameterError("region", f"needs at least 2 samples, got {v.size}")
    sd = v.std(ddof=1)
    return float("inf") if sd == 0 else float(v.mean() / sd)


def snr_db(values):
    """:func:`snr` in decibels, 20 log10(mean / sd).

    Examples
    --------
    >>> snr_db([9.0, 10.0, 11.0])
    20.0
    """
    s = snr(values)
    return float("inf") if np.isinf(s) else float(20.0 * np.log10(s)) if s > 0 else float("-inf")


def _roi(shape, roi):
    if roi is None:
        return (slice(None), slice(None))
    y0, y1, x0, x1 = (int(v) for v in roi)
    if not (0 <= y0 < y1 <= shape[0] and 0 <= x0 < x1 <= shape[1]):
        raise ParameterError("roi", f"(y0, y1, x0, x1) = {roi} must lie within the {shape[0]} x {shape[1]} image")
    return (slice(y0, y1), slice(x0, x1))


#: Fewest samples of a channel for :func:`region_snr`'s ``detrend`` (a quadratic has 6 coefficients).
DETREND_MIN_SAMPLES = 64


def _flatten(values, ys, xs, full):
    """``values`` at pixels ``(ys, xs)`` less their least-squares quadratic surface in x and y, plus its mean:
    the mean kept, the low-frequency variation (lens fall-off, cos^4) removed. Written by hand (six columns of
    a least-squares fit). Unchanged when there are too few samples or most are at ``full`` (a clipped channel's
    noise is the clipping)."""
    v = np.asarray(values, float).ravel()
    if v.size < DETREND_MIN_SAMPLES or (full is not None and np.mean(v >= full) > 0.5):
        return v
    y = (np.asarray(ys, float).ravel() - np.mean(ys)) / max(np.ptp(ys), 1.0)
    x = (np.asarray(xs, float).ravel() - np.mean(xs)) / max(np.ptp(xs), 1.0)
    a = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
    coef, *_ = np.linalg.lstsq(a, v, rcond=None)
    trend = a @ coef
    return v - trend + trend.mean()


def region_snr(image, roi=None, camera=None, detrend=False):
    """SNR of a uniform region of a camera image (or an (H, W) / (H, W, K) array), per channel and luminance.

    Parameters
    ----------
    image : CameraImage or array
        A raw mosaic (measured per sensor class on its own samples), a
        demosaiced or full-colour image, or an array.
    roi : (y0, y1, x0, x1), optional
        The uniform region, pixels; default the whole image.
    camera : Camera, optional
        The camera that made ``image``: an image without a bit depth from an
        electron-level sensor saturates at its full well
        (:func:`~camsim_core.metrics.exposure.saturation_level`), which no ADC
        marks (imx174 at 0 bits read 72.8 dB at its full well, unmarked).
    detrend : bool, optional
        Measure the noise about each channel's least-squares quadratic
        surface over the region (the mean unchanged): the low-frequency
        non-uniformity of the field (lens fall-off) removed, as ISO 15739
        asks. Without it, imx174's 8 % cos^4 fall-off over the uniform
        chart's central region read as noise: 31.7 dB where photon statistics,
        read noise, DSNU and PRNU give 41.8 dB.

    Returns
    -------
    dict
        Channel name -> ``{"mean", "sigma", "snr", "snr_db", "saturated"}``
        (``saturated``: most of the region at the full scale, where the
        clipped noise makes the SNR meaningless); ``"luminance"`` too for a
        full-colour image of more than one channel.

    Examples
    --------
    >>> import numpy as np
    >>> stats = region_snr(np.array([[9.0, 10.0], [11.0, 10.0]]))["0"]
    >>> stats["mean"], round(stats["snr"], 3), stats["saturated"]
    (10.0, 12.247, False)
    """
    from ..demosaicing import saturation_level
    from ..image import subtract_black_level
    from .sharpness import luminance_weights

    if hasattr(image, "black_level"):
        image = subtract_black_level(image)
    # where the raw clipped, in the units of the (pedestal-free) data: one value, or one per sensor class
    full = saturation_level(image) if hasattr(image, "full_scale") and hasattr(image, "quantized") else None
    if full is None and camera is not None:
        from .exposure import saturation_level as full_well_level

        full = full_well_level(camera)  # above the black level, as the data now are
    data = np.asarray(getattr(image, "data", image), float)
    if data.ndim not in (2, 3):
        raise ParameterError("image", f"expected (H, W) or (H, W, K) data, got shape {data.shape}")
    sel = _roi(data.shape, roi)
    names = tuple(getattr(image, "sensor_names", ()) or ())
    planes = {}
    if getattr(image, "mosaiced", False) and data.ndim == 2:
        from ..simulation import tile_index_map

        idx = tile_index_map(image.tile, data.shape)[sel]
        region = data[sel]
        for k in range(image.n_sensors or int(image.tile.max()) + 1):
            here = idx == k
            values = region[here]
            if detrend:
                level = full[k] if full is not None and np.ndim(full) and k < np.size(full) else full
                values = _flatten(values, *np.nonzero(here), None if np.ndim(level) else level)
            planes[names[k] if k < len(names) else str(k)] = values
    else:
        d = data[..., None] if data.ndim == 2 else data
        if len(names) != d.shape[2]:
            names = tuple(str(i) for i in range(d.shape[2]))
        weights = luminance_weights(image) if d.shape[2] > 1 else None
        if full is not None and np.ndim(full) and np.size(full) != d.shape[2]:
            full = None
        region = d[sel]
        if detrend:
            ys, xs = np.indices(region.shape[:2])
            region = np.stack([_flatten(region[..., c], ys, xs, None if full is None else
                                        (np.asarray(full, float)[c] if np.ndim(full) else full)).reshape(region.shape[:2])
                               for c in range(region.shape[2])], axis=2)
        return _colour_stats(region, names, weights, None if full is None else np.asarray(full, float))
    out = {}
    for k, (n, v) in enumerate(planes.items()):
        level = full[k] if full is not None and np.ndim(full) and k < np.size(full) else full
        out[n] = _stats(np.asarray(v, float).ravel(), None if np.ndim(level) else level)
    return out


def _entry(mean, sigma, saturated):
    s = float("inf") if sigma == 0 else mean / sigma
    db = float("inf") if np.isinf(s) else float(20.0 * np.log10(s)) if s > 0 else float("-inf")
    return {"mean": float(mean), "sigma": float(sigma), "snr": float(s), "snr_db": db, "saturated": bool(saturated)}


def _stats(v, full):
    if v.size < 2:
        raise ParameterError("region", f"needs at least 2 samples, got {v.size}")
    return _entry(v.mean(), v.std(ddof=1), full is not None and np.mean(v >= full) > 0.5)


def _colour_stats(region, names, weights, full):
    """Per-channel and luminance statistics of (h, w, K) samples from one covariance product (no per-channel passes)."""
    x = region.reshape(-1, region.shape[2])
    n = x.shape[0]
    if n < 2:
        raise ParameterError("region", f"needs at least 2 samples, got {n}")
    shift = x[0].copy()  # subtracting a sample keeps the one-pass variance well conditioned
    xs = x - shift
    s1 = xs.sum(axis=0)
    cov = (xs.T @ xs - np.outer(s1, s1) / n) / (n - 1)
    mean = s1 / n + shift
    sat = (x >= full).mean(axis=0) > 0.5 if full is not None else np.zeros(x.shape[1], bool)
    out = {name: _entry(mean[k], np.sqrt(max(cov[k, k], 0.0)), sat[k]) for k, name in enumerate(names)}
    if weights is not None:
        out["luminance"] = _entry(weights @ mean, np.sqrt(max(weights @ cov @ weights, 0.0)), bool(sat.any()))
    return out


def snr_vs_light(camera, luminances, *, size=64, illuminant="D65", seed=0, **simulate_kwargs):
    """SNR (dB) of ``camera`` on a uniform field at each of ``luminances`` (cd/m^2).

    The field fills the camera's view at its own sampling; returns
    ``{"luminance": array, channel: array of dB, ...}`` (channels as
    :func:`region_snr` reports them; NaN where the field saturates the channel).
    """
    from ..camera import load_camera
    from ..scene.charts import uniform_scene
    from ..simulation import simulate

    cam = load_camera(camera)
    lum = np.asarray(luminances, float).ravel()
    if lum.size == 0 or np.any(~np.isfinite(lum)) or np.any(lum <= 0):
        raise ParameterError("luminances", "must be positive numbers of cd/m^2")
    cam = cam.replace(height=size, width=size, seed=seed)
    out = {"luminance": lum}
    for i, L in enumerate(lum):
        scene = uniform_scene(size, luminance=float(L), illuminant=illuminant, angular_resolution=cam.angular_resolution)
        res = region_snr(simulate(scene, cam, **simulate_kwargs), camera=cam)  # saturated at its full well too
        for name, r in res.items():
            out.setdefault(name, np.full(lum.size, np.nan))[i] = np.nan if r["saturated"] else r["snr_db"]
    return out
