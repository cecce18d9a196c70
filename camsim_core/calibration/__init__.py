"""From a raw hyperspectral capture to a calibrated scene (chapter section 2).

:func:`calibrate` runs the chapter's steps in order:

1. read the folder and its manifest (:mod:`.manifest`);
2. dark subtraction, same exposure time (:mod:`.dark`);
3. registration of every plane to the 550 nm plane by binary edge maps,
   similarity model (:mod:`.registration`);
4. affine scatter correction with the Macbeth chart, ``c = m r + b``,
   subtract ``b`` (:mod:`.scatter`);
5. radiometric factors from a reference spectrum of one region, and the
   illuminant from a white reference when given (:mod:`.radiometric`);

and returns a :class:`CalibrationResult` whose ``scene`` camsim loads
directly; :mod:`.report` draws Figures 1.3-1.5, :mod:`.evaluation` compares
image and measured spectra (Figure 1.5's slope), and :mod:`.synthetic` makes
raw captures from a calibrated scene for round-trip tests.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FileFormatError, ParameterError
from ..scene import Scene, save_npz_scene
from ..spectra import Spectrum
from .dark import subtract_darks
from .evaluation import region_comparison, slope_through_origin
from .manifest import Manifest, load_frames, read_manifest
from .radiometric import calibration_factors, read_reference_csv, reference_per_band
from .regions import Regions, check_inside, read_regions
from .registration import RegistrationResult, Similarity, coverage, register_planes, warp_plane
from .scatter import fit_scatter, macbeth_reflectances, region_means

__all__ = ["calibrate", "CalibrationResult", "calibrate_planes", "Similarity"]


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """Everything :func:`calibrate` found.

    Attributes
    ----------
    scene : Scene
        Calibrated radiance, W/sr/m^2 per band of the plane sampling.
    registration : list of RegistrationResult
        Per plane: the similarity taking the 550 nm frame to the plane, the
        rms residual (px) of its edge fit and the fraction of edges matched.
    slope, intercept : (N,) or None
        The scatter regression ``c = m r + b`` per plane (counts); ``b`` was subtracted.
    factors : (N,)
        W/sr/m^2 per band per count after scatter correction.
    valid : (H, W) bool
        Pixels every plane covers after registration (outside, the nearest
        border value was repeated).
    raw : (N, H, W)
        Dark-subtracted planes before registration (for Figure 1.3).
    manifest : Manifest or None
    regions : Regions or None
    reference : (N,) reference spectrum per band, and ``clipped``: negative values set to 0.
    """

    scene: Scene
    registration: list
    slope: np.ndarray | None
    intercept: np.ndarray | None
    factors: np.ndarray
    valid: np.ndarray
    raw: np.ndarray
    reference: np.ndarray
    clipped: int
    manifest: Manifest | None = None
    regions: Regions | None = None
    extra: dict = field(default_factory=dict)


def _interior_box(valid):
    """The box ``[top, left, bottom, right]`` left by the smallest uniform border trim inside ``valid``."""
    h, w = valid.shape
    for m in range(min(h, w) // 2):
        if valid[m : h - m, m : w - m].all():
            return [m, m, h - m, w - m]
    return None


def calibrate_planes(
    planes,
    wavelengths,
    *,
    regions,
    reference,
    reference_wavelength=550.0,
    register=True,
    distance=1.0,
    angular_resolution=(57.3, 57.3),
    name="calibrated",
    sigma=1.0,
):
    """Calibrate dark-subtracted planes (N, H, W): registration, scatter, radiometric factors.

    ``reference`` is the reference spectrum per plane band (W/sr/m^2 per
    band, see :func:`.radiometric.reference_per_band`) measured in
    ``regions.reference``. Returns a :class:`CalibrationResult`.
    """
    planes = np.asarray(planes, float)
    wls = np.asarray(wavelengths, float)
    n, h, w = planes.shape
    check_inside(regions, (h, w))
    if regions.reference is None:
        raise FileFormatError(regions.source, "'reference' (the box the spectroradiometer measured) is required for radiometric calibration")
    if register:
        reg = register_planes(planes, wls, reference_wavelength, sigma=sigma)
    else:
        c = ((h - 1) / 2.0, (w - 1) / 2.0)
        reg = [RegistrationResult(Similarity(center=c), float("nan"), float("nan"), 0) for _ in range(n)]
    aligned = np.stack([warp_plane(p, r.transform) for p, r in zip(planes, reg)])
    valid = np.logical_and.reduce([coverage((h, w), r.transform) for r in reg])

    slope = intercept = None
    if regions.patches:
        idx = sorted(regions.patches)
        means = region_means(aligned, [regions.patches[k] for k in idx])
        slope, intercept = fit_scatter(means, macbeth_reflectances(wls, idx))
        aligned = aligned - intercept[:, None, None]
    else:
        warnings.warn("no chart patches given: scatter correction skipped", stacklevel=2)

    ref_values = region_means(aligned, [regions.reference])[0]
    factors = calibration_factors(ref_values, reference, wls)
    cube = np.moveaxis(aligned * factors[:, None, None], 0, -1)
    neg = cube < 0
    clipped = int(np.count_nonzero(neg))
    if clipped:
        cube = np.where(neg, 0.0, cube)

    illum = None
    if regions.white is not None:
        white = region_means(np.moveaxis(cube, -1, 0), [regions.white])[0]
        if regions.white_reflectance is not None:
            refl = np.broadcast_to(np.asarray(regions.white_reflectance, float), wls.shape)
        elif regions.white_patch is not None:
            refl = macbeth_reflectances(wls, [regions.white_patch])[0]
        else:
            refl = np.ones_like(wls)
        illum = Spectrum(wls, white / refl, "estimated from the white reference")
    box = _interior_box(valid)
    comments = (
        f"Calibrated from a raw capture (camsim calibrate): dark subtraction, registration to {reference_wavelength:g} nm "
        f"({'similarity on binary edge maps' if register else 'none'}), "
        f"{'scatter correction on ' + str(len(regions.patches)) + ' chart patches' if regions.patches else 'no scatter correction'}, "
        f"radiometric factors from the reference region {list(regions.reference)}. "
        f"Pixels covered by every plane: box {box}. Negative values clipped: {clipped}."
    )
    scene = Scene(cube, wls, distance, angular_resolution, "W/sr/m^2 per band", illum, name, comments)
    return CalibrationResult(scene, reg, slope, intercept, factors, valid, planes, np.asarray(reference, float), clipped, None, regions, {"interior_box": box})


def calibrate(raw_dir, out=None, *, mcc=None, reference=None, report=None, register=True):
    """Calibrate the raw capture in ``raw_dir`` (see :mod:`.manifest`) and optionally write it.

    Parameters
    ----------
    raw_dir : path
        Folder with ``manifest.json``, the planes and the dark frames.
    out : path, optional
        ``.npz`` scene to write (atomically, and only when every step succeeded).
    mcc : path, optional
        ``REGIONS.json`` (:mod:`.regions`); default: the manifest's ``regions``.
    reference : path, optional
        Reference spectrum CSV (:func:`.radiometric.read_reference_csv`);
        default: the manifest's ``reference``.
    report : path, optional
        Folder for the evaluation figures and a JSON summary (:mod:`.report`).
    register : bool
        False skips registration (identity transforms).

    Returns
    -------
    CalibrationResult
    """
    if out is not None and Path(out).suffix.lower() != ".npz":
        raise ParameterError("out", f"{out}: the calibrated scene is written as .npz")
    man = read_manifest(raw_dir)
    mcc = mcc if mcc is not None else man.regions
    reference = reference if reference is not None else man.reference
    if mcc is None:
        raise ParameterError("mcc", "no regions file: give --mcc REGIONS.json (chart patches and the reference region) or 'regions' in the manifest")
    if reference is None:
        raise ParameterError("reference", "no reference spectrum: give --reference REFERENCE.csv or 'reference' in the manifest")
    regions = read_regions(mcc)
    ref_w, ref_v = read_reference_csv(reference)
    for _, _, csv_path in regions.measured:
        read_reference_csv(csv_path)  # fail early, before any work
    frames, darks = load_frames(man)
    check_inside(regions, frames.shape[1:])
    wls = man.wavelengths
    planes = subtract_darks(frames, [p.exposure for p in man.planes], darks, wls)
    ref = reference_per_band(ref_w, ref_v, wls)
    result = calibrate_planes(
        planes,
        wls,
        regions=regions,
        reference=ref,
        reference_wavelength=man.reference_wavelength,
        register=register,
        distance=man.distance,
        angular_resolution=man.angular_resolution,
        name=man.name,
    )
    names, boxes, spectra = ["reference region"], [regions.reference], [ref]
    for rname, box, csv_path in regions.measured:
        mw, mv = read_reference_csv(csv_path)
        names.append(rname)
        boxes.append(box)
        spectra.append(reference_per_band(mw, mv, wls))
    image, measured = region_comparison(result.scene, boxes, np.stack(spectra))
    comparison = {"names": names, "image": image, "measured": measured, "slope": slope_through_origin(measured, image)}
    result = CalibrationResult(**{**result.__dict__, "manifest": man, "extra": {**result.extra, "comparison": comparison}})
    if report is not None:
        from .report import write_report

        write_report(result, report)
    if out is not None:
        save_npz_scene(result.scene, out)
    return result
