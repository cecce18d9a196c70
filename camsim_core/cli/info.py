"""``camsim info``: print a scene's, camera's or monitor's metadata."""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import FileFormatError

__all__ = ["register", "run", "describe"]


def register(subparsers):
    p = subparsers.add_parser("info", help="print a scene's, camera's or monitor's metadata")
    p.add_argument("target", help="a shipped name or a .Simg / .npz / .Scam / .Smon path")
    p.set_defaults(func=run)


def describe(target):
    """The metadata dict of a scene, camera or monitor named or pointed to by ``target``."""
    from ..camera import CAMERA_NAMES, load_camera
    from ..monitor import MONITOR_NAMES, load_monitor
    from ..scene import SCENE_NAMES, load_scene

    key = str(target).lower()
    suffix = Path(str(target)).suffix.lower()
    if key in SCENE_NAMES or suffix in (".simg", ".npz"):
        return load_scene(target).describe()
    if key in CAMERA_NAMES or key.startswith("mixture-") or suffix == ".scam":
        return load_camera(target).describe()
    if key in MONITOR_NAMES or suffix == ".smon":
        return load_monitor(target).describe()
    raise FileFormatError(
        target,
        "not a shipped name nor a .Simg, .npz, .Scam or .Smon file; shipped: "
        + ", ".join(SCENE_NAMES + CAMERA_NAMES + MONITOR_NAMES),
    )


def run(args):
    print(json.dumps(describe(args.target), indent=2))
    return 0
