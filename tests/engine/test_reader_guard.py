"""One test per signature the reader fuzz found in the MATLAB reader, the Scene and the shared guard.

* scipy's compiled v5 reader dies (SIGSEGV / SIGBUS) on array flags naming
  a class MATLAB does not define: the file is walked before scipy sees it;
* a compressed v5 bomb is refused within the caller's scene limit, before
  scipy allocates the variable;
* a struct where a number belongs (``float()`` of a ``mat_struct``) names
  the field;
* a Scene refuses NaN, infinite, negative, absurd or non-increasing
  wavelengths whatever reader made it;
* any other exception escaping a reader becomes a FileFormatError naming
  the user's file, with no server path.
"""

from __future__ import annotations

import io
import struct
import time
import tracemalloc
import zlib

import numpy as np
import pytest
import scipy.io

import camsim_core as cs
from camsim_core.errors import CamsimError, FileFormatError, ParameterError
from camsim_core.io.guard import reader_errors, scrub_paths
from camsim_core.io.matv5 import check_v5
from camsim_core.io.upload import load_upload
from camsim_core.scene import Scene

WLS = np.arange(400.0, 701.0, 10.0)


def _v5(variables, compress=False):
    buf = io.BytesIO()
    scipy.io.savemat(buf, variables, do_compression=compress)
    return bytearray(buf.getvalue())


def _class_offsets(data):
    """Offsets of every array-flags word in an uncompressed little-endian v5 file (tag 6, 8 bytes)."""
    return [i + 8 for i in range(128, len(data) - 16, 8) if data[i:i + 8] == struct.pack("<II", 6, 8)]


@pytest.mark.parametrize("cls", [0, 18, 50, 66, 196, 255])
def test_v5_unknown_array_class_is_refused_before_scipy(cls, monkeypatch):
    data = _v5({"rad": np.ones((2, 3, 31)), "bands": WLS})
    offsets = _class_offsets(data)
    assert len(offsets) == 2
    data[offsets[1]] = cls  # the second variable's class byte ('bands')

    def scipy_must_not_run(*a, **k):
        raise AssertionError("scipy read a file the walk should have refused")

    monkeypatch.setattr(scipy.io, "whosmat", scipy_must_not_run)
    monkeypatch.setattr(scipy.io, "loadmat", scipy_must_not_run)
    with pytest.raises(FileFormatError, match=rf"cube.mat: .*array class {cls}, which MATLAB does not define"):
        load_upload("cube.mat", bytes(data))


def test_v5_walk_accepts_what_scipy_writes():
    """Every kind of variable scipy writes, compressed or not, passes the walk (it refuses no valid file)."""
    import scipy.sparse

    variables = {"a": np.ones((3, 4, 5)), "c": np.array([[1 + 2j]]), "s": "hello", "u": "h\u00e9llo \u2603",
                 "cell": np.array([np.ones(3), "x", np.zeros((0, 3))], dtype=object),
                 "st": {"f": 1, "g": {"h": np.arange(5)}}, "sp": scipy.sparse.csr_matrix(np.eye(3)),
                 "b": np.array([True, False]), "i8": np.int8([1, 2]), "e": np.zeros((0, 0)), "i64": np.int64([1, 2**40])}
    for compress in (False, True):
        assert check_v5(bytes(_v5(variables, compress)), shown="x.mat", max_bytes=10**7) == 60  # 'a': 3 x 4 x 5


def test_v5_compressed_bomb_is_refused_within_the_upload_limit():
    """2 MB of compressed zeros declaring 400 MB: refused while decompressing, within the upload's scene bound."""
    cube = np.zeros((400, 400, 31 * 10))  # 49.6 M values, 397 MB as float64
    data = bytes(_v5({"rad": cube, "bands": np.arange(cube.shape[2], dtype=float)}, compress=True))
    del cube
    assert len(data) < 2_000_000
    tracemalloc.start()
    t0 = time.perf_counter()
    with pytest.raises(FileFormatError, match="bomb.mat: .*(expand to more than|more than the 8000000 allowed)"):
        load_upload("bomb.mat", data)
    elapsed = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 200 * 2**20, f"peak {peak / 2**20:.0f} MiB"  # the limit is 8 M values = 64 MB + 16 MiB
    assert elapsed < 10


