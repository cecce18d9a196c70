"""``camsim simulate``: a scene through a camera, written as a raw file or a displayed image."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import ParameterError

__all__ = ["register", "run"]


def _size(text):
    """``--size ROWSxCOLS`` as ``(rows, cols)``: whole numbers within the camera limits
    (:func:`~camsim_core.camera.camera.check_camera_size`)."""
    from ..camera.camera import check_camera_size

    try:
        rows, cols = (int(v) for v in str(text).lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected ROWSxCOLS (e.g. 3000x4000), got {text!r}") from None
    if rows < 1 or cols < 1:
        raise argparse.ArgumentTypeError(f"rows and columns must be >= 1, got {text!r}")
    try:
        return check_camera_size(rows, cols, "--size")
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--size: ")) from None


def register(subparsers):
    p = subparsers.add_parser(
        "simulate",
        help="simulate a camera image of a scene",
        description="Simulate what CAMERA records of SCENE. Writes a raw 8/16-bit TIFF or PNG (or .npy for "
        "unquantized data) with a JSON sidecar, or a CFA DNG; with --render, writes the displayed 8-bit PNG instead.",
    )
    p.add_argument("--scene", required=True, help="scene or chart name, or a scene file (.Simg, .npz, ENVI .hdr, .mat, photo, band-PNG folder)")
    p.add_argument("--camera", required=True, help="shipped camera name or a .Scam path")
    p.add_argument("--distance", type=float, help="camera distance to the scene, m (default: the scene's)")
    p.add_argument("--exposure", type=float, help="exposure time, s")
    p.add_argument("--f-stop", type=float, dest="f_stop", help="f-number")
    p.add_argument("--auto-exposure", action="store_true", help="choose the exposure that puts the bright end at 90%% of full scale")
    p.add_argument("--noise-sigma", type=float, dest="noise_sigma", help="Gaussian noise sigma, digital units")
    p.add_argument("--black-level", type=float, dest="black_level",
                   help="sensor pedestal added before quantization, digital units (default: the camera's, 0 for the shipped ones)")
    p.add_argument("--bits", type=int, help="quantization depth, 1-32, or 0 for no digitization (as --unquantized)")
    p.add_argument("--unquantized", action="store_true", help="no digitization (float output, write .npy); the same as --bits 0")
    p.add_argument("--no-mosaic", action="store_true", help="simulate a full-colour (non-mosaiced) camera")
    p.add_argument("--seed", type=int, help="noise seed")
    p.add_argument("--size", type=_size, metavar="ROWSxCOLS", help="the camera's pixel array, e.g. 3000x4000 (default: the camera's own)")
    p.add_argument("--demosaic", metavar="METHOD", help="demosaic the raw image (bilinear, freeman, bayesian, bayesian-original, malvar2004, menon2007)")
    p.add_argument("--render", metavar="METHOD", help="render for display (baseline, illuminant); implies --demosaic bilinear for a mosaic")
    p.add_argument("--illuminant", help="for --render illuminant: gray-world, max-rgb, or omit for the scene's known one")
    p.add_argument("--monitor", default="simtoolbox-test", help="monitor for --render (default simtoolbox-test)")
    p.add_argument("--out", required=True, help="output file: .tif, .png, .npy, or .dng (a CFA DNG raw converters open)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (it shows only on a terminal anyway)")
    p.set_defaults(func=run)


def _run_with_progress(image, steps, out, disable=None, write=None):
    """Apply ``steps`` (name, function) to ``image`` and write it to ``out`` (``write(image, path)``,
    default :func:`~camsim_core.io.output.write_image`), one progress-bar tick per step.

    The bar goes to standard error and shows only on a terminal (``disable=None``).
    """
    from tqdm.auto import tqdm

    from ..io.output import write_image

    with tqdm(total=len(steps) + 1, desc="simulate", unit="step", disable=disable, leave=True) as bar:
        for name, step in steps:
            bar.set_postfix_str(name)
            image = step(image)
            bar.update(1)
        bar.set_postfix_str(f"write {out.name}")
        (write or write_image)(image, out)
        bar.update(1)
    return image


def run(args):
    from .. import auto_exposure, load_camera, load_scene
    from ..camera.physical import with_settings
    from ..image import image_from_scene
    from ..io.output import RAW_SUFFIXES

    from . import check_output

    out = check_output(args.out)
    dng = out.suffix.lower() == ".dng"
    if out.suffix.lower() not in RAW_SUFFIXES and not dng:
        raise ParameterError("--out", f"{out.name}: expected a .tif, .png, .npy or .dng file name")
    unquantized = args.unquantized or args.bits == 0
    if dng and (args.render or args.demosaic or args.no_mosaic or unquantized):
        raise ParameterError("--out", f"{out.name}: a DNG holds the raw mosaic; drop --render, --demosaic, --no-mosaic and --unquantized (--bits 0)")
    if args.seed is not None and args.seed < 0:
        raise ParameterError("--seed", f"must be a whole number >= 0, got {args.seed}")
    for name in ("distance", "exposure", "f_stop", "noise_sigma"):
        v = getattr(args, name, None)
        if v is not None and not (v == v and abs(v) != float("inf")):
            raise ParameterError(f"--{name.replace('_', '-')}", f"must be a finite number, got {v}")
    if args.render and out.suffix.lower() not in (".png", ".tif", ".tiff"):
        raise ParameterError("--out", f"{out.name}: a rendered image is written as .png or .tif")
    scene = load_scene(args.scene)
    camera = load_camera(args.camera)
    changes = {}
    if args.noise_sigma is not None:
        changes["noise_sigma"] = args.noise_sigma
    if args.black_level is not None:
        changes["black_level"] = args.black_level
    bits = None if unquantized else (... if args.bits is None else args.bits)
    if args.no_mosaic:
        changes["mosaic"] = None
    if args.size is not None:
        changes["height"], changes["width"] = args.size
    for name in ("distance", "exposure", "f_stop", "seed"):
        if getattr(args, name) is not None:
            changes[name] = getattr(args, name)
    if "distance" not in changes and camera.distance is None:
        changes["distance"] = float(scene.distance)  # the distance the simulation uses: an angle of a pixel follows it
    # as the explorer and its parameters files build it: an electron-level sensor's ADC keeps spanning its full
    # well at another bit depth, and its pixel angle follows the distance
    camera = with_settings(camera, bits=bits, **changes)
    if args.auto_exposure:
        camera = camera.replace(exposure=auto_exposure(scene, camera))
    steps = [(getattr(s, "__name__", "stage"), lambda im, s=s: s(camera, im)) for s in camera.architecture]
    if args.demosaic or args.render:
        from .. import demosaic

        method = args.demosaic or "bilinear"
        steps.append((f"demosaic {method}", lambda im: demosaic(im, method=method) if (args.demosaic or im.mosaiced) else im))
    if args.render:
        from .. import load_monitor, render

        monitor = load_monitor(args.monitor)
        steps.append((f"render {args.render}", lambda im: render(im, monitor, method=args.render, illuminant=args.illuminant)))
    if dng:
        from ..io.dng import write_dng

        image = _run_with_progress(image_from_scene(scene), steps, out, disable=True if args.no_progress else None,
                                   write=lambda im, path: write_dng(im, path, model=camera.name or "camera",
                                                                    analog_gain=camera.analog_gain))
        print(f"wrote {out} ({image.data.shape[0]} x {image.data.shape[1]} CFA DNG, {image.bits}-bit)")
        return 0
    image = _run_with_progress(image_from_scene(scene), steps, out, disable=True if args.no_progress else None)
    print(f"wrote {out} ({' x '.join(str(s) for s in image.data.shape)}, {image.space}"
          f"{', mosaiced' if image.mosaiced else ''}{f', {image.bits}-bit' if image.quantized else ''}) and {out.name}.json")
    return 0
