"""colour-science's datasets that camsim uses at run time, shipped as one table file.

camsim takes its colour-matching functions, cone fundamentals, CIE illuminants,
ColorChecker reflectances, display primaries and basis functions from
colour-science [1]_. Importing colour-science costs 1.5-2 s of CPU (it imports
matplotlib through ``colour.plotting``), which every explorer server, upload
reader and command paid before its first ideal image. The arrays it would read
are therefore shipped in ``assets/colour-science/tables.npz``, written from
colour-science by :func:`write_tables` (``python -m
camsim_core.datasets.colour_science``) and read here in a few milliseconds. The
test suite compares every table with colour-science's own to the bit, so the
copy cannot drift from the library; its version is recorded in the file.

Also here, because the same tables serve them: :func:`xyz_to_srgb`, CIE XYZ
to sRGB, and :func:`srgb_to_linear`, the sRGB decoding (IEC 61966-2-1 [2]_),
written out (a matrix and the standard's two formulas) rather than
``colour.XYZ_to_sRGB`` and ``colour.cctf_decoding`` for the same reason; the
tests check them against colour-science.

References
----------
.. [1] Mansencal, T. et al., *Colour* (colour-science), BSD-3-Clause,
   https://www.colour-science.org/ (version in the table file).
.. [2] IEC 61966-2-1:1999, *Multimedia systems and equipment - Colour
   measurement and management - Part 2-1: Default RGB colour space - sRGB*.

Examples
--------
>>> from camsim_core.datasets.colour_science import table
>>> w, xyz = table("cie1931")
>>> float(w[0]), float(w[-1]), xyz.shape
(360.0, 830.0, (471, 3))
"""

from __future__ import annotations

import functools

import numpy as np

from . import asset_path

__all__ = ["TABLES", "table", "colourchecker_names", "xyz_to_srgb", "srgb_to_linear", "write_tables"]

#: The shipped tables: camsim's name -> (colour-science attribute path, key or keys), each read as
#: (wavelengths in nm, values (N,) or (N, K)).
TABLES = {
    "cie1931": ("MSDS_CMFS", "CIE 1931 2 Degree Standard Observer"),
    "stockman-sharpe": ("MSDS_CMFS", "Stockman & Sharpe 2 Degree Cone Fundamentals"),
    "D65": ("SDS_ILLUMINANTS", "D65"),
    "A": ("SDS_ILLUMINANTS", "A"),
    "crt-brainard-1997": ("MSDS_DISPLAY_PRIMARIES", "Typical CRT Brainard 1997"),
    "daylight-basis": ("colorimetry.datasets.illuminants.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES",
                       ("S0", "S1", "S2")),
    "mallett2019": ("recovery.MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019", None),
    "babelcolor": ("SDS_COLOURCHECKERS", "BabelColor Average"),
}

#: The file, inside the shipped data.
FILE = ("colour-science", "tables.npz")


def _from_colour(name):
    """(wavelengths, values) of table ``name`` read from colour-science itself (imports it)."""
    import colour

    attribute, key = TABLES[name]
    obj = colour
    for part in attribute.split("."):
        obj = getattr(obj, part)
    if name == "babelcolor":
        sds = obj[key]
        names = tuple(sds)
        return np.asarray(sds[names[0]].wavelengths, float), np.stack([sds[n].values for n in names], axis=1), names
    if isinstance(key, tuple):  # several spectral distributions on one sampling, as columns
        return np.asarray(obj[key[0]].wavelengths, float), np.stack([obj[k].values for k in key], axis=1), None
    data = obj if key is None else obj[key]
    return np.asarray(data.wavelengths, float), np.asarray(data.values, float), None


