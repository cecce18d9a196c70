"""CIELAB colour differences from XYZ images (chapter section 4.3).

The chapter judges uniform regions with the CIELAB colour difference (its
reference 44, CIE 15) and whole images with S-CIELAB (:mod:`.s_cielab`), both
from CIE 1931 XYZ tristimulus values of the image as the monitor displays it.
Everything colorimetric here is colour-science's (``colour.XYZ_to_Lab``,
``colour.delta_E``); this module only checks the input and passes the white
point on in absolute units.

References
----------
CIE 15:2004, Colorimetry, 3rd ed. (CIE 1976 L*a*b*, Delta E*ab).
Sharma, G., Wu, W. & Dalal, E. N. (2005), "The CIEDE2000 color-difference
formula: implementation notes, supplementary test data, and mathematical
observations", Color Res. Appl. 30(1), 21-30.
"""

from __future__ import annotations

import numpy as np

from .._chunks import map_pixels
from .._compiled import compiled
from .._parallel import CORES, run_blocks, split
from ..errors import ParameterError

__all__ = ["METHODS", "xyz_to_lab", "delta_e", "delta_e_lab", "check_white", "check_xyz"]

#: Colour-difference formulas offered (colour-science names).
METHODS = ("CIE 1976", "CIE 2000")

_ALIASES = {
    "cie 1976": "CIE 1976",
    "cie1976": "CIE 1976",
    "1976": "CIE 1976",
    "de76": "CIE 1976",
    "cie 2000": "CIE 2000",
    "cie2000": "CIE 2000",
    "2000": "CIE 2000",
    "ciede2000": "CIE 2000",
    "de2000": "CIE 2000",
}


def _method(method):
    key = str(method).strip().lower()
    if key not in _ALIASES:
        raise ParameterError("method", f"must be one of {METHODS}, got {method!r}")
    return _ALIASES[key]


