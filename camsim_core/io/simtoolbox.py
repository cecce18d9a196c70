"""Readers for the original simulator's text files: ``.Simg``, ``.Scam``, ``.Smon``, ``.dat``.

Hand-written: no library reads this format. The files (see
``assets/simtoolbox/README.md``) hold tagged sections:

* ``#SimName`` opens a section whose value is the following lines, up to
  ``#SimEnd`` (or ``#SimEndComments``) or the next tag; ``#SimName value``
  may also carry its value on the same line (the older ``.dat`` files);
* ``##SimName`` is a field of the section above it (``##SimEnd`` closes the
  group);
* ``#Sim#Name`` opens a matrix: ``rows cols`` then ``rows * cols`` numbers
  in row order; ``#Sim#Alg NAME`` lists one pipeline stage;
* ``#!#Sim...`` are headings and any other ``#`` line is a comment.

Line endings may be CR (classic Mac), LF or CRLF.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import FileFormatError
from .files import MAX_TEXT_BYTES, read_regular

__all__ = ["parse_tags", "read_tagged", "TaggedFile", "group_numbers", "group_number", "checked_number", "matrix",
           "checked_sensitivities", "wavelength_sampling", "checked_wavelengths", "MAX_SAMPLES", "MAX_WAVELENGTH"]

_SPLIT = re.compile(r"\r\n|\r|\n")


class TaggedFile(dict):
    """Parsed sections of a tagged file; ``require`` gives clear errors for missing tags."""

    def __init__(self, path, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.path = Path(path)

    def _find(self, name):
        for key in self:
            if key.lower() == name.lower():
                return key
        return None

    def has(self, name):
        return self._find(name) is not None

    def get_tag(self, name, default=None):
        key = self._find(name)
        return default if key is None else self[key]

    def require(self, name, what="value"):
        key = self._find(name)
        if key is None:
            raise FileFormatError(self.path, f"required tag #Sim{name} is missing ({what})")
        return self[key]

    def number(self, name, default=None, required=False, *, integer=False, positive=False, minimum=None, maximum=None):
        """One finite number from a section or a field (see :func:`checked_number` for the checks)."""
        value = self.require(name) if required else self.get_tag(name)
        if value is None:
            return default
        v = _first_number(self.path, name, value)
        return checked_number(self.path, f"#Sim{name}", [v], integer=integer, positive=positive, minimum=minimum,
                              maximum=maximum)

    def text(self, name, default=""):
        value = self.get_tag(name)
        if value is None:
            return default
        if isinstance(value, list):
            return "\n".join(value).strip()
        return str(value)


def _numbers(path, name, lines):
    tokens = " ".join(lines if isinstance(lines, list) else [str(lines)]).split()
    try:
        values = np.array([float(t) for t in tokens], dtype=float)
    except ValueError as exc:
        raise FileFormatError(path, f"tag #Sim{name} should hold numbers: {exc}") from None
    if not np.all(np.isfinite(values)):
        raise FileFormatError(path, f"tag #Sim{name} holds NaN or infinite values; expected finite numbers")
    return values


def _first_number(path, name, value):
    if isinstance(value, dict):
        raise FileFormatError(path, f"tag #Sim{name} should be a number, found a group")
    if isinstance(value, np.ndarray):
        arr = value.ravel()
    else:
        arr = _numbers(path, name, value)
    if arr.size == 0:
        raise FileFormatError(path, f"tag #Sim{name} is empty, expected a number")
    return float(arr[0])


def group_numbers(tagged, group, field, required=True):
    """Numbers of field ``##Sim<field>`` inside group ``<group>``."""
    g = tagged.require(group) if required else tagged.get_tag(group)
    if g is None:
        return None
    if not isinstance(g, dict):
        raise FileFormatError(tagged.path, f"#Sim{group} should be a group of ##Sim fields")
    for key, value in g.items():
        if key.lower() == field.lower():
            return _numbers(tagged.path, f"{group}/{field}", value)
    if required:
        raise FileFormatError(tagged.path, f"required field ##Sim{field} of #Sim{group} is missing")
    return None


def group_number(tagged, group, field, *, integer=False, positive=False, minimum=None, maximum=None, required=True):
    """The first number of field ``##Sim<field>`` of ``group``, checked.

    ``integer`` refuses fractions (a height of 2.5 is an error, never
    truncated), ``positive`` refuses zero and negatives, ``minimum`` and
    ``maximum`` set inclusive bounds. Returns ``None`` for a missing optional field.
    """
    values = group_numbers(tagged, group, field, required=required)
    if values is None:
        return None
    return checked_number(tagged.path, f"#Sim{group} ##Sim{field}", values, integer=integer, positive=positive,
                          minimum=minimum, maximum=maximum)


