"""Seeded fuzzing of the image readers: band-PNG folders, photos (PNG, JPEG) and ENVI images.

Every mutated file must give a valid scene (finite, non-negative radiance
in 3-D, strictly increasing wavelengths within the scene's
``WAVELENGTH_RANGE``, a positive distance and angular resolution) or a
:class:`~camsim_core.errors.CamsimError` whose message names the user's
file and never the folder it was read from; no other exception, no stray
warning (Pillow's decompression-bomb warning included), no call longer
than :data:`SLOW_SECONDS`.

Mutations: bytes flipped, files truncated, header text mutated (numbers
replaced by NaN, infinities, -1, 0, 1e308, 2**31, words), PNG headers
rewritten (decompression bombs: small files declaring 100000 x 100000
pixels, and a real one of 12000 x 12000 zeros), chunks dropped or
duplicated, bands missing, of other sizes and modes, JSON fields of the
wrong type. 60 mutations per format run with the suite; ``CAMSIM_FULL_FUZZ=1``
runs 1,500 per format and prints the table of outcomes and the signature
of every failure.

Below the fuzz: one regression test per failure signature the fuzz found.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import signal
import struct
import time
import traceback
import warnings
import zlib
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from camsim_core.errors import CamsimError, FileFormatError
from camsim_core.scene import SceneNotice, scene_from_rgb
from camsim_core.scene.cave import read_band_folder
from camsim_core.scene.envi import read_envi
from camsim_core.scene.photo import read_photo
from camsim_core.scene.scene import WAVELENGTH_RANGE

FULL = os.environ.get("CAMSIM_FULL_FUZZ") == "1"
COUNT = 1500 if FULL else 60
#: A call taking longer than this (s) counts as a hang (SIGALRM stops it).
SLOW_SECONDS = 60
WLS = 400.0 + 10.0 * np.arange(31)
NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w.])")
BAD_NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "-1", "0", "1e308", "-1e308", "2147483648", "4294967296",
               "1e400", "2.5", "0.5", "abc", "", "-0", "1e-308", "1" * 400, "\u0661\u0662"]
#: Sizes a rewritten PNG header declares: none, tiny, other, bombs, 32-bit overflows.
HEADER_SIZES = [0, 1, 3, 5, 8, 100_000, 12_000, 2**31 - 1, 2**32 - 1, 65_536]


# -- writing and patching files ------------------------------------------------------------------------

def _png_chunks(data):
    """[(type, body)] of a PNG's chunks (stops at the first malformed one)."""
    out, pos = [], 8
    while pos + 8 <= len(data):
        n = struct.unpack(">I", data[pos:pos + 4])[0]
        out.append((data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]))
        pos += 12 + n
    return out


def _png(chunks):
    """A PNG of ``chunks`` with their CRCs computed (a patched header stays readable)."""
    return b"\x89PNG\r\n\x1a\n" + b"".join(struct.pack(">I", len(body)) + t + body + struct.pack(">I", zlib.crc32(t + body))
                                           for t, body in chunks)


def _patched_ihdr(data, width=None, height=None, depth=None, colour=None):
    chunks = _png_chunks(data)
    w, h, d, c, rest = struct.unpack(">IIBB3s", chunks[0][1])
    body = struct.pack(">IIBB3s", w if width is None else width, h if height is None else height,
                       d if depth is None else depth, c if colour is None else colour, rest)
    return _png([(b"IHDR", body)] + chunks[1:])


def _tiff16_rgb(a):
    """A 16-bit RGB TIFF of ``a`` (H, W, 3) uint16 (tifffile writes it; Pillow cannot)."""
    import tifffile

    buf = io.BytesIO()
    tifffile.imwrite(buf, a, photometric="rgb")
    return buf.getvalue()


def _orientation_exif(value):
    from PIL import Image

    exif = Image.Exif()
    exif[0x0112] = value  # Orientation
    return exif.tobytes()


_ORIENTED = _orientation_exif(6)


def _png16_rgb(a):
    """A 16-bit RGB PNG of ``a`` (H, W, 3) uint16 (Pillow writes 16 bits for grey only)."""
    h, w, _ = a.shape
    rows = b"".join(b"\0" + a[i].astype(">u2").tobytes() for i in range(h))
    return _png([(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 2, 0, 0, 0)), (b"IDAT", zlib.compress(rows)), (b"IEND", b"")])