def check_white(white, name="white"):
    """The white point as a float array (3,) of positive, finite XYZ; else :class:`ParameterError`."""
    try:
        w = np.asarray(white, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(name, f"must be three numbers X, Y, Z, got {white!r}") from None
    if w.shape != (3,):
        raise ParameterError(name, f"must be the XYZ of the white, shape (3,), got shape {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ParameterError(name, f"X, Y and Z of the white must all be positive and finite, got {w.tolist()}")
    return w


def check_xyz(xyz, name="xyz"):
    """An XYZ image as a float array (..., 3) of finite values; else :class:`ParameterError`.

    float32 stays float32; other types become float64.
    """
    try:
        a = np.asarray(xyz)
        if a.dtype not in (np.float32, np.float64):
            a = np.asarray(xyz, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(name, "must be a numeric array of XYZ values (..., 3)") from None
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ParameterError(name, f"must hold X, Y, Z along its last axis (shape (..., 3)), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(name, "contains NaN or infinite values")
    return a


def check_pair(xyz1, xyz2, *, check_first=True, check_second=True):
    """Two XYZ images of the same shape (float arrays); else :class:`ParameterError`.

    ``check_first=False`` / ``check_second=False``: that image's values are checked by whoever uses them
    (a cache that checks an image once, where it makes its L*a*b*), here only its shape.
    """
    a = check_xyz(xyz1, "xyz1") if check_first else np.asarray(xyz1)
    b = check_xyz(xyz2, "xyz2") if check_second else np.asarray(xyz2)
    if a.shape != b.shape:
        raise ParameterError("xyz2", f"the two images must have the same shape, got {a.shape} and {b.shape}")
    return a, b


def rendered_pair(xyz1, xyz2, monitor):
    """The two inputs of a metric and their row converters to XYZ: ``(a, b, to_xyz_a, to_xyz_b)``.

    Without ``monitor``, two XYZ images (:func:`check_pair`) and ``None``
    converters. With it, two rendered images (``space="monitor"``) on that
    monitor: their frame-buffer values and the functions taking rows of
    them to XYZ (:func:`camsim_core.rendering.xyz.xyz_converter`), so a
    metric can convert by chunks and never hold a full XYZ image.
    """
    if monitor is None:
        for name, x in (("xyz1", xyz1), ("xyz2", xyz2)):
            if hasattr(x, "space"):
                raise ParameterError(name, "is a rendered image, not XYZ values: give monitor= (the monitor it was rendered for)")
        return check_pair(xyz1, xyz2) + (None, None)
    from ..monitor import Monitor, load_monitor
    from ..rendering.xyz import xyz_converter

    mon = monitor if isinstance(monitor, Monitor) else load_monitor(monitor)
    (a, to_a), (b, to_b) = (xyz_converter(x, mon, name) for name, x in (("xyz1", xyz1), ("xyz2", xyz2)))
    for name, v in (("xyz1", a), ("xyz2", b)):
        if not np.all(np.isfinite(v)):
            raise ParameterError(name, "the rendered image contains NaN or infinite values")
    if a.shape != b.shape:
        raise ParameterError("xyz2", f"the two images must have the same shape, got {a.shape} and {b.shape}")
    return a, b, to_a, to_b


def xyz_to_lab(xyz, white, *, checked=False):
    """CIE 1976 L*a*b* of ``xyz`` relative to the white ``white`` (same units as ``xyz``).

    Parameters
    ----------
    xyz : array_like (..., 3)
        Tristimulus values, any unit (cd/m^2, or relative).
    white : array_like (3,)
        XYZ of the reference white in the same unit (Y_n is not assumed 1 or 100).
    checked : bool, optional
        ``True`` when the caller checks ``xyz`` itself, once, with
        :func:`check_xyz` (a float array (..., 3) of finite values): the
        pass over the image that checks it is then skipped (the incremental
        pipeline converts an image by chunks). The white is always checked.

    Returns
    -------
    ndarray (..., 3)
        L* (0-100 for the white), a*, b*: the formula of
        ``colour.XYZ_to_Lab`` (CIE 15:2004) with the white's own X_n, Y_n,
        Z_n, written out in numpy. float32 input stays float32.

    Raises
    ------
    ParameterError
        For a white that is not three positive finite numbers, or (unless
        ``checked``) an ``xyz`` that is not finite values along a last axis of 3.

    References
    ----------
    CIE 15:2004, Colorimetry, section 8.2.1.

    Examples
    --------
    >>> import numpy as np
    >>> white = np.array([95.047, 100.0, 108.883])
    >>> xyz_to_lab(white, white).round(6).tolist()
    [100.0, 0.0, 0.0]
    >>> float(xyz_to_lab(white * 0.18, white)[0].round(2))  # an 18 % grey: L* = 116 0.18^(1/3) - 16
    49.5
    """
    w = check_white(white)
    return _xyz_to_lab(np.asarray(xyz) if checked else check_xyz(xyz), w)


def _xyz_to_lab(xyz, white):
    """CIE 1976 L*a*b*, written out (colour.XYZ_to_Lab's formula, CIE 15:2004).

    colour-science's general routine (domain scaling, xyY round trip of the
    white, float64 copies of every intermediate) costs ~5x this on a full
    frame; ``tests/engine/test_metrics.py`` checks the two agree. Works in the
    input's float dtype (float32 stays float32). The cube roots are numpy's
    (vectorized); the per-pixel arithmetic around them is two compiled
    passes (:func:`_ratio_rows`, :func:`_lab_rows`): numpy's elementwise
    operations on (n, 3) arrays run an inner loop of three values per pixel
    and took 6x as long.
    """
    xyz = np.asarray(xyz)
    dtype = xyz.dtype if xyz.dtype in (np.float32, np.float64) else np.dtype(np.float64)
    rows = np.ascontiguousarray(xyz, dtype).reshape(-1, 3)
    f = np.empty_like(rows)
    _ratio_kernel()(rows, np.asarray(white, float).astype(dtype), f)
    roots = np.empty_like(rows)
    return _lab_of_ratios(f, roots, roots).reshape(xyz.shape)


def _lab_of_ratios(f, roots, out):
    """L*a*b* (n, 3) into ``out`` of pixels' ratios to the white ``f`` (n, 3): their cube roots (numpy's,
    vectorized) into ``roots``, then :func:`_lab_rows`; ``out`` may be ``roots``. Returns ``out``."""
    np.cbrt(f, out=roots)
    _lab_kernel()(f, roots, np.array([(24 / 116) ** 3], f.dtype), out)
    return out


def _ratio_rows(xyz, white, out):
    """``out[i, c] = xyz[i, c] / white[c]`` in the arrays' dtype. Compiled by numba (:func:`_ratio_kernel`)."""
    for i in range(xyz.shape[0]):
        for c in range(3):
            out[i, c] = xyz[i, c] / white[c]


def _lab_rows(f, roots, threshold, out):
    """L*, a*, b* of pixels from their ratios to the white ``f`` (n, 3) and the ratios' cube roots.

    Per channel the CIE function ``t^(1/3)``, or ``t 841/108 + 16/116`` at
    ``t <= (24/116)^3``; then ``(116 fy - 16, 500 (fx - fy), 200 (fy - fz))``,
    in float64, stored in ``out``'s dtype (``out`` may be ``roots``).
    Compiled by numba (:func:`_lab_kernel`).
    """
    t = threshold[0]
    for i in range(f.shape[0]):
        v0 = f[i, 0] * (841 / 108) + 16 / 116 if f[i, 0] <= t else float(roots[i, 0])
        v1 = f[i, 1] * (841 / 108) + 16 / 116 if f[i, 1] <= t else float(roots[i, 1])
        v2 = f[i, 2] * (841 / 108) + 16 / 116 if f[i, 2] <= t else float(roots[i, 2])
        out[i, 0] = 116.0 * v1 - 16.0
        out[i, 1] = 500.0 * (v0 - v1)
        out[i, 2] = 200.0 * (v1 - v2)


def _distance_rows(a, b, out):
    """``out[i] = |a[i] - b[i]|`` (Euclidean, three channels) in float64, stored in ``out``'s dtype.
    Compiled by numba (:func:`_distance_kernel`)."""
    for i in range(a.shape[0]):
        d0 = float(a[i, 0]) - float(b[i, 0])
        d1 = float(a[i, 1]) - float(b[i, 1])
        d2 = float(a[i, 2]) - float(b[i, 2])
        out[i] = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


_ratio_kernel, _lab_kernel, _distance_kernel = compiled(_ratio_rows), compiled(_lab_rows), compiled(_distance_rows)


def delta_e_lab(lab1, lab2, method="CIE 1976"):
    """Colour difference between two L*a*b* arrays (..., 3): ``colour.delta_E``.

    CIE 1976 (the Euclidean distance) is computed here in the inputs' float
    dtype, one compiled pass (:func:`_distance_rows`); CIEDE2000 by colour-science.
    """
    method = _method(method)
    if method == "CIE 1976":
        a, b = np.asarray(lab1), np.asarray(lab2)
        dtype = np.result_type(a, b, np.float32)
        shape = np.broadcast_shapes(a.shape, b.shape)
        if shape[-1:] != (3,):  # not three channels: the plain formula
            d = np.subtract(a, b, dtype=dtype)
            return np.sqrt(np.sum(d * d, axis=-1))
        rows = [np.ascontiguousarray(np.broadcast_to(x, shape), x.dtype if x.dtype.kind == "f" else dtype).reshape(-1, 3)
                for x in (a, b)]
        n = rows[0].shape[0]
        out = np.empty(n, dtype)
        kernel = _distance_kernel()
        # blocks of rows on the machine's cores: the step that ends an S-CIELAB move, when nothing else runs
        # (the work counted in values read: six per distance written)
        run_blocks(lambda i, j: kernel(rows[0][i:j], rows[1][i:j], out[i:j]), split(n, CORES), values=6 * n)
        return out.reshape(shape[:-1])
    import colour  # here, not at import: colour-science takes 1.1-1.6 s to import (it loads matplotlib)

    return colour.delta_E(np.asarray(lab1, float), np.asarray(lab2, float), method=method)


def delta_e(xyz1, xyz2, white, method="CIE 1976", *, monitor=None):
    """CIELAB colour difference map between two XYZ images (chapter section 4.3).

    Parameters
    ----------
    xyz1, xyz2 : array_like (H, W, 3) (or any (..., 3), the same for both)
        CIE 1931 XYZ of the two images as displayed, in the unit of ``white``.
        With ``monitor``: the two rendered images (CameraImage, space
        "monitor") themselves, taken to XYZ on that monitor by chunks (the
        numbers of :func:`camsim_core.to_xyz`, without its full-size images).
    white : array_like (3,)
        XYZ of the reference white (e.g. the monitor's white); all positive.
    method : {"CIE 1976", "CIE 2000"}
        Delta E*ab (CIE 1976, the chapter's) or CIEDE2000.
    monitor : Monitor or name, optional
        The monitor the rendered images ``xyz1``, ``xyz2`` are shown on.

    Returns
    -------
    ndarray (H, W)
        The colour difference at each pixel.

    Raises
    ------
    ParameterError
        Different shapes, a white with a zero or negative entry, an unknown method.
    """
    method = _method(method)
    w = check_white(white)
    a, b, to_a, to_b = rendered_pair(xyz1, xyz2, monitor)
    return _delta_e_map(a, b, w, method, to_a, to_b)


def _delta_e_map(a, b, white, method, to_a=None, to_b=None):
    """dE map of two checked XYZ images under a checked white, by chunks of pixels: two Lab images and
    their difference never exist at full size. ``to_a``, ``to_b``: row converters to XYZ, when ``a``, ``b``
    are rendered monitor values (:func:`rendered_pair`)."""

    def de(x, y):
        x = x if to_a is None else to_a(x)
        y = y if to_b is None else to_b(y)
        return delta_e_lab(_xyz_to_lab(x, white), _xyz_to_lab(y, white), method)[:, None]

    return map_pixels(de, a, b)[..., 0]
