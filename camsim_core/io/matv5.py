"""Vetting a MATLAB v5 ``.mat`` file's structure before scipy reads it.

scipy's compiled v5 reader (``scipy.io.matlab._mio5_utils``) trusts the
file: a variable whose array flags name a class MATLAB does not have (byte
values 18-255 where 1-17 are defined) makes it crash the interpreter
(SIGSEGV or SIGBUS inside ``VarReader5.read_mi_matrix``), which in a server
takes every session with it. :func:`check_v5` walks every data element of
the file (top-level variables, compressed ones after a bounded
decompression, and every struct field and cell element inside them) and
refuses, with a :class:`~camsim_core.errors.FileFormatError` naming the
user's file:

* a header that is not a MATLAB 5 header, or an unknown byte order;
* an element that does not fit inside its parent, a truncated file;
* array flags of an unknown class, negative dimensions, a numeric part
  whose byte count disagrees with the dimensions;
* variables whose uncompressed size exceeds ``max_bytes`` (a compressed
  bomb is refused while it is decompressed, never held whole);
* nesting deeper than :data:`MAX_DEPTH`.

Hand-written against the MAT-File Format reference (MathWorks, "MAT-File
Format", R2024a, chapter 1: data element tags, the small data element
format, miMATRIX sub-elements); no library exposes a structural check.

Examples
--------
>>> import io, numpy as np, scipy.io
>>> buf = io.BytesIO()
>>> scipy.io.savemat(buf, {"rad": np.ones((2, 3, 4))})
>>> check_v5(buf.getbuffer(), shown="scene.mat", max_bytes=10**6)  # the largest array's value count
24
"""

from __future__ import annotations

import struct
import zlib

from ..errors import FileFormatError

__all__ = ["check_v5", "MAX_DEPTH"]

#: Deepest nesting of structs and cells accepted (ISETCam scenes nest 3-4 levels).
MAX_DEPTH = 32

_MATRIX, _COMPRESSED = 14, 15
#: Data types of numeric payloads and their item sizes (miINT8 ... miUINT64, miUTF8/16/32).
_ITEM = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8, 14: None, 16: 1, 17: 2, 18: 4}
#: MATLAB array classes: 1 cell, 2 struct, 3 object, 4 char, 5 sparse, 6-15 numeric, 16 function, 17 opaque.
_CELL, _STRUCT, _OBJECT, _CHAR, _SPARSE = 1, 2, 3, 4, 5
_NUMERIC = range(6, 16)
_CLASSES = range(1, 18)


