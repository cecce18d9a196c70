"""Bayesian demosaicing (Brainard's method; chapter section 4.1 and 5, references 24 and 25).

The full-colour image is modelled as a stationary Gaussian random field
whose mean and spatial-by-sensor covariance are estimated from a bilinearly
demosaiced version of the image itself (section 5: "the image statistics
are obtained by analyzing the distribution of sensor responses in a
bilinearly demosaiced version of the image"). The covariance is

    C[(a, p), (b, q)] = sum_i  lambda_i v_ai v_bi  rho_yi^|p_y - q_y|  rho_xi^|p_x - q_x|

with ``v_i``, ``lambda_i`` the principal components of the sensor
responses in the bilinear image (the cross-sensor covariance) and separable
exponential spatial correlations ``rho_y``, ``rho_x`` per pixel, taken from
the correlation of the bilinear image's largest (luminance-like) component
at a lag of one tile period (where interpolation has not smoothed it).
The model allows a ``rho`` per component, but the chromatic components of a
bilinear image are dominated by its own false-colour artifacts (their lag
correlation comes out far too low: 0.6 against 0.95 in the true image on
scikit-image's ``coffee``), so all components share the luminance value;
with per-component values from the bilinear image the estimate loses
2-5 dB PSNR on ``coffee``.

One addition to the image-estimated prior (a hyperprior of this
implementation, ``detail=0.1``): an achromatic component along the mean
sensor response ``mu / |mu|`` (a change of intensity at fixed colour),
of variance ``detail`` x the largest principal variance, whose spatial
correlation is the bilinear image's at a lag of one pixel. It encodes that
fine detail in natural images is mostly achromatic (the assumption behind
Freeman's method). It costs < 0.15 dB PSNR on scikit-image's astronaut,
coffee and chelsea, and lets the estimator carry the one-pixel structure
of Figure 1.10's stripes into the other sensor classes (an image whose R
and B samples are constant gives the estimated prior no R-G or B-G
covariance at all, so without it nothing but bilinear is possible).

The mosaic samples ``y`` of a ``window x window`` neighbourhood are
``y = A x + n`` with ``n`` white noise of variance ``image.noise_sigma^2``
(plus the 1/12 DU^2 of quantization for a quantized image); the posterior
mean of the K values at the centre pixel is

    x_hat = mu + C_xy (C_yy + sigma^2 I)^-1 (y - mu_y)

(Brainard 1994; Brainard & Sherman 1995). By default (``local_mean=True``)
the mean of each class in the window is itself unknown, with a flat prior
(the generalized-least-squares local mean replaces ``mu``; "ordinary
kriging"): the estimator then reproduces any uniform field exactly (with
the global ``mu`` it left a 0.5 % periodic pattern in uniform areas) and
gains 0.03-0.14 dB PSNR. The window is 7 x 7 for a Bayer tile
(``2 max(n, m) + 3``). The estimator depends only on the pixel's position
in the tile, so it is computed once per position and applied as linear
filters (strided views of the mosaic, one matrix product per position).
Edges are padded by reflection that keeps the tile phase. Works for any
tile, any number of sensors, and tiered tiles.

Two modes
---------
``mode="extended"`` (the default, ``demosaic(image, "bayesian")``) is
camsim's extension described above: the achromatic detail term, local
(per-window) means, a 7 x 7 window for a Bayer tile, and the image's true
noise variance in the likelihood.

``mode="original"`` (``demosaic(image, "bayesian-original")``) is as close
to Brainard's method as the chapter and the papers allow: the prior
estimated from the bilinear image as above but with no detail term
(``detail=0``), ONE global mean per sensor class (``local_mean=False``), a
5 x 5 neighbourhood, and a likelihood whose noise variance is a fixed
fraction of the prior's mean variance (``noise_fraction``, default
:data:`ORIGINAL_NOISE_FRACTION` = 0.01: the noise is not known to the
method, only assumed small against the signal), whatever noise the camera
added. The chapter gives none of these numbers; the fraction is camsim's
choice and is exposed. With one global mean a uniform area next to other
content is pulled towards the image's mean (by up to 1.5 % in the tests'
astronaut example), and the mode cannot carry one-pixel achromatic detail
into classes whose estimated covariance is zero (section 4.1's stripes).

Hand-written: no library provides this estimator.

References
----------
* D. H. Brainard, "Bayesian method for reconstructing color images from
  trichromatic samples", Proc. IS&T 47th Annual Meeting, 375-380 (1994).
* D. H. Brainard and D. Sherman, "Reconstructing images from trichromatic
  samples: from basic research to practical applications", Proc. IS&T/SID
  3rd Color Imaging Conference, 4-10 (1995).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._compiled import compiled
from .._parallel import CORES, run_blocks, split
from ..errors import ParameterError
from ._masks import check_mosaiced, phase_pad_index
from .bilinear import bilinear_planes

__all__ = ["demosaic_bayesian", "GaussianPrior", "estimate_prior", "posterior_filters", "MODES", "ORIGINAL_NOISE_FRACTION"]

#: ``mode`` values of :func:`demosaic_bayesian`.
MODES = ("extended", "original")

#: The original mode's likelihood noise variance, as a fraction of the prior's mean variance.
ORIGINAL_NOISE_FRACTION = 0.01

#: Bounds on the per-pixel spatial correlation of a component.
RHO_RANGE = (0.05, 0.995)


@dataclass(frozen=True)
class GaussianPrior:
    """Stationary Gaussian image prior (see the module docstring).

    ``mean`` (K,); ``vectors`` (K, K) and ``variances`` (K,) the principal
    components of the sensor responses with spatial correlations ``rho_y``,
    ``rho_x`` (K,) per pixel; plus an achromatic detail component along
    ``detail_vector`` (K,) of variance ``detail_variance`` and correlations
    ``detail_rho_y``, ``detail_rho_x``.
    """

    mean: np.ndarray
    vectors: np.ndarray
    variances: np.ndarray
    rho_y: np.ndarray
    rho_x: np.ndarray
    detail_vector: np.ndarray | None = None
    detail_variance: float = 0.0
    detail_rho_y: float = 0.0
    detail_rho_x: float = 0.0

    def covariance(self, a, b, dy, dx):
        """Cov(x_a(p), x_b(p + d)) for arrays of classes ``a``, ``b`` and offsets ``dy``, ``dx`` (broadcast)."""
        v = self.vectors
        w = v[a, :] * v[b, :] * self.variances
        ady, adx = np.abs(np.asarray(dy)), np.abs(np.asarray(dx))
        c = np.sum(w * self.rho_y ** ady[..., None] * self.rho_x ** adx[..., None], axis=-1)
        if self.detail_variance > 0:
            u = self.detail_vector
            c = c + self.detail_variance * u[a] * u[b] * self.detail_rho_y**ady * self.detail_rho_x**adx
        return c


def _lag_sums(z, lag, axis):
    """Sums (x_p x_{p+lag}, x_p^2, x_{p+lag}^2) of a plane ``z`` (h, w) along ``axis``."""
    if z.shape[axis] <= lag:
        return np.zeros(3)
    a, b = (z[:-lag], z[lag:]) if axis == 0 else (z[:, :-lag], z[:, lag:])
    return np.array([np.einsum("ij,ij->", a, b), np.einsum("ij,ij->", a, a), np.einsum("ij,ij->", b, b)])


def prior_sample(data, tile, k, max_pixels=1 << 18):
    """Bilinear demosaic of the whole mosaic, or of evenly spaced strips of it holding about ``max_pixels``.

    The prior needs image statistics, not every pixel: strips of 64 rows
    (whole tiles) keep the estimate cheap on large images.
    """
    h, w, _ = data.shape
    n = tile.shape[0]
    if h * w <= max_pixels:
        return [bilinear_planes(data, tile, k)]
    rows = max(n, (64 // n) * n)
    count = max(1, min(h // rows, max_pixels // (rows * w) or 1))
    starts = np.linspace(0, h - rows, count).astype(int) // n * n
    return [bilinear_planes(data[s : s + rows], tile, k) for s in np.unique(starts)]


def _rho(sums, lag):
    """Per-pixel correlation from lag sums at ``lag`` pixels, bounded to :data:`RHO_RANGE`."""
    lo, hi = RHO_RANGE
    r = sums[0] / np.sqrt(sums[1] * sums[2]) if sums[1] * sums[2] > 0 else hi**lag
    return float(np.clip(np.clip(r, lo**lag, hi**lag) ** (1.0 / lag), lo, hi))


def estimate_prior(fulls, period, detail=0.1):
    """A :class:`GaussianPrior` from full-colour (bilinear) image(s) (h, W, K) whose tile period is (n, m).

    ``detail``: variance of the achromatic detail component, relative to
    the largest principal variance (0 switches it off).
    """
    if isinstance(fulls, np.ndarray):
        fulls = [fulls]
    k = fulls[0].shape[2]
    n, m = (int(p) for p in period)
    flat = np.concatenate([f.reshape(-1, k) for f in fulls])
    mu = flat.mean(axis=0)
    cov = np.atleast_2d(np.cov(flat, rowvar=False)) if flat.shape[0] > 1 else np.zeros((k, k))
    lam, vec = np.linalg.eigh(cov)
    lam = np.clip(lam, 0.0, None)
    # spatial correlations of the largest (luminance-like) component: at one tile
    # period for the principal components (shared, see above), at one pixel for the detail
    sums = {key: np.zeros(3) for key in ("y", "x", "y1", "x1")}
    for f in fulls:
        z = (f - mu) @ vec[:, -1]
        sums["y"] += _lag_sums(z, n, 0)
        sums["x"] += _lag_sums(z, m, 1)
        sums["y1"] += _lag_sums(z, 1, 0)
        sums["x1"] += _lag_sums(z, 1, 1)
    norm = np.linalg.norm(mu)
    u = mu / norm if norm > 0 else np.full(k, 1.0 / np.sqrt(k))
    return GaussianPrior(
        mu, vec, lam, np.full(k, _rho(sums["y"], n)), np.full(k, _rho(sums["x"], m)),
        u, float(detail) * float(lam.max(initial=0.0)), _rho(sums["y1"], 1), _rho(sums["x1"], 1),
    )


def _observations(tile, py, px, half):
    """(dy, dx, tier, class) of every mosaic sample in the window around tile position (py, px)."""
    n, m, t = tile.shape
    d = np.arange(-half, half + 1)
    dy, dx, tier = (a.ravel() for a in np.meshgrid(d, d, np.arange(t), indexing="ij"))
    cls = tile[(py + dy) % n, (px + dx) % m, tier]
    return dy, dx, tier, cls


def posterior_filters(prior, tile, window, noise_var, ridge=1e-6, local_mean=True):
    """Per tile position (py, px): (filters (K, O), bias (K,), observations) of the posterior mean.

    ``x_hat = filters @ y + bias`` with ``y`` the O samples of the window.
    ``ridge`` (relative to the mean prior variance) keeps the solve well posed
    for noiseless images. ``local_mean``: the mean of each sensor class in
    the window is unknown (a flat prior on it) rather than the global
    ``prior.mean``: then ``m_hat = (H' C^-1 H)^-1 H' C^-1 y`` (H: which class
    each sample is) and ``x_hat = m_hat + C_xy C^-1 (y - H m_hat)``, which
    reproduces any uniform field exactly and follows local brightness.
    """
    tile = np.asarray(tile)
    n, m, _ = tile.shape
    k = prior.mean.size
    half = int(window) // 2
    scale = float(np.mean(prior.variances)) if np.any(prior.variances > 0) else 1.0
    reg = float(noise_var) + ridge * scale
    out = {}
    for py in range(n):
        for px in range(m):
            dy, dx, tier, cls = _observations(tile, py, px, half)
            c_yy = prior.covariance(cls[:, None], cls[None, :], dy[:, None] - dy[None, :], dx[:, None] - dx[None, :])
            c_yy[np.diag_indices_from(c_yy)] += reg
            c_xy = prior.covariance(np.arange(k)[:, None], cls[None, :], dy[None, :], dx[None, :])
            f = np.linalg.solve(c_yy, c_xy.T).T
            if local_mean:
                hmat = (cls[:, None] == np.arange(k)[None, :]).astype(float)
                if np.any(hmat.sum(axis=0) == 0):
                    raise ParameterError("window", f"a {window} x {window} window does not hold every sensor class of the tile")
                ci_h = np.linalg.solve(c_yy, hmat)
                g = np.linalg.solve(hmat.T @ ci_h, ci_h.T)  # (K, O): GLS local mean
                f = f + (np.eye(k) - f @ hmat) @ g
                bias = np.zeros(k)
            else:
                bias = prior.mean - f @ prior.mean[cls]
            out[(py, px)] = (f, bias, (dy, dx, tier))
    return out


def apply_filters(data, tile, filters, half, rows=32):
    """Apply per-position linear filters to mosaic planes (H, W, T) -> (H, W, K).

    The mosaic, padded by phase-keeping reflection, is split once into its
    n x m tile phases (contiguous float32 sub-images, one per phase and
    tier), so every sample the window of an output phase needs lies at a
    fixed offset in one of them. A compiled loop (:func:`_filter_rows`,
    numba; :func:`_filter_rows3` for three sensors) then accumulates, per output row of each tile position, the O
    weighted phase rows in single precision (relative error ~1e-7, far below
    any camera's noise) and adds the bias in the output's precision (the
    mosaic's dtype: float32 stays float32); blocks of ``rows`` phase rows go
    to the machine's cores. numpy needs the O shifted samples of every pixel
    stacked before one matrix product (49 copies a pixel on a Bayer tile);
    the loop reads each once from cache, ~3x faster at 12 megapixels.
    """
    h, w, t_count = data.shape
    n, m, _ = tile.shape
    iy = phase_pad_index(h, half, n)
    ix = phase_pad_index(w, half, m)
    hp_max, wp_max = -(-iy.size // n), -(-ix.size // m)
    planes = np.zeros((n * m * t_count, hp_max, wp_max), np.float32)
    for qy in range(n):
        for qx in range(m):
            ry, rx = iy[qy::n], ix[qx::m]
            for t in range(t_count):
                _take_grid(data[:, :, t], ry, rx, planes[(qy * m + qx) * t_count + t, : ry.size, : rx.size])
    items = sorted(filters.items())
    k = items[0][1][0].shape[0]
    o_count = max(f.shape[1] for _, (f, _, _) in items)
    out = np.empty((h, w, k), data.dtype if data.dtype in (np.float32, np.float64) else np.float64)
    count = len(items)
    weights = np.zeros((count, k, o_count), np.float32)
    bias = np.zeros((count, k), out.dtype)
    plane, ys, xs = (np.zeros((count, o_count), np.int64) for _ in range(3))
    pos = np.zeros((count, 4), np.int64)  # py, px, phase rows, phase columns
    for i, ((py, px), (f, b, (dy, dx, tier))) in enumerate(items):
        weights[i, :, : f.shape[1]] = f
        bias[i] = b
        a, c = half + py + np.asarray(dy), half + px + np.asarray(dx)
        plane[i, : f.shape[1]] = ((a % n) * m + c % m) * t_count + np.asarray(tier)
        ys[i, : f.shape[1]], xs[i, : f.shape[1]] = a // n, c // m
        pos[i] = py, px, len(range(py, h, n)), len(range(px, w, m))
    if k != 3:
        kernel = _filter_kernel()
    else:
        # three sensors (every shipped camera): the kernel that takes the taps seven at a time into three sums
        # (the same sums in the same order); the taps padded to whole groups read tap 0's row with weight 0
        groups = -(-o_count // GROUP)
        pad = groups * GROUP - o_count
        if pad:
            weights = np.concatenate([weights, np.zeros((count, k, pad), weights.dtype)], axis=2)
            plane, ys, xs = (np.concatenate([a, np.repeat(a[:, :1], pad, axis=1)], axis=1) for a in (plane, ys, xs))
        kernel = _filter_kernel3()
    edges = [min(int(pos[:, 2].max()), e * rows) for e in split(-(-int(pos[:, 2].max()) // rows), CORES)]
    # blocks of phase rows on the machine's cores (the kernel releases the GIL; each block writes its own rows)
    run_blocks(lambda a, b: kernel(planes, weights, bias, plane, ys, xs, pos, n, m, out, a, b), edges, values=out.size)
    return out


def _even_run(index):
    """(a, b, step): the longest run ``index[a:b]`` of equal steps (the part of a padded axis inside the image)."""
    if index.size < 2:
        return 0, index.size, 1
    d = np.diff(index)
    starts = np.concatenate([[0], np.flatnonzero(d[1:] != d[:-1]) + 1])  # where each run of equal steps starts
    ends = np.append(starts[1:], d.size)
    j = int(np.argmax(ends - starts))  # the first of the longest
    return int(starts[j]), int(ends[j]) + 1, int(d[starts[j]])


def _take_grid(src, rows, cols, dst):
    """``dst[...] = src[np.ix_(rows, cols)]``: the evenly spaced middle as a strided slice (one copy, no index
    arrays; a 12-megapixel raw's four phase planes 52-66 -> 17-19 ms), the padded borders by index."""
    ra, rb, rs = _even_run(rows)
    ca, cb, cs = _even_run(cols)
    if rs <= 0 or cs <= 0:
        dst[...] = src[np.ix_(rows, cols)]
        return
    dst[ra:rb, ca:cb] = src[rows[ra] : rows[rb - 1] + 1 : rs, cols[ca] : cols[cb - 1] + 1 : cs]
    dst[:ra] = src[np.ix_(rows[:ra], cols)]
    dst[rb:] = src[np.ix_(rows[rb:], cols)]
    dst[ra:rb, :ca] = src[np.ix_(rows[ra:rb], cols[:ca])]
    dst[ra:rb, cb:] = src[np.ix_(rows[ra:rb], cols[cb:])]


def _filter_rows(planes, weights, bias, plane, ys, xs, pos, n, m, out, r0, r1):
    """Phase rows r0..r1 of every tile position: ``out = weights @ samples + bias`` (see :func:`apply_filters`).

    Compiled by numba (:func:`_filter_kernel`). For output phase row ``r``
    of position ``p``, tap ``o`` reads row ``ys[p, o] + r`` of phase plane
    ``plane[p, o]`` from column ``xs[p, o]`` on: contiguous, so the
    innermost loop (over the row's pixels) vectorizes (~20x a scalar loop).
    """
    k = weights.shape[1]
    acc = np.empty((k, planes.shape[2]), np.float32)
    for r in range(r0, r1):
        for p in range(pos.shape[0]):
            hp, wp = pos[p, 2], pos[p, 3]
            if r >= hp or wp == 0:
                continue
            acc[:, :wp] = 0
            for o in range(weights.shape[2]):
                # a slice, then plain indices: numba vectorizes this loop (indexing ``row[x0 + j]`` it does not)
                src = planes[plane[p, o], ys[p, o] + r, xs[p, o] : xs[p, o] + wp]
                for c in range(k):
                    wt = weights[p, c, o]
                    if wt != 0:
                        a = acc[c]
                        for j in range(wp):
                            a[j] += wt * src[j]
            y = pos[p, 0] + r * n
            for j in range(wp):
                x = pos[p, 1] + j * m
                for c in range(k):
                    out[y, x, c] = acc[c, j] + bias[p, c]


_filter_kernel = compiled(_filter_rows)

#: Taps per group in the three-sensor kernel: a row of the Bayer tile's 7 x 7 window.
GROUP = 7


def _filter_rows3(planes, weights, bias, plane, ys, xs, pos, n, m, out, r0, r1):
    """:func:`_filter_rows` for three sensors, the taps (a multiple of :data:`GROUP`) seven at a time.

    A group's seven weighted samples are one expression per sensor, so each
    sum is loaded and stored once per group instead of once per tap (the
    generic kernel's inner loop is one tap for one sensor): 27 loads and
    stores per pixel and group against 63. Each sensor's loop reads eight
    arrays, few enough for the compiler's alias checks, so it vectorizes;
    one loop for the three sums (eleven arrays) did not. Each sum is
    accumulated in the generic kernel's order, so the values are its values;
    a weight of 0 adds a signed zero where the generic kernel skips the tap
    (it can only turn a sum of -0.0 into 0.0, or, on a raw holding inf or
    NaN, which no camera writes, make a sum NaN). Written out by hand, with
    numba: the group size must be fixed for the taps to be one expression.
    Filtering a 12-megapixel Bayer raw (with its phase planes): median
    175 -> 119 ms, interleaved.
    """
    acc = np.empty((3, planes.shape[2]), np.float32)
    a0, a1, a2 = acc[0], acc[1], acc[2]
    for r in range(r0, r1):
        for p in range(pos.shape[0]):
            hp, wp = pos[p, 2], pos[p, 3]
            if r >= hp or wp == 0:
                continue
            acc[:, :wp] = 0
            for g in range(0, weights.shape[2], 7):
                s0 = planes[plane[p, g], ys[p, g] + r, xs[p, g] : xs[p, g] + wp]
                s1 = planes[plane[p, g + 1], ys[p, g + 1] + r, xs[p, g + 1] : xs[p, g + 1] + wp]
                s2 = planes[plane[p, g + 2], ys[p, g + 2] + r, xs[p, g + 2] : xs[p, g + 2] + wp]
                s3 = planes[plane[p, g + 3], ys[p, g + 3] + r, xs[p, g + 3] : xs[p, g + 3] + wp]
                s4 = planes[plane[p, g + 4], ys[p, g + 4] + r, xs[p, g + 4] : xs[p, g + 4] + wp]
                s5 = planes[plane[p, g + 5], ys[p, g + 5] + r, xs[p, g + 5] : xs[p, g + 5] + wp]
                s6 = planes[plane[p, g + 6], ys[p, g + 6] + r, xs[p, g + 6] : xs[p, g + 6] + wp]
                u0, u1, u2, u3, u4, u5, u6 = weights[p, 0, g : g + 7]
                v0, v1, v2, v3, v4, v5, v6 = weights[p, 1, g : g + 7]
                w0, w1, w2, w3, w4, w5, w6 = weights[p, 2, g : g + 7]
                for j in range(wp):
                    a0[j] = a0[j] + u0 * s0[j] + u1 * s1[j] + u2 * s2[j] + u3 * s3[j] + u4 * s4[j] + u5 * s5[j] + u6 * s6[j]
                for j in range(wp):
                    a1[j] = a1[j] + v0 * s0[j] + v1 * s1[j] + v2 * s2[j] + v3 * s3[j] + v4 * s4[j] + v5 * s5[j] + v6 * s6[j]
                for j in range(wp):
                    a2[j] = a2[j] + w0 * s0[j] + w1 * s1[j] + w2 * s2[j] + w3 * s3[j] + w4 * s4[j] + w5 * s5[j] + w6 * s6[j]
            y = pos[p, 0] + r * n
            for j in range(wp):
                x = pos[p, 1] + j * m
                out[y, x, 0] = a0[j] + bias[p, 0]
                out[y, x, 1] = a1[j] + bias[p, 1]
                out[y, x, 2] = a2[j] + bias[p, 2]


_filter_kernel3 = compiled(_filter_rows3)


def demosaic_bayesian(image, window=None, noise_sigma=None, detail=None, local_mean=None, ridge=1e-6, *,
                      mode="extended", noise_fraction=None):
    """Brainard's Bayesian demosaicing (see the module docstring), camsim's extended mode or the original's.

    Parameters
    ----------
    window : int, optional
        Odd neighbourhood size; default ``2 * max(tile rows, tile columns) + 3``
        (7 for a Bayer tile) in the extended mode, 5 in the original mode.
    noise_sigma : float, optional
        Extended mode: noise standard deviation (digital units) in the
        likelihood; default ``image.noise_sigma``. Not used by the original mode.
    detail : float, optional
        Variance of the achromatic detail component relative to the largest
        principal variance (extended default 0.1; original: 0, the
        image-estimated prior alone).
    local_mean : bool, optional
        Treat each class's mean in the window as unknown (see
        :func:`posterior_filters`); extended default True, original False (one global mean).
    ridge : float
        Extra variance, relative to the mean prior variance, added for a well-posed solve.
    mode : {"extended", "original"}
    noise_fraction : float, optional
        Original mode: likelihood noise variance / mean prior variance
        (default :data:`ORIGINAL_NOISE_FRACTION`).
    """
    if mode not in MODES:
        raise ParameterError("mode", f"must be one of {', '.join(MODES)}, got {mode!r}")
    original = mode == "original"
    if detail is None:
        detail = 0.0 if original else 0.1
    if local_mean is None:
        local_mean = not original
    if original:
        if noise_sigma is not None:
            raise ParameterError("noise_sigma", "the original mode assumes a noise fraction (noise_fraction=), not a noise sigma")
        noise_fraction = ORIGINAL_NOISE_FRACTION if noise_fraction is None else noise_fraction
        if not (np.isfinite(noise_fraction) and noise_fraction >= 0):
            raise ParameterError("noise_fraction", f"must be a number >= 0, got {noise_fraction!r}")
    elif noise_fraction is not None:
        raise ParameterError("noise_fraction", "applies to mode='original' only")
    data, tile, k = check_mosaiced(image, "bayesian")
    n, m, _ = tile.shape
    default_window = 5 if original else 2 * max(n, m) + 3
    win = default_window if window is None else int(window)
    if win < 1 or win % 2 == 0:
        raise ParameterError("window", f"must be a positive odd number of pixels, got {window}")
    sigma = float(image.noise_sigma if noise_sigma is None else noise_sigma)
    if sigma < 0:
        raise ParameterError("noise_sigma", f"must be >= 0, got {sigma}")
    if detail < 0:
        raise ParameterError("detail", f"must be >= 0, got {detail}")
    prior = estimate_prior(prior_sample(data, tile, k), (n, m), detail)
    if original:
        noise_var = float(noise_fraction) * float(np.mean(prior.variances))
    else:
        noise_var = sigma**2 + (1.0 / 12.0 if image.quantized else 0.0)
    filters = posterior_filters(prior, tile, win, noise_var, ridge, local_mean)
    return apply_filters(data, tile, filters, win // 2)
