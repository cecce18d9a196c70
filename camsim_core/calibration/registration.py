"""Registration of hyperspectral planes to the 550 nm plane by their binary edge maps (chapter section 2).

Refocusing for each interference filter changes the magnification slightly
and the camera moves between exposures, so each plane differs from the
reference plane by a similarity transform (translation, rotation, scale).
Wavelength changes the size and even the sign of the contrast across an edge
(chapter Figure 1.1), which defeats intensity-based alignment; the chapter's
fix is to align *binary edge maps* instead. Here:

1. each plane's binary edge map is found with Canny's detector
   (:func:`skimage.feature.canny`), with hysteresis thresholds set relative
   to the plane's own strongest gradients so that they do not depend on the
   plane's exposure;
2. every edge pixel is localized to a fraction of a pixel along its gradient
   by a parabola through the gradient magnitude (Devernay 1995, "A non-maxima
   suppression method for edge detection with sub-pixel accuracy", INRIA
   RR-2724). The edge map stays binary: only where an edge lies counts, not
   its contrast or sign;
3. the search starts from no motion and, for larger camera movements, from
   the translation given by phase correlation of the smoothed binary edge
   maps (:func:`skimage.registration.phase_cross_correlation`); the latter
   is kept only if it matches clearly more edges, since a repetitive scene
   (the colour checker) can make phase correlation lock on a whole period;
4. the similarity is refined by point-to-line iterative closest points
   (Chen & Medioni 1992) between the two edge-point sets, with trimmed
   outliers; each iteration is a linear least-squares problem (hand-written:
   no library offers point-to-line ICP for a 2-D similarity).

Coordinates are (row, column) in pixels. A :class:`Similarity` maps a point
``p`` of the reference frame to where it lies in the plane,
``q = s R(angle) (p - c) + c + t`` with ``c`` the image centre, so a
registered plane is the plane sampled at ``T(p)`` (:func:`warp_plane`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import ParameterError

__all__ = [
    "Similarity",
    "EdgePoints",
    "RegistrationResult",
    "edge_points",
    "register_plane",
    "register_planes",
    "warp_plane",
    "coverage",
]


@dataclass(frozen=True)
class Similarity:
    """A 2-D similarity about ``center``: ``q = scale * R(angle) (p - center) + center + (dy, dx)``.

    ``angle`` in radians (positive turns the row axis towards the column
    axis), ``dy``/``dx`` in pixels, ``center`` (row, col).
    """

    dy: float = 0.0
    dx: float = 0.0
    angle: float = 0.0
    scale: float = 1.0
    center: tuple = (0.0, 0.0)

    @property
    def linear(self):
        """The 2 x 2 matrix ``scale * R(angle)`` acting on (row, col) column vectors."""
        c, s = np.cos(self.angle), np.sin(self.angle)
        return self.scale * np.array([[c, -s], [s, c]])

    def apply(self, points):
        """Map (..., 2) (row, col) points of the reference frame into the plane."""
        p = np.asarray(points, float)
        c = np.asarray(self.center, float)
        return (p - c) @ self.linear.T + c + np.array([self.dy, self.dx])

    def inverse(self):
        """The similarity mapping plane points back to the reference frame (same centre)."""
        inv = np.linalg.inv(self.linear)
        t = -inv @ np.array([self.dy, self.dx])
        return Similarity(float(t[0]), float(t[1]), -self.angle, 1.0 / self.scale, tuple(self.center))

    def as_dict(self):
        return {
            "dy_px": self.dy,
            "dx_px": self.dx,
            "angle_deg": float(np.degrees(self.angle)),
            "scale": self.scale,
            "center_rc": [float(v) for v in self.center],
        }


def displacement_error(a, b, shape):
    """Largest distance (px) between where ``a`` and ``b`` send the pixels of an image of ``shape``.

    For similarities the difference is affine, so its maximum over the image
    lies at a corner.
    """
    h, w = shape[:2]
    corners = np.array([[0, 0], [0, w - 1], [h - 1, 0], [h - 1, w - 1]], float)
    return float(np.max(np.linalg.norm(a.apply(corners) - b.apply(corners), axis=1)))


@dataclass(frozen=True)
class EdgePoints:
    """Sub-pixel edge points of one plane: ``points`` (M, 2) (row, col), unit ``normals`` (M, 2),
    and the binary ``edge_map`` they come from."""

    points: np.ndarray
    normals: np.ndarray
    edge_map: np.ndarray


@dataclass(frozen=True)
class RegistrationResult:
    """A plane's estimated transform and how well its edges fit the reference's.

    ``residual``: rms point-to-line distance (px) of the matched edge points;
    ``matched``: fraction of the plane's edge points matched (within 1 px).
    """

    transform: Similarity
    residual: float
    matched: float
    n_points: int


def _gradients(image, sigma):
    smooth = ndimage.gaussian_filter(np.asarray(image, float), sigma, mode="nearest")
    gy = ndimage.sobel(smooth, axis=0, mode="nearest")
    gx = ndimage.sobel(smooth, axis=1, mode="nearest")
    return gy, gx, np.hypot(gy, gx)


def edge_points(image, *, sigma=1.0, low=0.08, high=0.2, margin=4):
    """Binary Canny edges of ``image`` and their sub-pixel positions along the gradient.

    Parameters
    ----------
    image : ndarray (H, W)
    sigma : float
        Gaussian smoothing (px) before the gradient, as in Canny's detector.
    low, high : float
        Hysteresis thresholds as fractions of the 99.9th percentile of the
        gradient magnitude (so they are independent of exposure and gain).
    margin : int
        Edge points closer than this to the image border are dropped (a
        plane's border holds no reliable structure after the camera moved).
    """
    from skimage.feature import canny

    img = np.asarray(image, float)
    gy, gx, mag = _gradients(img, sigma)
    top = float(np.percentile(mag, 99.9))
    if not np.isfinite(top) or top <= 0:
        empty = np.zeros((0, 2))
        return EdgePoints(empty, empty, np.zeros(img.shape, bool))
    # skimage's canny smooths with the same sigma and takes Sobel gradients: same magnitude scale
    edges = canny(img, sigma=sigma, low_threshold=low * top, high_threshold=high * top, mode="nearest")
    h, w = img.shape
    rows, cols = np.nonzero(edges)
    keep = (rows >= margin) & (rows < h - margin) & (cols >= margin) & (cols < w - margin)
    rows, cols = rows[keep], cols[keep]
    g = np.stack([gy[rows, cols], gx[rows, cols]], axis=1)
    n = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)
    p0 = np.stack([rows, cols], axis=1).astype(float)
    m0 = mag[rows, cols]
    mm = ndimage.map_coordinates(mag, (p0 - n).T, order=1, mode="nearest")
    mp = ndimage.map_coordinates(mag, (p0 + n).T, order=1, mode="nearest")
    denom = mm - 2.0 * m0 + mp
    ok = denom < 0  # a true maximum along the gradient
    delta = np.where(ok, 0.5 * (mm - mp) / np.where(ok, denom, -1.0), 0.0)
    ok &= np.abs(delta) <= 0.5
    pts = p0[ok] + delta[ok, None] * n[ok]
    return EdgePoints(pts, n[ok], edges)


def _phase_translation(ref_map, mov_map, sigma=2.0):
    """Translation (dy, dx) taking reference points to plane points, from the smoothed edge maps."""
    from skimage.registration import phase_cross_correlation

    a = ndimage.gaussian_filter(ref_map.astype(float), sigma)
    b = ndimage.gaussian_filter(mov_map.astype(float), sigma)
    shift, _, _ = phase_cross_correlation(a, b, upsample_factor=4, normalization=None)
    # shift registers the plane onto the reference: ref(p) ~ plane(p - shift), so q = p - shift
    return -float(shift[0]), -float(shift[1])


def _icp(ref, mov, center, start, *, thresholds=(4.0, 2.0, 1.0), iterations=30, min_points=20):
    """Point-to-line ICP for the similarity ``U`` mapping plane points onto reference edges.

    Minimizes sum_i (n_i . (U(q_i) - p_i))^2 over matched pairs, with
    ``U(q) = [[a, -b], [b, a]] (q - c) + c + (u, v)`` (linear in a, b, u, v).
    Returns (U as Similarity, rms residual, matched fraction).
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(ref.points)
    c = np.asarray(center, float)
    inv = start.inverse()
    lin = inv.linear
    a, b = lin[0, 0], lin[1, 0]
    u, v = inv.dy, inv.dx
    q = mov.points - c
    qn = mov.normals
    resid, matched = np.inf, 0.0
    for thr in thresholds:
        for _ in range(iterations):
            m = np.array([[a, -b], [b, a]])
            x = q @ m.T + c + np.array([u, v])
            dist, idx = tree.query(x, distance_upper_bound=thr)
            sel = np.isfinite(dist)
            if sel.sum() < min_points:
                break
            p = ref.points[idx[sel]]
            n = ref.normals[idx[sel]]
            # normals must agree in direction up to sign (edges of either contrast polarity)
            nq = qn[sel] @ m.T
            nq /= np.maximum(np.linalg.norm(nq, axis=1, keepdims=True), 1e-300)
            agree = np.abs(np.sum(nq * n, axis=1)) > 0.8
            if agree.sum() < min_points:
                break
            qs, p, n = q[sel][agree], p[agree], n[agree]
            # residual n . (M qs + c + t - p), linear in (a, b, u, v)
            ny, nx = n[:, 0], n[:, 1]
            qy, qx = qs[:, 0], qs[:, 1]
            A = np.stack([ny * qy + nx * qx, -ny * qx + nx * qy, ny, nx], axis=1)
            rhs = np.sum(n * (p - c), axis=1)
            sol, *_ = np.linalg.lstsq(A, rhs, rcond=None)
            change = np.abs(sol - [a, b, u, v]).max()
            a, b, u, v = sol
            resid = float(np.sqrt(np.mean((A @ sol - rhs) ** 2)))
            matched = float(agree.sum()) / len(q)
            if change < 1e-7:
                break
    scale = float(np.hypot(a, b))
    return Similarity(float(u), float(v), float(np.arctan2(b, a)), scale, tuple(c)), resid, matched


def register_plane(reference, plane, *, sigma=1.0, reference_edges=None, prefer_small=0.1):
    """Estimate the similarity taking the reference frame to ``plane`` from their edge maps.

    ICP starts from no motion and from the phase-correlation translation of
    the smoothed edge maps; the latter wins only when it matches a fraction
    ``prefer_small`` more of the plane's edge points.

    Returns a :class:`RegistrationResult`. Raises :class:`ParameterError`
    when either image has too few edges to register.
    """
    ref = reference_edges if reference_edges is not None else edge_points(reference, sigma=sigma)
    mov = edge_points(plane, sigma=sigma)
    if len(ref.points) < 20 or len(mov.points) < 20:
        raise ParameterError("registration", f"too few edges to register ({len(ref.points)} in the reference, {len(mov.points)} in the plane); the scene needs visible edges")
    h, w = np.shape(plane)
    center = ((h - 1) / 2.0, (w - 1) / 2.0)
    # two starts: no motion (camera motion is small), and the phase-correlation translation,
    # which can lock on a period of a repetitive scene such as the colour checker: it is
    # taken only when it matches clearly more edges (``prefer_small``, a fraction of edges)
    u, resid, matched = _icp(ref, mov, center, Similarity(0.0, 0.0, 0.0, 1.0, center))
    dy, dx = _phase_translation(ref.edge_map, mov.edge_map)
    if np.hypot(dy, dx) > 1.0:
        u2, resid2, matched2 = _icp(ref, mov, center, Similarity(dy, dx, 0.0, 1.0, center))
        if matched2 > matched + prefer_small:
            u, resid, matched = u2, resid2, matched2
    return RegistrationResult(u.inverse(), resid, matched, len(mov.points))


def register_planes(planes, wavelengths, reference_wavelength=550.0, *, sigma=1.0):
    """Register every plane of ``planes`` (N, H, W) to the plane at ``reference_wavelength``.

    Returns a list of :class:`RegistrationResult` (the reference's own is the identity, residual 0).
    """
    wls = np.asarray(wavelengths, float)
    k = int(np.argmin(np.abs(wls - reference_wavelength)))
    if abs(wls[k] - reference_wavelength) > 1e-6:
        raise ParameterError("reference_wavelength", f"no plane at {reference_wavelength:g} nm to register to (planes: {wls[0]:g}-{wls[-1]:g} nm)")
    ref_edges = edge_points(planes[k], sigma=sigma)
    h, w = planes[k].shape
    center = ((h - 1) / 2.0, (w - 1) / 2.0)
    out = []
    for i, plane in enumerate(planes):
        if i == k:
            out.append(RegistrationResult(Similarity(center=center), 0.0, 1.0, len(ref_edges.points)))
            continue
        try:
            out.append(register_plane(None, plane, sigma=sigma, reference_edges=ref_edges))
        except ParameterError as exc:
            raise ParameterError(f"registration of the {wls[i]:g} nm plane", str(exc).split(": ", 1)[-1]) from None
    return out


def warp_plane(plane, transform, *, order=3):
    """The plane resampled onto the reference frame: ``out(p) = plane(T(p))``.

    Cubic-spline interpolation (:func:`scipy.ndimage.map_coordinates`);
    outside the plane the nearest border value is repeated (see :func:`coverage`).
    """
    h, w = plane.shape
    rr, cc = np.mgrid[0:h, 0:w].astype(float)
    q = transform.apply(np.stack([rr, cc], axis=-1))
    return ndimage.map_coordinates(np.asarray(plane, float), [q[..., 0], q[..., 1]], order=order, mode="nearest")


def coverage(shape, transform, margin=0.0):
    """Boolean (H, W): reference pixels whose source ``T(p)`` lies inside the plane, ``margin`` px from its border."""
    h, w = shape[:2]
    rr, cc = np.mgrid[0:h, 0:w].astype(float)
    q = transform.apply(np.stack([rr, cc], axis=-1))
    return (q[..., 0] >= margin) & (q[..., 0] <= h - 1 - margin) & (q[..., 1] >= margin) & (q[..., 1] <= w - 1 - margin)