class _Walk:
    def __init__(self, shown, order):
        self.shown = shown
        self.order = order
        self.largest = 0  # values in the largest numeric or character array seen

    def fail(self, message):
        raise FileFormatError(self.shown, f"not a valid MATLAB v5 file: {message}")

    def tag(self, buf, pos, end):
        """(type, nbytes, data start, next element) of the element at ``pos``, inside ``end``."""
        if pos + 8 > end:
            self.fail("an element runs past the end of its variable (truncated?)")
        word = struct.unpack_from(self.order + "I", buf, pos)[0]
        small = word >> 16
        if small:  # small data element: type and size in one word, data in the next 4 bytes
            if small > 4:
                self.fail(f"a small data element claims {small} bytes (at most 4)")
            return word & 0xFFFF, small, pos + 4, pos + 8
        mtype, n = struct.unpack_from(self.order + "II", buf, pos)
        start = pos + 8
        if n > end - start:
            self.fail(f"an element of {n} bytes runs past the end of its variable")
        return mtype, n, start, min(start + n + (-n % 8), end)

    def payload(self, buf, pos, end, count, what):
        """A numeric payload of ``count`` items; returns the next position."""
        mtype, n, start, nxt = self.tag(buf, pos, end)
        size = _ITEM.get(mtype)
        if size is None:
            self.fail(f"{what} has data type {mtype}, not a numeric type")
        if n != count * size and mtype not in (16, 17, 18):
            self.fail(f"{what} holds {n} bytes for {count} values of {size} bytes")
        return nxt

    def matrix(self, buf, start, n, depth):
        """Check one miMATRIX element's content (``n`` bytes from ``start``)."""
        if n == 0:
            return  # an empty array (e.g. an empty cell element)
        if depth > MAX_DEPTH:
            self.fail(f"structs or cells nested deeper than {MAX_DEPTH}")
        end = start + n
        mtype, ln, ds, pos = self.tag(buf, start, end)
        if mtype != 6 or ln != 8:
            self.fail("array flags missing")
        flags = struct.unpack_from(self.order + "I", buf, ds)[0]
        cls, complex_ = flags & 0xFF, bool(flags & 0x800)
        if cls not in _CLASSES:
            self.fail(f"a variable has array class {cls}, which MATLAB does not define (1-17)")
        mtype, ln, ds, pos = self.tag(buf, pos, end)
        if mtype != 5 or ln % 4 or ln < 8:
            self.fail("array dimensions missing")
        dims = struct.unpack_from(self.order + f"{ln // 4}i", buf, ds)
        if min(dims) < 0:
            self.fail(f"negative array dimensions {dims}")
        count = 1
        for d in dims:
            count *= d
        mtype, ln, ds, pos = self.tag(buf, pos, end)  # the array's name
        if mtype not in (1, 2):
            self.fail("array name missing")
        if cls in _NUMERIC or cls == _CHAR:
            self.largest = max(self.largest, count)
        if cls in _NUMERIC:
            pos = self.payload(buf, pos, end, count, "a numeric array")
            if complex_:
                self.payload(buf, pos, end, count, "a complex array's imaginary part")
        elif cls == _CHAR:
            self.payload(buf, pos, end, count, "a character array")
        elif cls == _SPARSE:
            for _ in range(3 + complex_):  # row indices, column starts, values (and imaginary values)
                _, _, _, pos = self.tag(buf, pos, end)
        elif cls in (_STRUCT, _OBJECT):
            if cls == _OBJECT:
                mtype, ln, ds, pos = self.tag(buf, pos, end)  # class name
            mtype, ln, ds, pos = self.tag(buf, pos, end)
            if mtype != 5 or ln != 4:
                self.fail("struct field name length missing")
            flen = struct.unpack_from(self.order + "i", buf, ds)[0]
            mtype, ln, ds, pos = self.tag(buf, pos, end)
            if flen <= 0 or mtype not in (1, 2) or ln % flen:
                self.fail(f"struct field names of {ln} bytes do not divide into names of {flen}")
            self.elements(buf, pos, end, count * (ln // flen), depth)
        elif cls == _CELL:
            self.elements(buf, pos, end, count, depth)

    def elements(self, buf, pos, end, count, depth):
        """``count`` nested miMATRIX elements from ``pos`` (struct fields or cell elements)."""
        if count * 8 > end - pos:
            self.fail(f"{count} struct fields or cell elements cannot fit in {end - pos} bytes")
        for _ in range(count):
            mtype, n, start, pos = self.tag(buf, pos, end)
            if mtype != _MATRIX:
                self.fail(f"a struct field or cell element has data type {mtype}, expected an array")
            self.matrix(buf, start, n, depth + 1)


def _inflate(buf, start, n, walk, budget):
    """The zlib stream of a compressed element, decompressed to at most ``budget`` bytes."""
    d = zlib.decompressobj()
    out, total = [], 0
    data = bytes(buf[start : start + n])
    while data:
        try:
            chunk = d.decompress(data, 1 << 24)
        except zlib.error as exc:
            walk.fail(f"a compressed variable is corrupt ({exc})")
        total += len(chunk)
        if total > budget:
            raise FileFormatError(walk.shown, f"variables expand to more than {budget + total - len(chunk)} bytes; "
                                              "too large a scene")
        out.append(chunk)
        data = d.unconsumed_tail
    if not d.eof:
        walk.fail("a compressed variable is truncated")
    return b"".join(out)


def check_v5(buf, *, shown, max_bytes):
    """Walk a MATLAB v5 file's elements; return the largest array's value count, or raise FileFormatError.

    Parameters
    ----------
    buf : bytes-like
        The whole file (bytes, a ``memoryview`` or an ``mmap``).
    shown : str
        The user's name of the file, for messages.
    max_bytes : int
        Most bytes all variables may hold once decompressed.

    Returns
    -------
    int
        Values (product of the dimensions) of the largest numeric or
        character array anywhere in the file, nested ones included: a
        caller bounds it before scipy allocates anything.

    Raises
    ------
    FileFormatError
        See the module docstring; the message names ``shown``.
    """
    if len(buf) < 128 or bytes(buf[:6]) != b"MATLAB":
        raise FileFormatError(shown, "not a MATLAB .mat file (no 'MATLAB' header)")
    mark = bytes(buf[126:128])
    if mark not in (b"IM", b"MI"):
        raise FileFormatError(shown, f"not a valid MATLAB v5 file: unknown byte order mark {mark!r}")
    walk = _Walk(shown, "<" if mark == b"IM" else ">")
    pos, end, total = 128, len(buf), 0
    while pos < end:
        if end - pos < 8:
            walk.fail("truncated after the last variable")
        mtype, n = struct.unpack_from(walk.order + "II", buf, pos)
        start = pos + 8
        if n > end - start:
            walk.fail(f"a variable of {n} bytes runs past the end of the file (truncated?)")
        if mtype == _COMPRESSED:
            inner = _inflate(buf, start, n, walk, max_bytes - total)
            total += len(inner)
            itype, ilen, istart, _ = walk.tag(inner, 0, len(inner))
            if itype != _MATRIX:
                walk.fail(f"a compressed variable holds data type {itype}, expected an array")
            walk.matrix(inner, istart, ilen, 0)
            pos = start + n
        elif mtype == _MATRIX:
            total += n
            if total > max_bytes:
                raise FileFormatError(shown, f"variables hold more than {max_bytes} bytes; too large a scene")
            walk.matrix(buf, start, n, 0)
            pos = start + n + (-n % 8)
        else:
            walk.fail(f"a top-level element has data type {mtype}, expected a variable")
    return walk.largest