def test_v5_array_over_the_scene_limit_is_refused_before_allocation(monkeypatch):
    data = bytes(_v5({"rad": np.ones((50, 50, 31)), "bands": WLS}))
    monkeypatch.setattr(scipy.io, "loadmat", lambda *a, **k: pytest.fail("allocated"))
    from camsim_core.io.upload import UploadLimits

    with pytest.raises(FileFormatError, match="more than the 1000 allowed"):
        load_upload("big.mat", data, UploadLimits(max_scene_values=1000))


@pytest.mark.parametrize("field", ["wAngular", "distance"])
def test_isetcam_struct_where_a_number_belongs_names_the_field(field):
    scene = {"data": {"photons": np.full((4, 5, 31), 1e15)}, "spectrum": {"wave": WLS}, "wAngular": 10.0,
             "distance": 1.2, "name": "x"}
    scene[field] = {"oops": 1.0}
    with pytest.raises(FileFormatError, match=rf"iset.mat: scene.{field} holds a struct, expected numbers"):
        load_upload("iset.mat", bytes(_v5({"scene": scene})))


@pytest.mark.parametrize("field,value", [("wAngular", -3.0), ("distance", 0.0), ("wAngular", np.nan)])
def test_isetcam_geometry_must_be_positive_and_finite(field, value):
    scene = {"data": {"photons": np.full((4, 5, 31), 1e15)}, "spectrum": {"wave": WLS}, "wAngular": 10.0, "distance": 1.2}
    scene[field] = value
    with pytest.raises(FileFormatError, match=rf"iset.mat: scene.{field} (must be a positive|holds NaN)"):
        load_upload("iset.mat", bytes(_v5({"scene": scene})))


@pytest.mark.parametrize("wavelengths", [
    np.r_[np.nan, WLS[1:]], np.r_[WLS[:-1], np.inf], np.r_[-10.0, WLS[1:]], np.r_[0.0, WLS[1:]],
    np.r_[WLS[:-1], 2.0**31], WLS[::-1], np.r_[WLS[:2], WLS[1:-1]]])
def test_scene_refuses_bad_wavelengths(wavelengths):
    with pytest.raises(ParameterError, match="wavelengths"):
        Scene(np.ones((2, 2, wavelengths.size)), wavelengths)


def test_scene_wavelengths_from_a_file_are_checked_whatever_the_reader():
    data = bytes(_v5({"rad": np.ones((2, 3, 31)), "bands": np.r_[WLS[:-1], 2.0**31]}))
    with pytest.raises(CamsimError, match=r"w.mat: .*wavelengths.*from 100 to 20000 nm"):
        load_upload("w.mat", data)


def test_guard_maps_any_exception_to_the_users_file_without_server_paths():
    with pytest.raises(FileFormatError) as info:
        with reader_errors("scene.mat"):
            raise TypeError("float() argument must be a string, not 'mat_struct' (/srv/camsim/tmp/x/scene.mat)")
    text = str(info.value)
    assert text.startswith("scene.mat: could not be read (TypeError: ")
    assert "/srv" not in text and "<path>" in text
    with pytest.raises(FileFormatError, match="too large to read"):
        with reader_errors("scene.mat"):
            raise MemoryError()
    with pytest.raises(ParameterError):  # a CamsimError passes as it is
        with reader_errors("scene.mat"):
            raise ParameterError("angle", "bad")


def test_scrub_keeps_the_users_name_and_drops_server_paths():
    assert scrub_paths("/home/me/scene.mat: bad at /usr/lib/x.so", keep=("/home/me/scene.mat",)) == \
        "/home/me/scene.mat: bad at <path>"
    assert scrub_paths("C:\\Users\\x\\a.mat broken") == "<path> broken"


def test_load_scene_never_leaks_an_unexpected_exception(tmp_path, monkeypatch):
    """A reader failing in an unforeseen way (here: ENVI raising KeyError) still gives one error naming the file."""
    import camsim_core.scene.envi as envi

    def broken(*a, **k):
        raise KeyError("/etc/shadow")

    monkeypatch.setattr(envi, "read_envi", broken)
    p = tmp_path / "x.hdr"
    p.write_text("ENVI\n")
    with pytest.raises(FileFormatError) as info:
        cs.load_scene(p)
    assert str(p) in str(info.value) and "/etc/shadow" not in str(info.value)
