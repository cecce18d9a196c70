"""The ``camsim`` command line.

Each sub-command lives in its own module of this package and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a
function ``func(args) -> int``. Errors of camsim's own (bad files, bad
parameters) print one clear line and exit with status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from ..errors import CamsimError

__all__ = ["main", "build_parser"]


def build_parser():
    parser = argparse.ArgumentParser(prog="camsim", description="Digital camera simulation from hyperspectral scenes.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        import numpy as np

        with np.errstate(over="ignore", invalid="ignore"):  # overflow saturates in the digitizer; no warnings
            return int(args.func(args) or 0)
    except CamsimError as exc:
        print(f"camsim {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"camsim {args.command}: interrupted", file=sys.stderr)
        return 130
    except (OSError, UnicodeError, MemoryError, RecursionError, ValueError, TypeError, ArithmeticError) as exc:
        # not one of camsim's own errors: still one line, never a traceback
        print(f"camsim {args.command}: error: {type(exc).__name__}: {_one_line(exc)}", file=sys.stderr)
        return 2


def _one_line(exc):
    text = " ".join(str(exc).split())
    return text if len(text) <= 500 else text[:497] + "..."


def check_output(path, flag="--out", *, suffixes=None):
    """Refuse an output path before any work: a folder, a missing parent folder, or an unknown suffix."""
    from pathlib import Path

    from ..errors import ParameterError

    p = Path(path)
    if p.is_dir() or str(path).endswith(("/", "\\")):
        raise ParameterError(flag, f"{path} is a folder; give a file name")
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise ParameterError(flag, f"folder {folder} does not exist")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise ParameterError(flag, f"{p.name}: expected one of {', '.join(suffixes)}")
    return p


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
