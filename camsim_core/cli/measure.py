"""``camsim measure``: MTF, SNR, chart colour accuracy and similarity of a camera, or MTF / SNR of an image file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__ = ["register", "run", "MAX_LUMINANCE"]

#: Highest luminance of ``--snr-vs-light``, cd/m^2: about the sun's disc (1.6e9); far beyond it the photon
#: counts overflow the noise generator.
MAX_LUMINANCE = 1e10


def register(subparsers):
    p = subparsers.add_parser(
        "measure",
        help="measure MTF, SNR, colour accuracy of a camera (or of an image file)",
        description="Simulate CAMERA on SCENE and measure it: slanted-edge MTF (scene slanted-edge), SNR (uniform), "
        "per-patch CIEDE2000 (macbeth), PSNR/SSIM/dE against the ideal image (any scene); or measure an existing "
        "image file (--image: a DNG or camera raw, a PNG or TIFF).",
    )
    p.add_argument("--scene", help="scene or chart name, or a scene file (default slanted-edge)")
    p.add_argument("--camera", default="kodak-dcs200-ir", help="camera name or .Scam path (default kodak-dcs200-ir)")
    p.add_argument("--image", help="measure this file instead of simulating (DNG/raw, PNG, TIFF)")
    p.add_argument("--what", help="comma-separated: mtf, snr, color, similarity (default: by scene)")
    p.add_argument("--roi", help="y0,y1,x0,x1 region of an --image to measure")
    p.add_argument("--patches", choices=("layout", "detect"),
                   help="colour accuracy: the chart generator's patch layout, or a chart detected in the image "
                   "(default: layout for the macbeth scene, detect for any other)")
    p.add_argument("--snr-vs-light", dest="snr_vs_light", metavar="L1,L2,...",
                   help="SNR (dB) of the camera on uniform fields of these luminances, cd/m^2 (at the given exposure)")
    p.add_argument("--distance", type=float, help="m (default: the camera's, else the scene's)")
    p.add_argument("--exposure", type=float, help="s (default: auto exposure)")
    p.add_argument("--f-stop", type=float, dest="f_stop")
    p.add_argument("--noise-sigma", type=float, dest="noise_sigma")
    p.add_argument("--bits", type=int, help="ADC bit depth, 1-32, or 0 for unquantized (default: the camera's)")
    p.add_argument("--black-level", type=float, dest="black_level")
    p.add_argument("--seed", type=int)
    p.add_argument("--demosaic", default="bilinear")
    p.add_argument("--monitor", default="simtoolbox-test")
    p.add_argument("--json", dest="json_out", help="write every number (and the MTF curves) to this JSON file")
    p.set_defaults(func=run)


def _image_report(args, what):
    from .. import demosaic, load_raw
    from ..metrics import edge_mtf, region_snr

    path = Path(args.image)
    if path.suffix.lower() in (".png", ".tif", ".tiff"):
        from ..errors import FileFormatError

        try:
            from PIL import Image

            with Image.open(path) as im:
                data = np.asarray(im, float)
        except Exception as exc:
            raise FileFormatError(path, f"not a readable image ({exc})") from None
        image = data
    else:
        raw = load_raw(path)
        image = demosaic(raw, args.demosaic) if "mtf" in what else raw
    data = np.asarray(getattr(image, "data", image))
    if args.roi:
        try:
            y0, y1, x0, x1 = (int(v) for v in args.roi.split(","))
        except ValueError:
            raise ParameterError("--roi", f"expected y0,y1,x0,x1, got {args.roi!r}") from None
        if not (0 <= y0 < y1 <= data.shape[0] and 0 <= x0 < x1 <= data.shape[1]):
            raise ParameterError("--roi", f"{args.roi} lies outside the {data.shape[0]} x {data.shape[1]} image")
        roi = (y0, y1, x0, x1)
    else:
        roi = None
    out = {"image": str(path), "image_shape": list(data.shape[:2])}
    if "mtf" in what:
        crop = data[roi[0]:roi[1], roi[2]:roi[3]] if roi else data
        src = image.replace(data=crop) if hasattr(image, "replace") else crop
        out["mtf"] = {k: {"mtf50": v["mtf50"], "mtf_nyquist": v["mtf_nyquist"], "frequency": v["frequency"].tolist(),
                          "mtf": v["mtf"].tolist()} for k, v in edge_mtf(src).items()}
    if "snr" in what:
        # the field's shading removed, as for a simulated camera (metrics.report.measure_images) and in the explorer
        out["snr"] = {"roi": list(roi) if roi else None, "channels": region_snr(image, roi, detrend=True),
                      "detrended": True}
    bad = sorted(set(what) - {"mtf", "snr"})
    if bad:
        raise ParameterError("--what", f"{', '.join(bad)} needs a simulated camera (--scene), not an --image")
    return out


def _snr_curve(args):
    from ..metrics import snr_vs_light

    try:
        levels = [float(v) for v in args.snr_vs_light.split(",") if v.strip()]
    except ValueError:
        raise ParameterError("--snr-vs-light", f"expected luminances like 10,30,100, got {args.snr_vs_light!r}") from None
    if not levels or not all(0 < v <= MAX_LUMINANCE for v in levels):  # NaN fails too
        raise ParameterError("--snr-vs-light", f"expected luminances from above 0 to {MAX_LUMINANCE:g} cd/m^2, "
                                               f"got {args.snr_vs_light!r}")
    cam = _camera(args, ("noise_sigma", "black_level", "seed", "f_stop", "exposure"))
    curve = snr_vs_light(cam, levels)
    return {"camera": cam.name, "snr_vs_light": {k: [float(x) for x in v] for k, v in curve.items()}}


def _camera(args, fields, scene=None):
    """The ``--camera`` with the flags ``fields`` and ``--bits`` set as the explorer and its parameters files set them
    (:func:`~camsim_core.camera.physical.with_settings`: an electron-level sensor's ADC keeps spanning its full well
    at another bit depth, its pixel angle follows the distance; ``--bits 0`` is unquantized). Given the ``scene``,
    a camera without a distance (and no ``--distance``) is placed at the scene's, the one the simulation uses."""
    from .. import load_camera
    from ..camera.physical import with_settings

    cam = load_camera(args.camera)
    changes = {k: getattr(args, k) for k in fields if getattr(args, k) is not None}
    if scene is not None and "distance" in fields and changes.get("distance") is None and cam.distance is None:
        changes["distance"] = float(scene.distance)
    return with_settings(cam, bits=... if args.bits is None else args.bits, **changes)


