"""Monitors: phosphor spectra and gamma tables (chapter section 4.2, Eqs. 1.3-1.4).

References
----------
* ``simtoolbox-test``: SimToolbox ``monitors/SimToolboxTest.Smon`` (a
  Psychtoolbox calibration, 380:4:780 nm, 1024-entry gamma tables).
* ``brainard-crt``: colour-science's 'Typical CRT Brainard 1997' primaries,
  with a 2.2 power-law gamma table (the dataset has none of its own).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ._chunks import map_pixels
from ._compiled import compiled
from .datasets import SIMTOOLBOX
from .errors import FileFormatError, ParameterError
from .spectra import resample_power, sampling_wavelengths

__all__ = ["Monitor", "load_monitor", "MONITOR_NAMES"]

MONITOR_NAMES = ("simtoolbox-test", "brainard-crt")


@dataclass(frozen=True, eq=False)
class Monitor:
    """A calibrated display.

    Attributes
    ----------
    wavelengths : ndarray (N,)
        nm, sampling of the spectra.
    primaries : ndarray (N, 3)
        Spectral power of each phosphor at full linear setting, per band of
        ``wavelengths`` (the columns of B_M in Eq. 1.3).
    gamma_input : ndarray (M,)
        Settings in [0, 1] at which the gamma table was measured.
    gamma_table : ndarray (M, 3)
        Linear output (0-1) of each phosphor at those settings.
    ambient : ndarray (N,) or None
        Light the screen reflects, per band of ``wavelengths``, >= 0.
    background : (r, g, b)
        Settings in [0, 1].
    bits : int
        Depth of the frame buffer, 1 to 16 (8: values 0-255).

    Examples
    --------
    >>> import numpy as np
    >>> g = np.linspace(0, 1, 11)
    >>> m = Monitor(np.array([450.0, 550.0, 650.0]), np.eye(3), g, np.stack([g ** 2] * 3, axis=1), name="square-law")
    >>> m.levels, m.describe()["wavelengths_nm"]
    (256, '450-650')
    """

    wavelengths: np.ndarray
    primaries: np.ndarray
    gamma_input: np.ndarray
    gamma_table: np.ndarray
    ambient: np.ndarray | None = None
    background: tuple = (0.5, 0.5, 0.5)
    bits: int = 8
    name: str = ""

    def __post_init__(self):
        def array(name, ndim):
            try:
                a = np.array(getattr(self, name), float, ndmin=ndim)
            except (TypeError, ValueError):
                raise ParameterError(name, f"must be numbers, got {type(getattr(self, name)).__name__}") from None
            if not np.all(np.isfinite(a)):
                raise ParameterError(name, "must be finite (no NaN or infinity)")
            return a

        w = array("wavelengths", 1).ravel()
        if w.size < 1 or np.any(w <= 0) or np.any(np.diff(w) <= 0):
            raise ParameterError("wavelengths", "must be positive nm, strictly increasing")
        p = array("primaries", 2)
        if p.shape != (w.size, 3):
            raise ParameterError(self.name or "monitor", f"primaries must be ({w.size}, 3), got {p.shape}")
        if np.any(p < 0):
            raise ParameterError("primaries", "spectral power must be >= 0")
        gi = array("gamma_input", 1).ravel()
        gt = array("gamma_table", 2)
        if gt.shape != (gi.size, 3):
            raise ParameterError(self.name or "monitor", f"gamma table must be ({gi.size}, 3), got {gt.shape}")
        # a table inverted by interpolation must be non-decreasing
        gt = np.maximum.accumulate(gt, axis=0)
        arrays = [w, p, gi, gt]
        if self.ambient is not None:
            amb = array("ambient", 1).ravel()
            if amb.shape != w.shape or np.any(amb < 0):
                raise ParameterError("ambient", f"must be {w.size} values >= 0 (one per wavelength), or None")
            arrays.append(amb)
            object.__setattr__(self, "ambient", amb)
        bg = array("background", 1).ravel()
        if bg.size != 3 or np.any(bg < 0) or np.any(bg > 1):
            raise ParameterError("background", f"must be three settings in [0, 1], got {self.background!r}")
        object.__setattr__(self, "background", tuple(float(v) for v in bg))
        if isinstance(self.bits, bool) or not isinstance(self.bits, (int, np.integer)) or not 1 <= self.bits <= 16:
            raise ParameterError("bits", f"a frame buffer has 1 to 16 bits, got {self.bits!r}")
        for a in arrays:
            a.flags.writeable = False
        object.__setattr__(self, "wavelengths", w)
        object.__setattr__(self, "primaries", p)
        object.__setattr__(self, "gamma_input", gi)
        object.__setattr__(self, "gamma_table", gt)

    @property
    def levels(self):
        return 2 ** self.bits

    def primaries_on(self, wavelengths):
        """B_M on another sampling, kept in per-band units (scaled by the ratio of band widths)."""
        return resample_power(self.wavelengths, self.primaries.T, wavelengths).T

    def linear_to_settings(self, linear):
        """Gamma correction by table lookup: linear intensities (..., 3) in [0, 1] -> settings in [0, 1].

        Examples
        --------
        A monitor whose output is the square of its setting (a gamma table of settings^2):

        >>> import numpy as np
        >>> g = np.linspace(0, 1, 11)
        >>> m = Monitor(np.array([450.0, 550.0, 650.0]), np.eye(3), g, np.stack([g ** 2] * 3, axis=1), name="square-law")
        >>> m.linear_to_settings([0.25, 0.25, 1.0]).tolist()
        [0.5, 0.5, 1.0]
        """
        lin = np.clip(np.asarray(linear, float), 0.0, 1.0)
        out = np.empty_like(lin)
        for c in range(3):
            table = self.gamma_table[:, c] / self.gamma_table[-1, c]
            # strictly increasing x for interp: drop flat steps
            keep = np.concatenate([[True], np.diff(table) > 0])
            out[..., c] = np.interp(lin[..., c], table[keep], self.gamma_input[keep])
        return out

    def settings_to_linear(self, settings):
        """The gamma table forward: settings (..., 3) in [0, 1] -> linear intensities in [0, 1].

        Examples
        --------
        >>> import numpy as np
        >>> g = np.linspace(0, 1, 11)
        >>> m = Monitor(np.array([450.0, 550.0, 650.0]), np.eye(3), g, np.stack([g ** 2] * 3, axis=1), name="square-law")
        >>> m.settings_to_linear([0.5, 0.5, 0.0]).tolist()
        [0.25, 0.25, 0.0]
        """
        s = np.clip(np.asarray(settings, float), 0.0, 1.0)
        out = np.empty_like(s)
        for c in range(3):
            table = self.gamma_table[:, c] / self.gamma_table[-1, c]
            out[..., c] = np.interp(s[..., c], self.gamma_input, table)
        return out

    def linear_to_frame_buffer(self, linear):
        """Gamma-corrected frame-buffer values ``rint(linear_to_settings(linear) * (2**bits - 1))``, by table.

        The same numbers as that expression (the value is a non-decreasing
        step function of the linear intensity): a 65536-bucket table gives
        the value at each bucket's low end, raised past the steps at or
        below the value (:func:`_frame_buffer_steps`; ~1 % of buckets hold
        one), the rule the compiled rendering follows. ~10x faster than
        ``np.interp`` over every pixel. Returns the input's float dtype
        (float32 stays float32).

        Examples
        --------
        A quarter of full intensity on a square-law monitor: setting 0.5, frame-buffer value rint(127.5) = 128.

        >>> import numpy as np
        >>> g = np.linspace(0, 1, 11)
        >>> m = Monitor(np.array([450.0, 550.0, 650.0]), np.eye(3), g, np.stack([g ** 2] * 3, axis=1), name="square-law")
        >>> m.linear_to_frame_buffer(np.array([[0.25, 1.0, 0.0]])).tolist()
        [[128.0, 255.0, 0.0]]
        """
        lin = np.asarray(linear)
        dtype = lin.dtype if lin.dtype in (np.float32, np.float64) else np.dtype(np.float64)
        # by chunks of pixels: the lookups' temporaries (indices, table values) stay a few MiB
        # instead of four copies of a 12-megapixel image
        return map_pixels(lambda chunk: self._frame_buffer_chunk(chunk, dtype), lin).astype(dtype, copy=False)

    def _frame_buffer_chunk(self, lin, dtype):
        """:meth:`linear_to_frame_buffer` of (n, 3) values: the rule of the compiled rendering
        (:func:`_render_rows`) in numpy, each value its bucket's low end raised past the steps at or below it."""
        lin = np.clip(lin, 0.0, 1.0, dtype=dtype)
        idx = (lin * dtype.type(_BUCKETS)).astype(np.int32)
        idx += (np.arange(3, dtype=np.int32) * (_BUCKETS + 1))
        out = _frame_buffer_lows(self, dtype).take(idx).astype(dtype)
        # where each channel's next value begins, +inf past its last: flat, (3 (2**bits),)
        steps = _frame_buffer_steps(self, dtype)
        nxt = np.concatenate([steps, np.full((3, 1), np.inf, dtype)], axis=1).ravel()
        row = np.arange(3, dtype=np.int32) * (nxt.size // 3)
        flat, x = out.reshape(-1), lin.reshape(-1)
        np.add(out, row, out=idx, casting="unsafe")  # idx reused: where each value's next step is in nxt
        up = np.flatnonzero(nxt.take(idx) <= lin)
        while up.size:  # raised past one step; those still at or past the next go round again (a bucket seldom holds two)
            flat[up] += 1
            up = up[nxt.take(flat[up].astype(np.intp) + row[up % 3]) <= x[up]]
        return out

    def _settings_to_frame_buffer(self, rows, matrix, scale, out=None):
        """Frame-buffer values (n, 3) of sensor rows (n, K): ``clip(matrix @ r / scale, 0, 1)``, then
        :meth:`linear_to_frame_buffer`'s numbers, in one compiled pass (:func:`_render_rows`); written into
        ``out`` (n, 3, C-ordered, the rows' dtype) when given.

        The rendering of a chunk of pixels: numpy takes ~10 passes for the
        same (the product, scaling, clipping, bucket index, lookups). A value
        whose bucket holds a step is settled in the pass by the table of
        where each frame-buffer value begins (:func:`_frame_buffer_steps`),
        not evaluated afterwards. In the rows' float dtype (float32 stays
        float32); NaN stays NaN.
        """
        dtype = rows.dtype
        lo = _frame_buffer_lows(self, dtype)
        if out is None:
            out = np.empty((rows.shape[0], 3), dtype)
        kernel = _render_kernel3() if rows.shape[1] == 3 else _render_kernel()
        kernel(np.ascontiguousarray(rows), np.ascontiguousarray(matrix, dtype), dtype.type(scale),
               np.array([0, 1], dtype), lo, _frame_buffer_steps(self, dtype), _BUCKETS, out)
        return out

    def frame_buffer_to_linear(self, values):
        """``settings_to_linear(values / (2**bits - 1))`` for frame-buffer values (..., 3), by a 2**bits table.

        Whole numbers in range are looked up (the same numbers); anything else
        goes through :meth:`settings_to_linear`. Returns the input's float
        dtype (float32 stays float32).

        Examples
        --------
        >>> import numpy as np
        >>> g = np.linspace(0, 1, 11)
        >>> m = Monitor(np.array([450.0, 550.0, 650.0]), np.eye(3), g, np.stack([g ** 2] * 3, axis=1), name="square-law")
        >>> m.frame_buffer_to_linear(np.array([255.0, 0.0, 255.0])).tolist()
        [1.0, 0.0, 1.0]
        """
        v = np.asarray(values)
        dtype = v.dtype if v.dtype in (np.float32, np.float64) else np.dtype(np.float64)
        full = 2**self.bits - 1
        with np.errstate(invalid="ignore"):  # NaN or out of int32's range: not a table index, checked next
            idx = v.astype(np.int32)
        if not (np.array_equal(idx, v) and idx.min(initial=0) >= 0 and idx.max(initial=0) <= full):
            return self.settings_to_linear(v / float(full)).astype(dtype, copy=False)
        idx += np.arange(3, dtype=np.int32) * (full + 1)
        return _linear_table(self, dtype).ravel().take(idx)

    def _settings(self, lin, c):
        """Channel ``c`` of :meth:`linear_to_settings` on values already in [0, 1]."""
        table = self.gamma_table[:, c] / self.gamma_table[-1, c]
        keep = np.concatenate([[True], np.diff(table) > 0])
        return np.interp(lin, table[keep], self.gamma_input[keep])

    def describe(self):
        return {"name": self.name, "kind": "monitor", "wavelengths_nm": f"{self.wavelengths[0]:g}-{self.wavelengths[-1]:g}",
                "bits": self.bits, "gamma_entries": int(self.gamma_input.size)}


#: Buckets of the frame-buffer table over linear intensities [0, 1] (a power of 2: x * 2**16 is exact).
_BUCKETS = 1 << 16


def _render_rows(rows, m, scale, limits, lo, steps, buckets, out):
    """The kernel of :meth:`Monitor._settings_to_frame_buffer`.

    Per pixel and channel: the linear setting ``w = (m @ r) / scale`` clipped
    to ``limits`` ([0, 1] in the rows' dtype, so that numba keeps ``w`` in
    it), its bucket ``int(w * buckets)``, the frame-buffer value at the
    bucket's low end, raised past every step at or below ``w`` (``steps[c, v]``:
    where channel c's value v + 1 begins; usually one comparison, a bucket
    seldom holds a step). NaN stays NaN. Compiled by numba (:func:`_render_kernel`).
    """
    k = rows.shape[1]
    top = limits[1] * buckets  # the bucket count as a float (a power of 2: w * top is exact, as w * buckets was)
    stride = buckets + 1
    full = steps.shape[1]
    for i in range(rows.shape[0]):
        for c in range(3):
            w = m[c, 0] * rows[i, 0]
            for j in range(1, k):
                w += m[c, j] * rows[i, j]
            w = w / scale
            if w < limits[0]:
                w = limits[0]
            elif w > limits[1]:
                w = limits[1]
            if w >= 0:  # not NaN
                v = int(lo[int(w * top) + c * stride])
                while v < full and w >= steps[c, v]:
                    v += 1
                out[i, c] = v
            else:
                out[i, c] = w


def _render_rows3(rows, m, scale, limits, lo, steps, buckets, out):
    """:func:`_render_rows` for three sensors, a pixel's three values held for its three channels (the same
    numbers, in the same order of operations; a quarter less time than the general loop). Its clipping and
    lookup repeat the general kernel's lines: each kernel is compiled alone, and a helper shared between
    them would have to be compiled on its own and inlined."""
    top = limits[1] * buckets
    stride = buckets + 1
    full = steps.shape[1]
    for i in range(rows.shape[0]):
        r0, r1, r2 = rows[i, 0], rows[i, 1], rows[i, 2]
        for c in range(3):
            w = m[c, 0] * r0
            w += m[c, 1] * r1
            w += m[c, 2] * r2
            w = w / scale
            if w < limits[0]:
                w = limits[0]
            elif w > limits[1]:
                w = limits[1]
            if w >= 0:  # not NaN
                v = int(lo[int(w * top) + c * stride])
                while v < full and w >= steps[c, v]:
                    v += 1
                out[i, c] = v
            else:
                out[i, c] = w


_render_kernel = compiled(_render_rows)
_render_kernel3 = compiled(_render_rows3)


@lru_cache(maxsize=16)
def _linear_table(monitor, dtype):
    """Per channel, the linear intensity of every frame-buffer value: (3, 2**bits) in ``dtype``, read-only."""
    full = 2**monitor.bits - 1
    table = monitor.settings_to_linear(np.arange(full + 1, dtype=float)[:, None].repeat(3, axis=1) / float(full))
    table = np.ascontiguousarray(table.T, dtype)
    table.flags.writeable = False
    return table


@lru_cache(maxsize=16)
def _frame_buffer_lows(monitor, dtype):
    """Per channel, the frame-buffer value at each bucket's low end: flat (3 (B + 1),), read-only.

    Bucket b holds the ``dtype`` values x with b <= x * B < b + 1. A value in
    it is that one raised past the steps at or below it
    (:func:`_frame_buffer_steps`; a bucket seldom holds one).
    """
    full = float(2**monitor.bits - 1)
    starts = (np.arange(_BUCKETS + 1) / _BUCKETS).astype(dtype)
    lo = np.stack([np.rint(monitor._settings(starts.astype(np.float64), c) * full) for c in range(3)])
    # whole numbers: held in the narrowest unsigned type (an 8-bit monitor's table fits the CPU's cache)
    store = np.uint8 if full <= 255 else np.uint16 if full <= 65535 else dtype
    lo = lo.astype(store).ravel()
    lo.flags.writeable = False
    return lo


@lru_cache(maxsize=16)
def _frame_buffer_steps(monitor, dtype):
    """Per channel, where each frame-buffer value begins: (3, 2**bits - 1) in ``dtype``, read-only.

    Entry [c, v] is the smallest ``dtype`` value x in [0, 1] whose frame-buffer value
    ``rint(linear_to_settings(x) * (2**bits - 1))`` exceeds v (0 when even x = 0 does, +inf when
    not even x = 1 does): the value is a non-decreasing step function of x, so the value of any
    x is the number of entries at or below it. Found by bisection over the dtype's values
    (non-negative floats order as their bit patterns), evaluating that expression exactly.
    """
    full = 2**monitor.bits - 1
    dt = np.dtype(dtype)
    bits = np.uint32 if dt.itemsize == 4 else np.uint64
    levels = np.arange(full, dtype=np.float64)
    one = np.array(1, dt).view(bits)
    steps = np.empty((3, full), dt)
    for c in range(3):
        def value(b):
            return np.rint(monitor._settings(b.view(dt).astype(np.float64), c) * float(full))

        lo = np.zeros(full, bits)  # value(lo) <= v < value(hi), kept while they are apart
        hi = np.full(full, one, bits)
        for _ in range(8 * dt.itemsize):
            mid = lo + (hi - lo) // 2
            above = value(mid) > levels
            hi = np.where(above, mid, hi)
            lo = np.where(above, lo, mid)
        steps[c] = hi.view(dt)
        steps[c, value(np.zeros(1, bits))[0] > levels] = 0
        steps[c, value(np.full(1, one, bits))[0] <= levels] = np.inf
    steps.flags.writeable = False
    return steps


def read_smon(path):
    """Read a SimToolbox ``.Smon`` monitor file.

    Parameters
    ----------
    path : path
        The ``.Smon`` file.

    Returns
    -------
    Monitor
        8 bits, named after the file.

    Raises
    ------
    FileFormatError
        Naming the file and the tag, for any field that is missing, of the
        wrong kind or shape, not finite, or out of its physical range:
        ``#Sim#EmissionSpectra`` (wavelengths x 3, >= 0, each phosphor
        emitting somewhere), ``#Sim#GammaInput`` (at least 2 settings
        strictly increasing within [0, 1]), ``#Sim#GammaTable`` (settings x 3,
        >= 0, some output for every phosphor), ``#Sim#AmbientSpectrum``
        (one value per wavelength, >= 0: light the screen reflects cannot be
        negative) and ``#Sim#BgColor`` (three settings in [0, 1]).
    """
    from .io.simtoolbox import _numbers, matrix, read_tagged, wavelength_sampling

    path = Path(path)
    t = read_tagged(path)
    w = wavelength_sampling(t)
    prim = matrix(t, "EmissionSpectra", "phosphor spectra")
    if prim.shape[0] != w.size:
        raise FileFormatError(path, f"#Sim#EmissionSpectra has {prim.shape[0]} rows for {w.size} wavelengths")
    if prim.shape[1] != 3:
        raise FileFormatError(path, f"#Sim#EmissionSpectra must have 3 columns (phosphors), has {prim.shape[1]}")
    if np.any(prim < 0) or not np.any(prim > 0, axis=0).all():
        raise FileFormatError(path, "#Sim#EmissionSpectra must be non-negative, each phosphor emitting somewhere")
    gi = matrix(t, "GammaInput", "the settings of the gamma table").ravel()
    gt = matrix(t, "GammaTable", "each phosphor's output at those settings")
    if gt.shape != (gi.size, 3):
        raise FileFormatError(path, f"#Sim#GammaTable must be {gi.size} x 3 to match #Sim#GammaInput, is {' x '.join(map(str, gt.shape))}")
    if gi.size < 2:
        raise FileFormatError(path, f"#Sim#GammaInput has {gi.size} entries; a gamma table needs at least 2")
    if np.any(np.diff(gi) <= 0) or gi[0] < 0 or gi[-1] > 1:
        raise FileFormatError(path, "#Sim#GammaInput must increase strictly within [0, 1]")
    if np.any(gt < 0) or np.any(gt.max(axis=0) <= 0):
        raise FileFormatError(path, "#Sim#GammaTable must be non-negative with some output for every phosphor (an all-zero table renders black)")
    amb = _tag_numbers(t, "AmbientSpectrum", _numbers)
    if amb is not None:
        if amb.size != w.size:
            raise FileFormatError(path, f"#Sim#AmbientSpectrum has {amb.size} values for {w.size} wavelengths")
        if np.any(amb < 0):
            j = int(np.argmin(amb))
            raise FileFormatError(path, f"#Sim#AmbientSpectrum must be >= 0 (ambient light cannot be negative); "
                                        f"it is {amb[j]:g} at {w[j]:g} nm")
    bg = _tag_numbers(t, "BgColor", _numbers)
    if bg is not None and (bg.size != 3 or np.any(bg < 0) or np.any(bg > 1)):
        raise FileFormatError(path, f"#Sim#BgColor must be three settings in [0, 1], found {bg.tolist()[:6]}")
    try:
        return Monitor(w, prim, gi, gt, amb, tuple(float(v) for v in bg) if bg is not None else (0.5, 0.5, 0.5), 8,
                       path.stem)
    except ValueError as exc:
        raise FileFormatError(path, str(exc)) from None


def _tag_numbers(t, name, numbers):
    """The numbers of optional tag ``name`` (a matrix or a section of lines), finite; None when absent."""
    value = t.get_tag(name)
    if value is None:
        return None
    if isinstance(value, dict):
        raise FileFormatError(t.path, f"#Sim#{name} should hold numbers, found a group of ##Sim fields")
    if isinstance(value, np.ndarray):
        return value.ravel()
    return numbers(t.path, name, value)


@lru_cache(maxsize=None)
def _shipped(name):
    if name == "simtoolbox-test":
        m = read_smon(SIMTOOLBOX / "monitors" / "SimToolboxTest.Smon")
        return Monitor(m.wavelengths, m.primaries, m.gamma_input, m.gamma_table, m.ambient, m.background, 8, name)
    from .datasets.colour_science import table

    w, primaries = table("crt-brainard-1997")  # colour-science's, shipped
    gi = np.linspace(0, 1, 1024)
    gt = np.repeat((gi ** 2.2)[:, None], 3, axis=1)
    return Monitor(w, primaries, gi, gt, None, (0.5, 0.5, 0.5), 8, name)


def load_monitor(name_or_path):
    """A :class:`Monitor` from a shipped name (``MONITOR_NAMES``) or an ``.Smon`` path.

    Examples
    --------
    >>> monitor = load_monitor("simtoolbox-test")
    >>> monitor.bits, monitor.primaries.shape[1]
    (8, 3)
    """
    if isinstance(name_or_path, Monitor):
        return name_or_path
    key = str(name_or_path)
    if key.lower() in MONITOR_NAMES:
        return _shipped(key.lower())
    p = Path(key)
    if not os.path.lexists(p):
        raise FileFormatError(p, f"no such file, and not a shipped monitor name ({', '.join(MONITOR_NAMES)})")
    if p.suffix.lower() != ".smon":
        raise FileFormatError(p, "unknown monitor format: expected a SimToolbox .Smon file")
    return read_smon(p)
