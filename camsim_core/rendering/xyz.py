"""Rendered monitor image -> CIE 1931 XYZ (chapter section 4.3): w -> B_M w -> XYZ.

Frame-buffer values are turned into linear phosphor intensities by the
monitor's gamma table, the emitted spectrum is ``B_M w`` (W/sr/m^2 per band,
the monitor calibration's units), and ``XYZ = 683 sum(cmf x spectrum)``
with the CIE 1931 2-degree colour-matching functions (colour-science), so
Y is luminance in cd/m^2 (the ``simtoolbox-test`` monitor's white, all
three phosphors at full setting, is about Y = 143 cd/m^2). The monitor's
ambient light is left out (the chapter compares emitted images).
"""

from __future__ import annotations

import math

import numpy as np

from .._chunks import map_pixels
from .._compiled import compiled
from ..monitor import _linear_table
from ..errors import ParameterError
from ._linear import apply_matrix

__all__ = ["to_xyz", "monitor_xyz_matrix", "white_xyz"]


def monitor_xyz_matrix(monitor):
    """(3, 3) matrix from linear phosphor intensities to XYZ (cd/m^2): 683 cmf^T B_M.

    Examples
    --------
    Each column is the XYZ (cd/m^2) of one phosphor at full setting:

    >>> from camsim_core.monitor import load_monitor
    >>> m = monitor_xyz_matrix(load_monitor("simtoolbox-test"))
    >>> m.shape, bool((m[1] > 0).all())
    ((3, 3), True)
    """
    from ..datasets.sensors import cie1931_xyz

    cmf = cie1931_xyz().on(monitor.wavelengths)
    return 683.0 * cmf @ monitor.primaries


def white_xyz(monitor):
    """XYZ (cd/m^2) of the monitor's white (every phosphor at full setting): a white point for CIELAB.

    Examples
    --------
    The ``simtoolbox-test`` monitor's white: Y about 143 cd/m^2.

    >>> import numpy as np
    >>> from camsim_core.monitor import load_monitor
    >>> np.round(white_xyz(load_monitor("simtoolbox-test"))).tolist()
    [136.0, 143.0, 203.0]
    """
    return monitor_xyz_matrix(monitor).sum(axis=1)


def to_xyz(rendered, monitor):
    """(H, W, 3) XYZ in cd/m^2 of a rendered image (``space="monitor"``, frame-buffer values) on ``monitor``.

    In the image's float dtype (a float32 rendering gives float32 XYZ).

    Examples
    --------
    A frame buffer at full setting shows the monitor's white:

    >>> import numpy as np
    >>> from camsim_core.image import CameraImage
    >>> from camsim_core.monitor import load_monitor
    >>> monitor = load_monitor("simtoolbox-test")
    >>> white = CameraImage(np.full((1, 2, 3), 255.0), np.array([]), space="monitor")
    >>> bool(np.allclose(to_xyz(white, monitor)[0, 1], white_xyz(monitor)))
    True
    """
    data, convert = xyz_converter(rendered, monitor)
    return map_pixels(convert, data, into=(3, data.dtype))  # by chunks: no full-size temporaries


def xyz_converter(rendered, monitor, name="rendered"):
    """The checked frame-buffer values (H, W, 3) of ``rendered`` and the function taking rows of them (n, 3) to XYZ.

    For callers that need XYZ a part at a time (the metrics, by chunks or
    bands of rows) without holding a full XYZ image; :func:`to_xyz` is
    ``map_pixels(convert, data)``, the chunks written into its result
    (``convert(values, out=...)``: ``out`` (n, 3) in the data's dtype).
    """
    if getattr(rendered, "space", None) != "monitor":
        raise ParameterError(name, f"needs a rendered monitor image (space 'monitor'), got {getattr(rendered, 'space', type(rendered).__name__)!r}")
    data = np.asarray(rendered.data)
    if data.dtype not in (np.float32, np.float64):
        data = data.astype(np.float64)
    if data.ndim != 3 or data.shape[2] != 3:
        raise ParameterError(name, f"expected (H, W, 3) monitor values, got {data.shape}")
    bits = rendered.bits or monitor.bits
    m = monitor_xyz_matrix(monitor)
    dtype = data.dtype
    if bits == monitor.bits:
        table = _linear_table(monitor, dtype)  # the table Monitor.frame_buffer_to_linear looks values up in
        m_dt = np.ascontiguousarray(m, dtype)
        kernel = _xyz_kernel()

    def convert(values, out=None):
        if out is None:
            out = np.empty(values.shape, dtype)
        if bits == monitor.bits:
            values = np.ascontiguousarray(values)
            if kernel(values, table, m_dt, out) < 0:  # every value a table index: done in one pass
                return out
            linear = monitor.frame_buffer_to_linear(values)
        else:
            linear = monitor.settings_to_linear(values / float(2**bits - 1)).astype(values.dtype, copy=False)
        out[...] = apply_matrix(linear[:, None, :], m)[:, 0, :]
        return out

    return data, convert


def _xyz_rows(values, table, m, out):
    """XYZ of frame-buffer rows (n, 3) (C-ordered): ``m @ [table[0, r], table[1, g], table[2, b]]``; -1, or 0
    (``out`` not written) when some value is not a whole number in the table's range (the caller then takes
    the general path).

    Compiled by numba (:func:`_xyz_kernel`): numpy takes ~8 passes over the
    pixels for the same (whole-number check, index arithmetic, lookups, a
    3 x 3 product); this is two, ~5x faster on a megapixel image. The check
    is a pass of its own, without a branch (it vectorizes): checking each
    value before its lookup took a third longer (9.3 against 7.0 ms for
    1012 x 1317 pixels, one core). In the arrays' dtype (float32 stays
    float32); the same table values as :meth:`Monitor.frame_buffer_to_linear`,
    products within rounding of it.
    """
    top = table.shape[1] - 1
    flat = values.reshape(-1)
    whole = True
    for k in range(flat.size):
        v = flat[k]
        whole &= (v >= 0) & (v <= top) & (math.floor(v) == v)  # NaN fails too
    if not whole:
        return 0
    for i in range(values.shape[0]):
        la, lb, lc = table[0, int(values[i, 0])], table[1, int(values[i, 1])], table[2, int(values[i, 2])]
        out[i, 0] = m[0, 0] * la + m[0, 1] * lb + m[0, 2] * lc
        out[i, 1] = m[1, 0] * la + m[1, 1] * lb + m[1, 2] * lc
        out[i, 2] = m[2, 0] * la + m[2, 1] * lb + m[2, 2] * lc
    return -1


_xyz_kernel = compiled(_xyz_rows)
