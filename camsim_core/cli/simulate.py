"""``camsim simulate``: a scene through a camera, written as a raw file or a displayed image."""

from __future__ import annotations

from pathlib import Path

from ..errors import ParameterError

__all__ = ["register", "run"]


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
    p.add_argument("--bits", type=int, help="quantization depth, 1-32")
    p.add_argument("--unquantized", action="store_true", help="no digitization (float output, write .npy)")
    p.add_argument("--no-mosaic", action="store_true", help="simulate a full-colour (non-mosaiced) camera")
    p.add_argument("--seed", type=int, help="noise seed")
    p.add_argument("--demosaic", metavar="METHOD", help="demosaic the raw image (bilinear, freeman, bayesian, bayesian-original, malvar2004, menon2007)")
    p.add_argument("--render", metavar="METHOD", help="render for display (baseline, illuminant); implies --demosaic bilinear for a mosaic")
    p.add_argument("--illuminant", help="for --render illuminant: gray-world, max-rgb, or omit for the scene's known one")
    p.add_argument("--monitor", default="simtoolbox-test", help="monitor for --render (default simtoolbox-test)")
    p.add_argument("--out", required=True, help="output file: .tif, .png, .npy, or .dng (a CFA DNG raw converters open)")
    p.set_defaults(func=run)


def run(args):
    from .. import auto_exposure, load_camera, load_scene, simulate
    from ..io.output import RAW_SUFFIXES, write_image

    out = Path(args.out)
    dng = out.suffix.lower() == ".dng"
    if out.suffix.lower() not in RAW_SUFFIXES and not dng:
        raise ParameterError("--out", f"{out.name}: expected a .tif, .png, .npy or .dng file name")
    if dng and (args.render or args.demosaic or args.no_mosaic or args.unquantized):
        raise ParameterError("--out", f"{out.name}: a DNG holds the raw mosaic; drop --render, --demosaic, --no-mosaic and --unquantized")
    if args.render and out.suffix.lower() not in (".png", ".tif", ".tiff"):
        raise ParameterError("--out", f"{out.name}: a rendered image is written as .png or .tif")
    scene = load_scene(args.scene)
    camera = load_camera(args.camera)
    changes = {}
    if args.noise_sigma is not None:
        changes["noise_sigma"] = args.noise_sigma
    if args.black_level is not None:
        changes["black_level"] = args.black_level
    if args.bits is not None:
        changes["bits"] = args.bits
    if args.unquantized:
        changes["bits"] = None
    if args.no_mosaic:
        changes["mosaic"] = None
    for name in ("distance", "exposure", "f_stop", "seed"):
        if getattr(args, name) is not None:
            changes[name] = getattr(args, name)
    camera = camera.replace(**changes)
    if args.auto_exposure:
        camera = camera.replace(exposure=auto_exposure(scene, camera))
    image = simulate(scene, camera)
    if args.demosaic or (args.render and image.mosaiced):
        from .. import demosaic

        image = demosaic(image, method=args.demosaic or "bilinear")
    if args.render:
        from .. import load_monitor, render

        image = render(image, load_monitor(args.monitor), method=args.render, illuminant=args.illuminant)
    if dng:
        from ..io.dng import write_dng

        write_dng(image, out, model=camera.name or "camera")
        print(f"wrote {out} ({image.data.shape[0]} x {image.data.shape[1]} CFA DNG, {image.bits}-bit)")
        return 0
    write_image(image, out)
    print(f"wrote {out} ({' x '.join(str(s) for s in image.data.shape)}, {image.space}"
          f"{', mosaiced' if image.mosaiced else ''}{f', {image.bits}-bit' if image.quantized else ''}) and {out.name}.json")
    return 0
