"""The ``camsim`` command line.

Each sub-command lives in its own module of this package and defines
``register(subparsers)``, which adds its parser and sets ``func`` to a
function ``func(args) -> int``. Every failure prints one line on stderr
and exits with status 2, never a traceback: camsim's own errors (bad files,
bad parameters: :class:`~camsim_core.errors.CamsimError`) as their message,
argument errors as argparse's message without the usage block, and any
other exception as its type and message (set ``CAMSIM_DEBUG=1`` to see its
traceback instead). Warnings raised on the way (numpy's, Pillow's) are not
printed when the command fails; when it succeeds each distinct one is one
``warning:`` line on stderr.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
import warnings

from ..errors import CamsimError

__all__ = ["main", "build_parser"]


class OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line on stderr (and status 2), not the usage block.

    Sub-command parsers are of the same class (``add_subparsers`` makes them so).
    """

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {_one_line(message)} (see {self.prog} --help)\n")


def build_parser():
    """The ``camsim`` parser with every sub-command of this package."""
    parser = OneLineParser(prog="camsim", description="Digital camera simulation from hyperspectral scenes.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    parser.command_names = tuple(sorted(sub.choices))
    return parser


def main(argv=None):
    """Run the ``camsim`` command line.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success, 2 for bad input (one line on stderr), 130 when
        interrupted. Argument errors and ``--help`` raise ``SystemExit`` (2
        and 0) as argparse does.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["serve"]:  # the explorer's command: its flags and server are the explorer's (see cli/serve.py)
        from .serve import main as serve

        # a server runs for hours: its warnings are shown as they come, not kept
        return _run(argparse.Namespace(command="serve", func=lambda _: serve(argv[1:])))
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        print(f"camsim: error: a COMMAND is required ({', '.join(parser.command_names)})", file=sys.stderr)
        return 2
    with warnings.catch_warnings(record=True) as caught:  # the filters in force stay; shown warnings are kept
        status = _run(args)
    if status == 0:
        for text in dict.fromkeys(f"{w.category.__name__}: {_one_line(w.message)}" for w in caught):
            print(f"camsim {args.command}: warning: {text}", file=sys.stderr)
    return status


def _run(args):
    """``args.func(args)`` with every failure turned into one line on stderr and its status."""
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
    except Exception as exc:
        # not one of camsim's own errors (a disk full, a file that cannot be read, or a check camsim lacks):
        # still one line, with the exception's type, never a traceback unless asked for
        if os.environ.get("CAMSIM_DEBUG") == "1":
            raise
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
