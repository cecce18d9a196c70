"""``camsim calibrate RAW_DIR --out SCENE.npz [--mcc REGIONS.json] [--reference REFERENCE.csv] [--report REPORT_DIR]``.

From a raw hyperspectral capture (a folder of monochromatic planes, dark
frames and ``manifest.json``) to a calibrated scene (chapter section 2);
see :mod:`camsim_core.calibration`.
"""

from __future__ import annotations

import numpy as np


def register(subparsers):
    p = subparsers.add_parser(
        "calibrate",
        help="calibrate a raw hyperspectral capture into a scene (.npz)",
        description="Dark subtraction, registration to the 550 nm plane (binary edge maps, similarity), "
        "scatter correction with the Macbeth chart and radiometric calibration from a reference spectrum "
        "(chapter section 2). RAW_DIR holds manifest.json, the planes and the dark frames.",
    )
    p.add_argument("raw_dir", metavar="RAW_DIR", help="folder with manifest.json, the planes and the dark frames")
    p.add_argument("--out", required=True, metavar="SCENE.npz", help="calibrated scene to write (.npz)")
    p.add_argument("--mcc", metavar="REGIONS.json", help="chart patch, reference and white regions (default: the manifest's 'regions')")
    p.add_argument("--reference", metavar="REFERENCE.csv", help="reference spectrum, wavelength,radiance per nm (default: the manifest's 'reference')")
    p.add_argument("--report", metavar="REPORT_DIR", help="write Figures 1.3-1.5 and calibration.json here")
    p.add_argument("--no-registration", action="store_true", help="skip registration (planes already aligned)")
    p.set_defaults(func=run)


def _check_text_file(path, flag):
    """Refuse ``path`` for ``flag`` unless it is a readable UTF-8 text file (the regions JSON, the reference CSV)."""
    import codecs
    from pathlib import Path

    from ..errors import ParameterError

    p = Path(path)
    if not p.is_file():
        raise ParameterError(flag, f"{path}: no such file" if not p.exists() else f"{path} is not a regular file")
    try:
        with p.open("rb") as f:  # the first MiB (a character cut at its end is not an error): enough to tell text from binary
            codecs.getincrementaldecoder("utf-8")().decode(f.read(1 << 20), final=False)
    except OSError as exc:
        raise ParameterError(flag, f"{path}: cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise ParameterError(flag, f"{path}: not a UTF-8 text file (byte {exc.start}: {exc.reason})") from None


def run(args):
    from pathlib import Path

    from ..calibration import calibrate
    from ..errors import ParameterError
    from . import check_output

    check_output(args.out, "--out", suffixes=(".npz",))
    for flag, path in (("--mcc", args.mcc), ("--reference", args.reference)):
        if path is not None:
            _check_text_file(path, flag)
    if args.report:
        report = Path(args.report)
        if report.exists() and not report.is_dir():
            raise ParameterError("--report", f"{report} exists and is not a folder")
        if not report.exists() and not (report.parent if str(report.parent) else Path(".")).is_dir():
            raise ParameterError("--report", f"folder {report.parent} does not exist")
    res = calibrate(args.raw_dir, args.out, mcc=args.mcc, reference=args.reference, report=args.report, register=not args.no_registration)
    reg = [r for r in res.registration if np.isfinite(r.residual)]
    h, w, n = res.scene.data.shape
    print(f"wrote {args.out}: {h} x {w} px, {n} planes {res.scene.wavelengths[0]:g}-{res.scene.wavelengths[-1]:g} nm")
    if reg:
        worst = max(reg, key=lambda r: r.residual)
        print(f"registration: edge residual rms up to {worst.residual:.3f} px; interior covered by all planes {res.extra.get('interior_box')}")
    if res.intercept is not None:
        print(f"scatter correction: intercepts {res.intercept.min():.4g} to {res.intercept.max():.4g} counts subtracted")
    if res.clipped:
        print(f"{res.clipped} negative values clipped to 0")
    comp = res.extra.get("comparison")
    if comp is not None and len(comp["names"]) > 1:
        print(f"image against measured spectra: slope {comp['slope']:.3f} over {len(comp['names'])} regions")
    if args.report:
        print(f"report in {args.report}")
    return 0