def checked_number(path, where, values, *, integer=False, positive=False, minimum=None, maximum=None):
    """The first of ``values`` (finite), checked as in :func:`group_number`.

    Parameters
    ----------
    path : path or str
        The file every error names.
    where : str
        The tag or field every error names (e.g. ``"#SimHeight"``).
    values : array_like
        Numbers; the first is checked and returned.
    integer, positive : bool
        Refuse fractions / zero and negatives.
    minimum, maximum : float, optional
        Inclusive bounds.

    Returns
    -------
    int or float
        An int when ``integer``.

    Raises
    ------
    FileFormatError
        Naming ``path`` and ``where``.
    """
    arr = np.asarray(values, float).ravel()
    if arr.size == 0:
        raise FileFormatError(path, f"{where} is empty, expected a number")
    v = float(arr[0])
    if not np.isfinite(v):
        raise FileFormatError(path, f"{where} is {v}, expected a finite number")
    if integer and v != round(v):
        raise FileFormatError(path, f"{where} is {v:g}, expected a whole number")
    if positive and v <= 0:
        raise FileFormatError(path, f"{where} is {v:g}, expected a positive number")
    if minimum is not None and v < minimum:
        raise FileFormatError(path, f"{where} is {v:g}, expected at least {minimum:g}")
    if maximum is not None and v > maximum:
        raise FileFormatError(path, f"{where} is {v:g}, expected at most {maximum:g}")
    return int(round(v)) if integer else v


def matrix(tagged, name, what="values"):
    """The ``#Sim#<name>`` matrix of ``tagged`` (a 2-D float array), or a FileFormatError naming the file and tag.

    A tag written as a section or a group (not ``#Sim#`` with ``rows cols``)
    is refused, as is a missing one.
    """
    value = tagged.require(name, what)
    if not isinstance(value, np.ndarray) or value.ndim != 2:
        raise FileFormatError(tagged.path, f"#Sim#{name} must be a matrix ('#Sim#{name}', then 'rows cols' and the values)")
    return value


def checked_sensitivities(path, where, values, names, wavelengths, unit="Watts"):
    """Spectral sensitivities (K, N) of a file, refused unless physical.

    Every value must be finite and >= 0 (a sensor cannot record negative
    light), every sensor must respond somewhere (an all-zero row records
    nothing), and quantum efficiencies (``unit="Quanta"``) must be at most 1.

    Parameters
    ----------
    path : path or str
        The file every error names.
    where : str
        The tag every error names.
    values : ndarray (K, N)
    names : sequence of str
        The sensors' names (K).
    wavelengths : ndarray (N,)
        nm.
    unit : "Watts" or "Quanta"

    Returns
    -------
    ndarray (K, N)
        ``values`` unchanged.

    Raises
    ------
    FileFormatError
        Naming ``path``, ``where``, the sensor and the wavelength.
    """
    v = np.asarray(values, float)
    if not np.all(np.isfinite(v)):
        raise FileFormatError(path, f"{where} holds NaN or infinite values; expected finite sensitivities")
    if v.size and v.min() < 0:
        k, j = np.unravel_index(np.argmin(v), v.shape)
        raise FileFormatError(path, f"{where}: sensitivities must be >= 0; sensor {names[k]} is {v[k, j]:g} at {wavelengths[j]:g} nm")
    dead = [names[k] for k in range(v.shape[0]) if not np.any(v[k] > 0)]
    if dead:
        raise FileFormatError(path, f"{where}: sensor {', '.join(dead)} is 0 at every wavelength (it would record nothing)")
    if unit == "Quanta" and v.size and v.max() > 1:
        k, j = np.unravel_index(np.argmax(v), v.shape)
        raise FileFormatError(path, f"{where}: quantum efficiencies must be at most 1; sensor {names[k]} is {v[k, j]:g} at "
                                    f"{wavelengths[j]:g} nm")
    return v


