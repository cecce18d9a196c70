"""``camsim serve``: start the explorer (a Panel web app, issue 5) on a local port.

The engine itself never imports Panel: this command imports the ``app``
package only when it runs.
"""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import ParameterError

__all__ = ["register", "run"]


def register(subparsers):
    p = subparsers.add_parser("serve", help="start the explorer web app")
    p.add_argument("--port", type=int, default=5006, help="port to listen on (default 5006; 0 picks a free one)")
    p.add_argument("--address", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1; 0.0.0.0 to serve a class or a review)")
    p.add_argument("--scene", default=None, help="scene sessions open on: a shipped name or a .Simg / .npz path")
    p.add_argument("--allow-origin", action="append", default=[],
                   help="extra host:port allowed to open the websocket (repeatable)")
    p.add_argument("--show", action="store_true", help="open a browser tab")
    p.set_defaults(func=run)


def _import_app():
    """The ``app`` package (beside ``camsim_core`` in a checkout)."""
    root = Path(__file__).resolve().parents[2]
    if (root / "app" / "__init__.py").exists() and str(root) not in sys.path:
        sys.path.insert(0, str(root))
    import app.main

    return app.main


def run(args):
    from .. import load_scene

    if not 0 <= args.port <= 65535:
        raise ParameterError("--port", f"must be 0..65535, got {args.port}")
    scene = None
    if args.scene:
        scene = load_scene(args.scene)  # validate now: a clear error, not a broken page
        scene = args.scene if str(args.scene).lower() == scene.name else scene
    main = _import_app()
    import panel as pn

    main.configure(scene)
    origins = [f"{host}:{args.port}" for host in ("localhost", "127.0.0.1", args.address)] + list(args.allow_origin)
    if args.address == "0.0.0.0":
        origins.append("*")
    print(f"camsim explorer on http://{'localhost' if args.address in ('127.0.0.1', '0.0.0.0') else args.address}:{args.port}/"
          " (Ctrl-C to stop)", flush=True)
    pn.serve(main.create_app, port=args.port, address=args.address, show=args.show,
             websocket_origin=sorted(set(origins)), title="camsim explorer", verbose=False)
    return 0