def _print(report):
    if "snr_vs_light" in report:
        c = report["snr_vs_light"]
        names = [k for k in c if k != "luminance"]
        print("SNR (dB) vs light   " + "".join(f"{n:>10}" for n in names) + "   (nan: saturated)")
        for i, lum in enumerate(c["luminance"]):
            print(f"  {lum:10.3g} cd/m^2 " + "".join(f"{c[n][i]:10.2f}" for n in names))
    if "mtf" in report:
        print("MTF (slanted edge)     MTF50 cy/px   MTF at Nyquist")
        for k, v in report["mtf"].items():
            print(f"  {k:<20} {v['mtf50']:11.3f}   {v['mtf_nyquist']:14.3f}")
    if "snr" in report:
        print("SNR (uniform region)   mean DU      sigma DU    SNR dB")
        for k, v in report["snr"]["channels"].items():
            flag = "  (saturated)" if v.get("saturated") else ""
            print(f"  {k:<20} {v['mean']:9.2f}   {v['sigma']:9.3f}   {v['snr_db']:7.2f}{flag}")
    if "color" in report:
        c = report["color"]
        where = {"detected": "patches detected in the image", "layout": "patches from the chart's layout"}.get(c.get("patches"), "")
        print(f"Macbeth CIEDE2000 vs ideal: mean {c['mean']:.2f}, max {c['max']:.2f} ({where})")
        for r in range(4):
            print("  " + "  ".join(f"{v:5.2f}" for v in c["per_patch"][6 * r : 6 * r + 6]))
    if "similarity" in report:
        s = report["similarity"]
        print(f"vs ideal: PSNR {s['psnr_db']:.2f} dB, SSIM {s['ssim']:.4f}, mean dE*ab {s['mean_delta_e_ab']:.2f}")


def run(args):
    from ..io.output import atomic_write
    from ..metrics.report import MEASURES, default_measures, quality_report

    what = tuple(w.strip().lower() for w in args.what.split(",") if w.strip()) if args.what else None
    if what:
        unknown = sorted(set(what) - set(MEASURES))
        if unknown:
            raise ParameterError("--what", f"unknown measure(s) {unknown}; valid: {', '.join(MEASURES)}")
    if args.snr_vs_light:
        report = _snr_curve(args)
    elif args.image:
        report = _image_report(args, what or ("mtf",))
    else:
        from .. import auto_exposure, load_scene

        scene = load_scene(args.scene or "slanted-edge")
        cam = _camera(args, ("noise_sigma", "black_level", "seed", "distance", "f_stop"), scene)
        cam = cam.replace(exposure=args.exposure if args.exposure is not None else auto_exposure(scene, cam))
        report = quality_report(scene, cam, what or default_measures(scene.name), demosaic=args.demosaic,
                                monitor=args.monitor, patches=args.patches)
    _print(report)
    if args.json_out:
        text = json.dumps(report, indent=1, default=float)
        atomic_write(args.json_out, lambda f: f.write(text.encode()))
        print(f"wrote {args.json_out}")
    return 0