def write_tables(path=None):
    """Write every table of :data:`TABLES` from the installed colour-science to ``path`` (the shipped file
    by default); returns the path.

    Parameters
    ----------
    path : str or Path, optional
        Where to write the ``.npz``; by default ``assets/colour-science/tables.npz``.
    """
    import colour

    arrays = {"colour_version": np.array(colour.__version__)}
    for name in TABLES:
        w, v, names = _from_colour(name)
        arrays[f"{name}/wavelengths"], arrays[f"{name}/values"] = w, v
        if names is not None:
            arrays[f"{name}/names"] = np.array(names)
    cs = colour.RGB_COLOURSPACES["sRGB"]
    arrays["srgb/matrix_XYZ_to_RGB"] = np.asarray(cs.matrix_XYZ_to_RGB, float)
    out = asset_path(*FILE) if path is None else path
    np.savez_compressed(out, **arrays)
    return out


@functools.lru_cache(maxsize=1)
def _file():
    with np.load(asset_path(*FILE), allow_pickle=False) as f:
        out = {}
        for key in f.files:
            a = f[key]
            a.flags.writeable = False
            out[key] = a
        return out


def table(name):
    """(wavelengths, values) of a colour-science dataset camsim ships (see :data:`TABLES`).

    Parameters
    ----------
    name : str
        A key of :data:`TABLES`.

    Returns
    -------
    wavelengths : ndarray (N,)
        nm, as colour-science samples the dataset.
    values : ndarray (N,) or (N, K)
        The dataset's values (read-only): one column per function, primary or reflectance.

    Examples
    --------
    >>> w, spd = table("D65")
    >>> float(spd[w == 560][0])
    100.0
    """
    if name not in TABLES:
        from ..errors import ParameterError

        raise ParameterError("name", f"unknown colour-science table {name!r}; known: {', '.join(TABLES)}")
    f = _file()
    return f[f"{name}/wavelengths"], f[f"{name}/values"]


def colourchecker_names():
    """The 24 patch names of the BabelColor average ColorChecker, in the columns' order of ``table("babelcolor")``."""
    return tuple(str(n) for n in _file()["babelcolor/names"])


def xyz_to_srgb(xyz, encode=True):
    """CIE XYZ (D65, Y of white 1) to sRGB, IEC 61966-2-1 (the standard's matrix and encoding, unclipped).

    Written out rather than ``colour.XYZ_to_sRGB`` (the same numbers: the tests compare them) so that no
    process imports colour-science for it (see the module docstring).

    Parameters
    ----------
    xyz : array_like (..., 3)
        Tristimulus values, white Y = 1.
    encode : bool
        Apply the sRGB encoding (1.055 x^(1/2.4) - 0.055 above 0.0031308, 12.92 x at and below, negatives
        included); False gives linear RGB.

    Returns
    -------
    ndarray (..., 3)
        sRGB values (1 for the white), float64, not clipped.

    Examples
    --------
    >>> xyz_to_srgb([0.95047, 1.0, 1.08883]).round(3).tolist()
    [1.0, 1.0, 1.0]
    """
    rgb = np.asarray(xyz, float) @ _file()["srgb/matrix_XYZ_to_RGB"].T
    if not encode:
        return rgb
    return np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * np.power(np.maximum(rgb, 0.0031308), 1 / 2.4) - 0.055)


def srgb_to_linear(values):
    """sRGB decoding, IEC 61966-2-1: encoded values to linear light (``colour.cctf_decoding(v, "sRGB")``).

    Parameters
    ----------
    values : array_like
        Encoded sRGB values, [0, 1] for the gamut.

    Returns
    -------
    ndarray
        Linear values: v / 12.92 at and below 0.04045 (12.92 x 0.0031308), ((v + 0.055) / 1.055)^2.4 above.

    Examples
    --------
    >>> srgb_to_linear([0.0, 0.5, 1.0]).round(4).tolist()
    [0.0, 0.214, 1.0]
    """
    v = np.asarray(values, float)
    knee = 12.92 * 0.0031308
    return np.where(v <= knee, v / 12.92, np.power((np.maximum(v, knee) + 0.055) / 1.055, 2.4))


if __name__ == "__main__":
    print(write_tables())