def _real_bomb(side=12000):
    """A grey 8-bit PNG of ``side`` x ``side`` zeros: about 150 kB that decodes to side^2 bytes."""
    z = zlib.compressobj(9)
    row = b"\0" * (side + 1)
    idat = b"".join(z.compress(row * 100) for _ in range(side // 100)) + z.flush()
    return _png([(b"IHDR", struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)), (b"IDAT", idat), (b"IEND", b"")])


def _image_bytes(a, fmt="PNG", mode=None, **kw):
    buf = io.BytesIO()
    im = Image.fromarray(a)
    (im.convert(mode) if mode else im).save(buf, format=fmt, **kw)
    return buf.getvalue()


def _flip(data, rng, at=None):
    b = bytearray(data)
    for _ in range(rng.integers(1, 5)):
        b[rng.integers(len(b)) if at is None else rng.integers(*at)] = rng.integers(256)
    return bytes(b)


def _mutate_numbers(text, rng):
    spots = list(NUMBER.finditer(text))
    if not spots:
        return text
    for _ in range(rng.integers(1, 3)):
        m = spots[rng.integers(len(spots))]
        text = text[: m.start()] + BAD_NUMBERS[rng.integers(len(BAD_NUMBERS))] + text[m.end():]
        spots = list(NUMBER.finditer(text))
        if not spots:
            break
    return text


def _mutate_lines(text, rng):
    lines = text.split("\n")
    kind = rng.integers(4)
    i = rng.integers(len(lines))
    if kind == 0:
        del lines[i]
    elif kind == 1:
        lines.insert(i, lines[i])
    elif kind == 2:
        lines[i] = ""
    else:
        return text[: rng.integers(len(text) + 1)]
    return "\n".join(lines)


# -- the sources -----------------------------------------------------------------------------------------

def make_sources():
    """The valid files the fuzz mutates (bytes), and a real decompression bomb."""
    rng = np.random.default_rng(7)
    bands16 = rng.integers(0, 65536, size=(31, 6, 7), dtype=np.uint16)
    rgb = rng.integers(0, 256, size=(12, 16, 3), dtype=np.uint8)
    rgb16 = rng.integers(0, 65536, size=(12, 16, 3), dtype=np.uint16)
    cube = rng.uniform(0.0, 2.0, size=(5, 4, 31))
    return {
        "bands16": [_image_bytes(b) for b in bands16],
        "bands8": [_image_bytes((b >> 8).astype(np.uint8)) for b in bands16],
        "photos": {
            "rgb8.png": _image_bytes(rgb),
            "grey16.png": _image_bytes(rgb16[:, :, 0]),
            "rgb16.png": _png16_rgb(rgb16),
            "rgb16.tif": _tiff16_rgb(rgb16),  # 16-bit colour TIFF: read by tifffile, not Pillow
            "portrait.jpg": _image_bytes(rgb, "JPEG", exif=_ORIENTED),  # EXIF orientation 6: turned upright
            "palette.png": _image_bytes(rgb, mode="P"),
            "rgb8.jpg": _image_bytes(rgb, "JPEG", quality=90),
            "grey8.jpg": _image_bytes(rgb[:, :, 1], "JPEG"),
            "progressive.jpg": _image_bytes(rgb, "JPEG", progressive=True),
        },
        "others": [_image_bytes(rgb), _image_bytes(rgb[:, :, 0]), _image_bytes(rgb, mode="RGBA"),
                   _image_bytes(rgb, mode="P"), _image_bytes(rgb, mode="1"), _image_bytes(rgb, mode="LA"),
                   _image_bytes(bands16[0, :, :5]), _image_bytes(bands16[0, :5, :]), _image_bytes(rgb, "JPEG"),
                   _png16_rgb(rgb16[:6, :7]), _image_bytes(rgb[:6, :7], "GIF"), _image_bytes(rgb[:6, :7], "BMP"),
                   _image_bytes(rgb[:6, :7], "TIFF"), b"", b"not a png", b"\x89PNG\r\n\x1a\n"],
        "cube": cube,
        "bomb": _real_bomb(),
    }


@pytest.fixture(scope="module")
def sources():
    return make_sources()


# -- band-PNG folders --------------------------------------------------------------------------------------

_JSON_VALUES = [None, True, "abc", "", [], {}, [1, 2, 3], [[400.0]], -1, 0, 1e308, 2**31, 10**400, float("nan"),
                float("inf"), ["a"] * 31, [None] * 31, list(WLS[::-1]), [500.0] * 31, list(WLS * 1e9),
                list(WLS - 500), list(range(31)), ["../x.png"] * 31, ["/etc/passwd"], ["a\0b.png"],
                ["x" * 5000 + ".png"], [{"a": 1}] * 31, {"wavelengths": list(WLS)}]


def _band_folder_case(src, folder, rng):
    """Write a mutated band folder; return the name errors must give it."""
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    bits = 16 if rng.random() < 0.7 else 8
    bands = list(src["bands16" if bits == 16 else "bands8"])
    names = [f"toy_{k + 1:02d}.png" for k in range(31)]
    meta = {"wavelengths": list(WLS), "files": names, "distance": 1.5, "angular_resolution": [60, 60], "scale": 0.01}
    with_json = rng.random() < 0.7
    kind = rng.integers(12)
    if kind == 0 and with_json:  # a number of the JSON mutated in its text
        text = _mutate_numbers(json.dumps(meta), rng)
    elif kind == 1 and with_json:  # a field of the wrong type or value
        meta[list(meta)[rng.integers(len(meta))]] = _JSON_VALUES[rng.integers(len(_JSON_VALUES))]
        text = json.dumps(meta)
    elif kind == 2 and with_json:  # the JSON's lines or structure broken
        text = _mutate_lines(json.dumps(meta, indent=1), rng) if rng.random() < 0.7 else \
            ["[" * 100_000, b"\xff\xfe{", "", "null", "[]", "{}", "[400]", json.dumps(list(WLS))][rng.integers(8)]
        if rng.random() < 0.3:
            del meta[list(meta)[rng.integers(len(meta))]]
            text = json.dumps(meta)
    else:
        text = json.dumps(meta)
    k = int(rng.integers(31)) if rng.random() < 0.5 else 0  # the first band sets the size: mutate it often
    if kind == 3:
        bands[k] = _flip(bands[k], rng)
    elif kind == 4:
        bands[k] = bands[k][: rng.integers(len(bands[k]))]
    elif kind == 5:  # the header declares another size: a bomb, zero, a 32-bit overflow
        bands[k] = _patched_ihdr(bands[k], width=int(rng.choice(HEADER_SIZES)), height=int(rng.choice(HEADER_SIZES)))
    elif kind == 6:
        bands[k] = _patched_ihdr(bands[k], depth=int(rng.choice([0, 1, 2, 4, 8, 16, 32, 255])),
                                 colour=int(rng.choice([0, 1, 2, 3, 4, 6, 7, 255])))
    elif kind == 7:  # another image in place of a band: other mode or size, JPEG, GIF, empty, junk
        bands[k] = src["others"][rng.integers(len(src["others"]))]
    elif kind == 8:  # a band missing, or one more
        if rng.random() < 0.5:
            del bands[k], names[k]
        else:
            bands.append(bands[0])
            names.append(["toy_32.png", "toy_00.png", "extra.png", "toy_01.PNG"][rng.integers(4)])
    elif kind == 9:  # a band renamed
        names[k] = ["toy_1.png", "toy_99.png", "toy_02.png", "band.png", "toy_01.txt"][rng.integers(5)]
    elif kind == 10:  # one band, a real decompression bomb (12000 x 12000 zeros)
        bands, names, text, with_json = [src["bomb"]], ["bomb.png"], json.dumps({"wavelengths": [550.0]}), True
    for name, data in zip(names, bands):
        (folder / name).write_bytes(data)
    if with_json:
        (folder / "scene.json").write_bytes(text.encode("utf-8", "surrogateescape") if isinstance(text, str) else text)
    if kind == 11 and rng.random() < 0.5:  # a folder in place of a band, or the bands one level down
        (folder / names[k]).unlink()
        (folder / names[k]).mkdir()
    elif kind == 11:
        inner = folder / "toy_ms"
        shutil.move(str(folder), str(folder.parent / "moving"))
        folder.mkdir()
        shutil.move(str(folder.parent / "moving"), str(inner))
    return folder.name


# -- photos -------------------------------------------------------------------------------------------------

def _jpeg_size_offset(data):
    """Offset of the height in a JPEG's first start-of-frame segment, or None."""
    for m in re.finditer(rb"\xff[\xc0\xc1\xc2]", data):
        return m.start() + 5
    return None


def _photo_case(src, root, rng):
    """Write a mutated photo; return its path."""
    names = list(src["photos"])
    name = names[rng.integers(len(names))]
    data = src["photos"][name]
    png = name.endswith(".png")
    kind = rng.integers(9)
    if kind == 0:
        data = _flip(data, rng)
    elif kind == 1:
        data = _flip(data, rng, at=(0, min(len(data), 64)))  # the header
    elif kind == 2:
        data = data[: rng.integers(len(data))]
    elif kind == 3:  # another declared size: bombs, zero, overflows
        w, h = int(rng.choice(HEADER_SIZES)), int(rng.choice(HEADER_SIZES))
        if png:
            data = _patched_ihdr(data, width=w, height=h)
        elif (at := _jpeg_size_offset(data)) is not None:
            data = data[:at] + struct.pack(">HH", h & 0xFFFF, w & 0xFFFF) + data[at + 4:]
    elif kind == 4 and png:
        data = _patched_ihdr(data, depth=int(rng.choice([0, 1, 2, 4, 8, 16, 32])), colour=int(rng.choice([0, 2, 3, 4, 5, 6, 7])))
    elif kind == 5 and png:  # a chunk dropped, duplicated, or a bogus one added
        chunks = _png_chunks(data)
        i = rng.integers(len(chunks))
        r = rng.random()
        if r < 0.35:
            del chunks[i]
        elif r < 0.7:
            chunks.insert(i, chunks[i])
        else:
            extra = [(b"tEXt", b"k\0" + b"v" * 5000), (b"zTXt", b"k\0\0" + zlib.compress(b"a" * 2**24)),
                     (b"iCCP", b"p\0\0" + b"junk"), (b"PLTE", b"\0" * 7), (b"tRNS", b"\0" * 300),
                     (b"sBIT", b""), (b"pHYs", b"\xff" * 9), (b"acTL", b"\0\0\0\xff\0\0\0\0")]
            chunks.insert(max(1, i), extra[rng.integers(len(extra))])
        data = _png(chunks)
    elif kind == 6:
        data = src["bomb"]
    elif kind == 7:
        data = src["others"][rng.integers(len(src["others"]))]
    suffix = Path(name).suffix if rng.random() < 0.9 else [".png", ".jpg", ".bmp", ".tif"][rng.integers(4)]
    path = root / f"holiday{suffix}"
    path.write_bytes(data)
    return path


# -- ENVI -----------------------------------------------------------------------------------------------------

_ENVI_FIELDS = {
    "interleave": ["bsq", "bil", "bip", "BIP", "xyz", "", "{bsq}"],
    "data type": ["1", "2", "3", "4", "5", "6", "9", "12", "13", "14", "15", "0", "16", "-4", "abc", "4.5", "{4}"],
    "byte order": ["0", "1", "2", "-1", "x", ""],
    "header offset": ["0", "-1", "7", "1000000000", "abc", "1e3"],
    "wavelength units": ["nanometers", "Micrometers", "um", "mm", "furlongs", "", "Unknown"],
    "data units": ["W/(m^2 sr nm)", "uW/(cm^2 sr nm)", "photons/(s sr m^2 nm)", "lux", ""],
    "distance": ["2", "0", "-1", "nan", "inf", "{}", "{1, 2}", "abc"],
    "angular resolution": ["{80, 90}", "{80}", "{}", "{nan, 1}", "{0, 0}", "{inf, inf}", "{1, 2, 3}", "{a, b}"],
    "fov": ["10", "0", "-5", "nan", "1e-300", "400", "abc"],
    "samples": ["4", "0", "-4", "5", "2147483648", "abc", "4.0"],
    "lines": ["5", "0", "-5", "6", "4294967296", "1e9"],
    "bands": ["31", "30", "32", "0", "1"],
    "wavelength": ["{" + ", ".join(f"{w:g}" for w in WLS[::-1]) + "}", "{" + ", ".join(["nan"] * 31) + "}",
                   "{" + ", ".join(f"{w * 1e6:g}" for w in WLS) + "}", "{" + ", ".join(["500"] * 31) + "}",
                   "{" + ", ".join(str(2**31 + k) for k in range(31)) + "}", "{}", "{400, 410}", "abc",
                   "{" + ", ".join(f"{w / 1000:g}" for w in WLS) + "}", "{" + ", ".join(f"{w - 500:g}" for w in WLS) + "}"],
}


def _set_field(text, key, value):
    pattern = re.compile(rf"^{re.escape(key)}\s*=.*?(?:\}}|$)", re.IGNORECASE | re.MULTILINE | re.DOTALL)
    if pattern.search(text):
        return pattern.sub(lambda _: f"{key} = {value}", text, count=1)
    return text + f"\n{key} = {value}\n"


def _envi_case(src, root, rng):
    """Write a mutated ENVI header and data file; return the header's path."""
    from spectral.io import envi

    shutil.rmtree(root, ignore_errors=True)
    root.mkdir(parents=True)
    hdr = root / "capture.hdr"
    dtype = [np.float32, np.float64, np.uint16, np.int16, np.uint8][rng.integers(5)]
    cube = src["cube"] * (1000 if np.issubdtype(dtype, np.integer) and dtype != np.uint8 else 100 if dtype == np.uint8 else 1)
    meta = {"wavelength": [f"{w:g}" for w in WLS], "wavelength units": "nanometers", "distance": "1.5",
            "angular resolution": ["80", "90"], "data units": "W/(m^2 sr nm)"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        envi.save_image(str(hdr), cube.astype(dtype), interleave=["bsq", "bil", "bip"][rng.integers(3)], ext=".img",
                        byteorder=int(rng.integers(2)), metadata=meta)
    text = hdr.read_text()
    data = root / "capture.img"
    kind = rng.integers(8)
    if kind <= 1:
        text = _mutate_numbers(text, rng)
    elif kind == 2:
        text = _mutate_lines(text, rng)
    elif kind <= 4:
        for _ in range(rng.integers(1, 3)):
            key = list(_ENVI_FIELDS)[rng.integers(len(_ENVI_FIELDS))]
            text = _set_field(text, key, _ENVI_FIELDS[key][rng.integers(len(_ENVI_FIELDS[key]))])
    elif kind == 5:
        raw = data.read_bytes()
        r = rng.random()
        if r < 0.3:
            data.write_bytes(raw[: rng.integers(len(raw))])
        elif r < 0.6:
            data.write_bytes(_flip(raw, rng))
        elif r < 0.8:
            data.unlink()
        else:
            data.write_bytes(raw + b"\0" * int(rng.integers(1, 5000)))
    elif kind == 6:  # the header's bytes flipped (not text any more)
        hdr.write_bytes(_flip(text.encode(), rng))
        return hdr
    else:  # fields duplicated with other values
        key = list(_ENVI_FIELDS)[rng.integers(len(_ENVI_FIELDS))]
        text += f"\n{key} = {_ENVI_FIELDS[key][rng.integers(len(_ENVI_FIELDS[key]))]}\n"
    hdr.write_text(text, encoding="utf-8")
    return hdr


# -- running and judging ------------------------------------------------------------------------------------

class _Hang(Exception):
    pass


def _alarm(signum, frame):
    raise _Hang()


def _invalid(scene):
    """Why ``scene`` is not a valid scene, or '' if it is."""
    d = np.asarray(scene.data)
    w = np.asarray(scene.wavelengths, float)
    ar = np.asarray(scene.angular_resolution, float)
    problems = [
        (d.ndim != 3 or min(d.shape) < 1, f"radiance of shape {d.shape}"),
        (d.size and not np.all(np.isfinite(d)), "non-finite radiance"),
        (d.size and np.nanmin(d) < 0, "negative radiance"),
        (w.shape != d.shape[-1:], f"{w.size} wavelengths for shape {d.shape}"),
        (not np.all(np.isfinite(w)) or np.any(w < WAVELENGTH_RANGE[0]) or np.any(w > WAVELENGTH_RANGE[1]),
         f"wavelengths outside {WAVELENGTH_RANGE} nm: {w[:3]}..."),
        (np.any(np.diff(w) <= 0), "wavelengths not strictly increasing"),
        (not (np.isfinite(scene.distance) and scene.distance > 0), f"distance {scene.distance}"),
        (ar.shape != (2,) or not np.all(np.isfinite(ar)) or np.any(ar <= 0), f"angular resolution {ar}"),
    ]
    return "; ".join(why for bad, why in problems if bad)


def _signature(exc):
    """Exception type, where it was raised (file:function) and its message with the numbers blanked."""
    frames = traceback.extract_tb(exc.__traceback__)
    where = f"{Path(frames[-1].filename).name}:{frames[-1].name}" if frames else "?"
    text = re.sub(r"\d+", "N", str(exc).split("\n")[0])[:70]
    return f"{type(exc).__name__} at {where}: {text}"


def outcome(reader, path, expected_name, hidden):
    """(outcome, signature): 'loaded', 'error', or a failure ('raw', 'invalid', 'leak', 'unnamed', 'warning', 'hang').

    ``expected_name`` must appear in an error's message and ``hidden`` (the
    folder the file was read from) must not.
    """
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(SLOW_SECONDS)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                scene = reader(path)
            except CamsimError as exc:
                text = str(exc)
                if hidden in text:
                    return "leak", "the message shows the folder the file was read from"
                if expected_name not in text:
                    return "unnamed", f"{type(exc).__name__}: {text[:120]}"
                result = "error", ""
            except _Hang:
                return "hang", f"over {SLOW_SECONDS} s"
            except Exception as exc:  # noqa: BLE001 - what the fuzz is looking for
                return "raw", _signature(exc)
            else:
                why = _invalid(scene)
                result = ("invalid", why) if why else ("loaded", "")
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    stray = [w for w in caught if not issubclass(w.category, SceneNotice)]
    if stray:
        return "warning", f"{stray[0].category.__name__}: {re.sub(r'[0-9]+', 'N', str(stray[0].message))[:80]}"
    return result


FORMATS = ("band folder", "photo", "envi")
FAILURES = ("raw", "invalid", "leak", "unnamed", "warning", "hang")


def fuzz(sources, root, count, seed=20260611):
    """({format: Counter of outcomes}, {format: Counter of failure signatures}) of ``count`` mutations per format."""
    rng = np.random.default_rng(seed)
    counts = {f: Counter() for f in FORMATS}
    signatures = {f: Counter() for f in FORMATS}
    hidden = str(root)
    for _ in range(count):
        shown = rng.random() < 0.5  # half the calls name the file as an upload does
        folder = root / "bands" / "toy_ms"
        name = _band_folder_case(sources, folder, rng)
        photo = _photo_case(sources, root, rng)
        hdr = _envi_case(sources, root / "envi", rng)
        kw = lambda upload: {"shown": upload} if shown else {}  # noqa: E731
        cases = [("band folder", lambda p: read_band_folder(p, **kw("toy.zip")), folder, "toy.zip" if shown else name),
                 ("photo", lambda p: read_photo(p, **kw("holiday.png")), photo, "holiday.png" if shown else photo.name),
                 ("envi", lambda p: read_envi(p, **kw("capture.zip")), hdr, "capture.zip" if shown else hdr.name)]
        for fmt, reader, path, expected in cases:
            result, why = outcome(reader, path, expected, hidden)
            counts[fmt][result] += 1
            if result in FAILURES:
                signatures[fmt][f"{result}: {why}"] += 1
        photo.unlink()
    return counts, signatures


def test_reader_fuzz_images(sources, tmp_path, capsys):
    started = time.perf_counter()
    counts, signatures = fuzz(sources, tmp_path, COUNT)
    with capsys.disabled():
        print(f"\nimage reader fuzz, {COUNT} mutations per format{' (full)' if FULL else ''}, "
              f"{time.perf_counter() - started:.1f} s:")
        print(f"{'format':12} {'loaded':>7} {'error':>7} {'raw tracebacks':>15} {'invalid':>8} {'leak':>5} "
              f"{'unnamed':>8} {'warning':>8} {'hang':>5}")
        for f, c in counts.items():
            print(f"{f:12} {c['loaded']:7d} {c['error']:7d} {c['raw']:15d} {c['invalid']:8d} {c['leak']:5d} "
                  f"{c['unnamed']:8d} {c['warning']:8d} {c['hang']:5d}")
        for f, sig in signatures.items():
            for s, n in sig.most_common():
                print(f"  {f}: {n:4d} x {s}")
    for f, c in counts.items():
        assert sum(c.values()) == COUNT
        assert c["error"] > 0 and c["loaded"] > 0, f"{f}: the fuzz must reach both outcomes, got {dict(c)}"
        assert not signatures[f], f"{f}: {dict(signatures[f])}"


# -- one regression test per failure signature the fuzz found -------------------------------------------------

@pytest.fixture
def strict():
    """Warnings as errors, but a reader's notices about assumed geometry and units."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", SceneNotice)
        yield


def _toy_folder(folder, meta=None, bands=None):
    """A band folder of 31 small 16-bit bands (``bands`` replaces some by index) and ``meta`` as scene.json."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(3)
    names = [f"toy_{k + 1:02d}.png" for k in range(31)]
    for k, name in enumerate(names):
        data = (bands or {}).get(k)
        (folder / name).write_bytes(data if data is not None else _image_bytes(rng.integers(0, 65536, (6, 7), dtype=np.uint16)))
    if meta is not None:
        (folder / "scene.json").write_text(meta if isinstance(meta, str) else json.dumps(meta))
    return folder


def test_band_declaring_a_bomb_size_is_refused_naming_it(tmp_path, strict):
    # was: PIL.Image.DecompressionBombError from Image.open
    band = _patched_ihdr(_image_bytes(np.zeros((6, 7), np.uint16)), width=100_000, height=100_000)
    folder = _toy_folder(tmp_path / "toy_ms", bands={4: band})
    with pytest.raises(FileFormatError, match=r"^toy_ms: toy_05.png: refused as a possible decompression bomb"):
        read_band_folder(folder)


def test_a_real_decompression_bomb_below_the_size_limit_is_never_decoded(tmp_path, strict):
    # was: Pillow's DecompressionBombWarning, then 144 MB decoded into a 1.1 GB cube
    folder = tmp_path / "one"
    folder.mkdir()
    (folder / "bomb.png").write_bytes(_real_bomb())
    (folder / "scene.json").write_text('{"wavelengths": [550]}')
    with pytest.raises(FileFormatError, match=r"^one: bomb.png: refused as a possible decompression bomb.*89,478,485"):
        read_band_folder(folder)
    (tmp_path / "photo.png").write_bytes(_real_bomb())
    with pytest.raises(FileFormatError, match=r"^photo.png: refused as a possible decompression bomb"):
        read_photo(tmp_path / "photo.png")


@pytest.mark.parametrize("meta, message", [
    ({"scale": [1, 2]}, "'scale' must be a number"),  # was: TypeError float() of a list
    ({"distance": {}}, "'distance' must be a number"),  # was: TypeError float() of a dict
    ({"distance": "far"}, "'distance' must be a number"),  # was: ValueError could not convert string to float
    ({"scale": 10**400}, "'scale' must be a finite positive number"),  # was: OverflowError in read_band_folder
    ({"angular_resolution": [1, 2, 3]}, "'angular_resolution' must hold 1 or 2"),  # was: ValueError from broadcast_to
    ({"files": 5}, "'files' must be a list"),  # was: TypeError 'int' object is not iterable
    ({"wavelengths": [10**400] + list(WLS[1:])}, "'wavelengths' holds 1 NaN or infinite"),  # was: OverflowError
    ({"wavelengths": [float("nan")] + list(WLS[1:])}, "'wavelengths' holds 1 NaN"),  # was: a NaN wavelength accepted
    ("[" * 100_000, "not valid JSON"),  # was: RecursionError from the JSON decoder
], ids=["scale-list", "distance-dict", "distance-text", "scale-huge-int", "ar-three", "files-int",
        "wavelength-huge-int", "wavelength-nan", "json-deep"])
def test_band_folder_json_fields_are_checked(tmp_path, strict, meta, message):
    if isinstance(meta, dict):
        meta = {"wavelengths": list(WLS), **meta}
    folder = _toy_folder(tmp_path / "toy_ms", meta)
    with pytest.raises(FileFormatError, match=rf"^toy_ms: scene.json: .*{re.escape(message)}"):
        read_band_folder(folder)


def _broken_chunk(a):
    """A PNG of ``a`` whose pixel data is split by a chunk of a name no PNG may have."""
    chunks = _png_chunks(_image_bytes(a))
    idat = chunks[1][1]
    return _png(chunks[:1] + [(b"IDAT", idat[:10]), (b"\0\1\2\3", b""), (b"IDAT", idat[10:]), chunks[-1]])


def test_a_broken_png_chunk_is_an_error_naming_the_file(tmp_path, strict):
    # was: SyntaxError "broken PNG file" from PngImagePlugin while decoding
    (tmp_path / "holiday.png").write_bytes(_broken_chunk(np.zeros((12, 16, 3), np.uint8)))
    with pytest.raises(FileFormatError, match=r"^holiday.png: not a readable image \(SyntaxError"):
        read_photo(tmp_path / "holiday.png")
    noise = np.random.default_rng(2).integers(0, 65536, (6, 7), dtype=np.uint16)  # pixel data longer than 10 bytes
    folder = _toy_folder(tmp_path / "toy_ms", bands={0: _broken_chunk(noise)})
    with pytest.raises(FileFormatError, match=r"^toy_ms: toy_01.png: not a readable PNG \(SyntaxError"):
        read_band_folder(folder)


def test_photo_declaring_a_bomb_size_is_refused_naming_it(tmp_path, strict):
    # was: PIL.Image.DecompressionBombError from Image.open
    (tmp_path / "x.png").write_bytes(_patched_ihdr(_image_bytes(np.zeros((4, 4, 3), np.uint8)), width=100_000, height=100_000))
    with pytest.raises(FileFormatError, match=r"^x.png: refused as a possible decompression bomb"):
        read_photo(tmp_path / "x.png")


def test_a_text_chunk_that_expands_too_far_is_an_error(tmp_path, strict):
    # was: ValueError "Decompressed data too large for PngImagePlugin.MAX_TEXT_CHUNK"
    chunks = _png_chunks(_image_bytes(np.zeros((4, 4, 3), np.uint8)))
    chunks.insert(1, (b"zTXt", b"k\0\0" + zlib.compress(b"a" * 2**24)))
    (tmp_path / "x.png").write_bytes(_png(chunks))
    with pytest.raises(FileFormatError, match=r"^x.png: not a readable image \(ValueError: Decompressed data too large"):
        read_photo(tmp_path / "x.png")


def test_a_palette_transparency_after_the_pixels_gives_no_warning(tmp_path, strict):
    # was: Pillow's UserWarning "Palette images with Transparency expressed in bytes should be converted to RGBA"
    rgb = np.random.default_rng(1).integers(0, 256, (6, 8, 3), dtype=np.uint8)
    chunks = _png_chunks(_image_bytes(rgb, mode="P"))
    chunks.insert(len(chunks) - 1, (b"tRNS", b"\0" * 5))  # after IDAT: read only with the pixels
    (tmp_path / "p.png").write_bytes(_png(chunks))
    expected = np.asarray(Image.open(io.BytesIO(_image_bytes(rgb, mode="P"))).convert("RGB")) / 255.0
    scene = read_photo(tmp_path / "p.png")
    assert scene.shape == (6, 8, 31)
    np.testing.assert_allclose(scene.data, scene_from_rgb(expected).data)


def _envi(tmp_path, edit=lambda t: t, data=None, interleave="bsq", dtype=np.float32, **meta):
    from spectral.io import envi

    hdr = tmp_path / "capture.hdr"
    cube = np.ones((5, 4, 3)) if data is None else data
    envi.save_image(str(hdr), cube.astype(dtype), ext=".img", interleave=interleave, force=True,
                    metadata={"wavelength": ["500", "550", "600"], "distance": "1", "angular resolution": ["50", "50"],
                              "data units": "W/sr/m^2 per band", **meta})
    hdr.write_text(edit(hdr.read_text()))
    return hdr


def test_envi_negative_header_offset_is_refused(tmp_path, strict):
    # was: ValueError "axes don't match array" (spectral's memmap failed and returned None, then transposed)
    hdr = _envi(tmp_path, lambda t: t.replace("header offset = 0", "header offset = -1"))
    with pytest.raises(FileFormatError, match=r"^capture.hdr: header field 'header offset' must be >= 0"):
        read_envi(hdr)


@pytest.mark.parametrize("values, message", [
    ("2147483648, 2147483649, 2147483650", "'wavelength' spans 2.14748e+09..2.14748e+09 nm"),
    ("nan, 550, 600", "'wavelength' holds NaN or infinite values")])
def test_envi_absurd_wavelengths_are_refused_naming_the_field(tmp_path, strict, values, message):
    # was: accepted (2**31 nm, NaN), then refused by Scene without naming the header's field
    hdr = _envi(tmp_path, lambda t: re.sub(r"wavelength = \{[^}]*\}", f"wavelength = {{{values}}}", t))
    with pytest.raises(FileFormatError, match=rf"^capture.hdr: {re.escape(message)}"):
        read_envi(hdr)


def test_envi_keys_in_capitals_are_read_without_a_warning(tmp_path, strict):
    # was: spectral's UserWarning "Parameters with non-lowercase names encountered and converted to lowercase"
    hdr = _envi(tmp_path, lambda t: t.replace("lines", "Lines").replace("data type", "Data Type"))
    assert read_envi(hdr).shape == (5, 4, 3)


def test_envi_signalling_nan_data_is_refused_without_a_numpy_warning(tmp_path, strict):
    # was: numpy's RuntimeWarning "invalid value encountered in cast" before the NaN were refused
    snan = np.frombuffer(b"\x01\x00\x80\x7f", "<f4")[0]
    hdr = _envi(tmp_path, data=np.full((5, 4, 3), snan, np.float32), interleave="bip")
    with pytest.raises(FileFormatError, match="radiance has 60 NaN or infinite values"):
        read_envi(hdr)


def test_errors_never_show_the_folder_a_file_was_read_from(tmp_path, strict):
    # was: every message began with the file's full path (an upload's temporary folder on a server)
    (tmp_path / "x.png").write_bytes(b"not an image")
    hdr = _envi(tmp_path, lambda t: t.replace("byte order = 0", "byte order = 7"))
    folder = _toy_folder(tmp_path / "toy_ms", {"wavelengths": list(WLS[::-1])})
    for call, name in ((lambda: read_photo(tmp_path / "x.png"), "x.png"), (lambda: read_envi(hdr), "capture.hdr"),
                       (lambda: read_band_folder(folder), "toy_ms")):
        with pytest.raises(FileFormatError) as info:
            call()
        assert str(info.value).startswith(f"{name}: ") and str(tmp_path) not in str(info.value)
    with pytest.raises(FileFormatError, match=r"^holiday.png: not a readable image \(not an image format Pillow knows\)$"):
        read_photo(tmp_path / "x.png", shown="holiday.png")