def parse_tags(text, path="<text>"):
    """Parse the tagged text format into a :class:`TaggedFile`.

    Sections map to a list of text lines, groups to a dict of field -> lines,
    matrices to a 2-D float array, and ``Alg`` to the list of stage names.
    """
    out = TaggedFile(path)
    lines = _SPLIT.split(text)
    section = None  # name of the open #Sim section (its value: list of lines)
    group = None  # name of the open group (dict)
    field = None  # name of the open ##Sim field in the group
    i = 0
    n = len(lines)
    while i < n:
        raw = lines[i]
        s = raw.strip()
        i += 1
        if s.startswith("#Sim#"):
            body = s[5:].split(None, 1)
            name = body[0] if body else ""
            rest = body[1].strip() if len(body) > 1 else ""
            section = group = field = None
            if name == "Alg":
                out.setdefault("Alg", []).append(rest)
                continue
            if name.startswith("Alg"):  # '#Sim#AlgSimWeightRawImages' in the .dat files
                out.setdefault("Alg", []).append(name[3:])
                continue
            header = rest
            while not header and i < n:
                header = lines[i].strip()
                i += 1
            dims = header.split()
            try:
                rows, cols = float(dims[0]), float(dims[1])
                values = [float(v) for v in dims[2:]]
            except (IndexError, ValueError):
                raise FileFormatError(path, f"matrix #Sim#{name} should start with 'rows cols', found {header!r}") from None
            if not all(np.isfinite(d) and d >= 0 and d == int(d) for d in (rows, cols)):
                raise FileFormatError(path, f"matrix #Sim#{name} has size {header!r}; expected two whole numbers >= 0")
            rows, cols = int(rows), int(cols)
            need = rows * cols
            while len(values) < need and i < n:
                t = lines[i].strip()
                if t.startswith("#"):
                    break
                i += 1
                try:
                    values.extend(float(v) for v in t.split())
                except ValueError:
                    raise FileFormatError(path, f"matrix #Sim#{name}: non-numeric line {t!r}") from None
            if len(values) < need:
                raise FileFormatError(path, f"matrix #Sim#{name} is truncated: {len(values)} of {rows} x {cols} values")
            matrix = np.array(values[:need], dtype=float).reshape(rows, cols)
            if not np.all(np.isfinite(matrix)):
                raise FileFormatError(path, f"matrix #Sim#{name} holds NaN or infinite values; expected finite numbers")
            out[name] = matrix
            continue
        if s.startswith("##Sim"):
            body = s[5:].split(None, 1)
            name = body[0] if body else ""
            rest = body[1].strip() if len(body) > 1 else ""
            if name == "End":
                group = field = None
                section = None
                continue
            if group is None:
                if section is not None and not out.get(section):
                    # '#SimangularResolution' then '##Simx 55.93': the section becomes a group
                    group = section
                    out[group] = {}
                else:
                    group = name
                    out[group] = {}
                    section = None
                    field = None
                    if not rest:
                        continue
                    # a lone '##SimType value' line with no open group: store flat
                    out[name] = [rest]
                    group = None
                    continue
            section = None
            field = name
            out[group][field] = [rest] if rest else []
            continue
        if s.startswith("#!#"):
            continue
        if s.startswith("#Sim"):
            body = s[4:].split(None, 1)
            name = body[0] if body else ""
            rest = body[1].strip() if len(body) > 1 else ""
            group = field = None
            if name in ("End", "EndComments"):
                section = None
                continue
            section = name
            out[section] = [rest] if rest else []
            continue
        if s.startswith("#") and section != "Comments":
            continue
        if not s:
            continue
        if field is not None and group is not None:
            out[group][field].append(s)
        elif section is not None:
            out[section].append(s)
    return out


def read_tagged(path, shown=None):
    """Read and parse a tagged file; a missing, special or oversized file gets a clear error.

    ``shown`` is the name the user knows the file by (default: ``path``); it
    is the one every error names.
    """
    p = Path(path)
    raw = read_regular(p, max_bytes=MAX_TEXT_BYTES, shown=shown)
    return parse_tags(raw.decode("latin-1"), path=p if shown is None else shown)


#: Most wavelength samples a file may declare (a guard against absurd headers, not a physical limit).
MAX_SAMPLES = 4096


def wavelength_sampling(tagged, group="WavelengthSampling"):
    """Wavelengths (nm) of group ``#Sim<group>`` (``##SimStart``, ``##SimStep``, ``##SimNumberSamples``), checked.

    Start and step must be finite and positive, the count a whole number
    from 1 to :data:`MAX_SAMPLES`.
    """
    start = group_number(tagged, group, "Start", positive=True)
    step = group_number(tagged, group, "Step", positive=True)
    count = group_number(tagged, group, "NumberSamples", integer=True, positive=True)
    if count > MAX_SAMPLES:
        raise FileFormatError(tagged.path, f"#Sim{group} ##SimNumberSamples is {count}, more than {MAX_SAMPLES}")
    return checked_wavelengths(tagged.path, f"#Sim{group}", start, step, count)


#: Longest wavelength a file may sample, nm (far infrared; a guard against overflowing samplings).
MAX_WAVELENGTH = 1e6


def checked_wavelengths(path, where, start, step, count):
    """``start + step * arange(count)`` (nm), refused unless every sample is finite and at most :data:`MAX_WAVELENGTH`,
    and the samples strictly increase (a step too small to change ``start`` in floating point is refused)."""
    last = start + step * (count - 1)
    if not np.isfinite(last) or last > MAX_WAVELENGTH:
        raise FileFormatError(path, f"{where} samples up to {last:g} nm; expected at most {MAX_WAVELENGTH:g} nm")
    w = start + step * np.arange(count)
    if count > 1 and not np.all(np.diff(w) > 0):
        raise FileFormatError(path, f"{where}: a step of {step:g} nm from {start:g} nm does not separate the samples")
    return w
