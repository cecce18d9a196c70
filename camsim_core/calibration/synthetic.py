"""Raw hyperspectral captures made from a calibrated scene, for round-trip tests of :func:`calibrate`.

The forward model inverts the chapter's calibration steps: plane ``k`` at
pixel ``q`` of its own frame holds

    counts_k(q) = gain_k * L_k(T_k^{-1}(q)) + veil_k + dark_e(q)

with ``L_k`` the scene radiance (per band), ``T_k`` the similarity taking the
scene (550 nm) frame into plane ``k`` (camera motion, refocus
magnification), ``veil_k`` a uniform scattered-light offset and ``dark_e``
the dark frame of the plane's exposure time (a level plus a fixed pixel
pattern). Counts are rounded to 16-bit integers. Outside the scene the
nearest border value is repeated. The scene should be smooth at the pixel
scale (as any optics make it), or the two interpolations of a round trip
(here, and in registration) dominate the error.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from .manifest import MANIFEST_NAME
from .radiometric import band_widths
from .registration import Similarity, warp_plane

__all__ = ["random_transforms", "raw_captures"]


def random_transforms(n, shape, *, seed=0, max_shift=3.0, max_angle_deg=1.0, max_scale=0.015):
    """``n`` random similarities about the centre of ``shape`` (uniform in the given ranges)."""
    rng = np.random.default_rng(seed)
    h, w = shape[:2]
    c = ((h - 1) / 2.0, (w - 1) / 2.0)
    return [
        Similarity(
            float(rng.uniform(-max_shift, max_shift)),
            float(rng.uniform(-max_shift, max_shift)),
            float(np.radians(rng.uniform(-max_angle_deg, max_angle_deg))),
            float(1.0 + rng.uniform(-max_scale, max_scale)),
            c,
        )
        for _ in range(n)
    ]


def _write(path, counts, fmt):
    a = counts.astype(np.uint16)
    if fmt == "tiff":
        import tifffile

        tifffile.imwrite(path, a, photometric="minisblack")
    elif fmt == "png":
        from PIL import Image

        Image.fromarray(a).save(path, format="PNG")
    elif fmt == "raw-be16":
        Path(path).write_bytes(a.astype(">u2").tobytes())
    else:
        raise ParameterError("fmt", f"expected tiff, png or raw-be16, got {fmt!r}")


def raw_captures(
    scene,
    folder,
    *,
    transforms=None,
    gains=None,
    dark_levels=None,
    veils=None,
    exposures=None,
    f_stops=None,
    dark_pattern=20.0,
    fmt="tiff",
    seed=0,
    regions=None,
    reference_box=None,
    reference_wavelength=550.0,
):
    """Write a raw capture of ``scene`` into ``folder`` (planes, darks, ``manifest.json``).

    Parameters
    ----------
    scene : Scene
    folder : path (created)
    transforms : list of Similarity (N,), default identity
        Each plane's motion; the plane at ``reference_wavelength`` should be
        the identity (the frame the calibration returns to).
    gains : (N,) counts per unit radiance (default: 30000 / the plane's maximum)
    dark_levels : (N,) counts (default 200); one dark frame per plane, each plane its own exposure
    veils : (N,) counts of uniform scattered light (default 0)
    exposures, f_stops : (N,) s and f-number (recorded in the manifest; default 0.1 * (k + 1) s, f/8)
    dark_pattern : float
        Standard deviation (counts) of the dark frames' fixed pixel pattern.
    fmt : "tiff", "png" or "raw-be16"
    regions : dict, optional
        Written as ``regions.json`` and named in the manifest.
    reference_box : (top, left, bottom, right), optional
        Writes ``reference.csv``: the scene's mean radiance in the box, per
        nm (what a spectroradiometer would report), named in the manifest.

    Returns
    -------
    dict with the truth: ``transforms``, ``gains``, ``dark_levels``, ``veils``, ``exposures``.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    data = np.moveaxis(np.asarray(scene.data, float), -1, 0)
    n, h, w = data.shape
    wls = np.asarray(scene.wavelengths, float)
    c = ((h - 1) / 2.0, (w - 1) / 2.0)
    transforms = list(transforms) if transforms is not None else [Similarity(center=c)] * n
    gains = np.asarray(gains, float) if gains is not None else 30000.0 / np.maximum(data.reshape(n, -1).max(axis=1), 1e-300)
    dark_levels = np.broadcast_to(np.asarray(200.0 if dark_levels is None else dark_levels, float), (n,))
    veils = np.broadcast_to(np.asarray(0.0 if veils is None else veils, float), (n,))
    exposures = np.asarray(exposures, float) if exposures is not None else 0.1 * (np.arange(n) + 1)
    f_stops = np.broadcast_to(np.asarray(8.0 if f_stops is None else f_stops, float), (n,))
    if len(transforms) != n or gains.shape != (n,) or exposures.shape != (n,):
        raise ParameterError("raw_captures", f"transforms, gains and exposures need one entry per plane ({n})")
    rng = np.random.default_rng(seed)
    suffix = {"tiff": ".tif", "png": ".png", "raw-be16": ""}[fmt]
    planes, darks = [], []
    for k in range(n):
        dark = dark_levels[k] + dark_pattern * rng.standard_normal((h, w))
        signal = gains[k] * warp_plane(data[k], transforms[k].inverse())
        counts = np.round(signal + veils[k] + dark)
        dark_counts = np.round(dark)
        if counts.min() < 0 or counts.max() > 65535 or dark_counts.min() < 0:
            raise ParameterError("gains", f"the {wls[k]:g} nm plane does not fit 16 bits (counts {counts.min():g}-{counts.max():g})")
        name, dname = f"{int(round(wls[k]))}{suffix}", f"dark_{k:02d}{suffix}"
        _write(folder / name, counts, fmt)
        _write(folder / dname, dark_counts, fmt)
        planes.append({"wavelength": float(wls[k]), "exposure": float(exposures[k]), "f_stop": float(f_stops[k]), "file": name})
        darks.append({"exposure": float(exposures[k]), "file": dname})
    manifest = {
        "format": fmt,
        "reference_wavelength": reference_wavelength,
        "distance": scene.distance,
        "angular_resolution": list(scene.angular_resolution),
        "name": scene.name,
        "planes": planes,
        "darks": darks,
    }
    if fmt == "raw-be16":
        manifest.update(height=h, width=w)
    if regions is not None:
        (folder / "regions.json").write_text(json.dumps(regions, indent=1))
        manifest["regions"] = "regions.json"
    if reference_box is not None:
        t, l, b, r = reference_box
        per_band = data[:, t:b, l:r].mean(axis=(1, 2))
        per_nm = per_band / band_widths(wls)
        lines = ["# unit: W/sr/m^2/nm", "wavelength,radiance"] + [f"{x:g},{y:.10g}" for x, y in zip(wls, per_nm)]
        (folder / "reference.csv").write_text("\n".join(lines) + "\n")
        manifest["reference"] = "reference.csv"
    (folder / MANIFEST_NAME).write_text(json.dumps(manifest, indent=1))
    return {"transforms": transforms, "gains": gains, "dark_levels": dark_levels, "veils": veils, "exposures": exposures}
