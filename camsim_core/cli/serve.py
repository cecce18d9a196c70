"""``camsim serve``: the explorer's web server, a command of the explorer.

The server and its flags live with the explorer (``camsim_explorer.serve``,
installed with ``pip install "camsim-spectral[app]"``). The engine only names
the command here; :func:`main` imports the explorer when the command runs,
so no other command (and no engine module) imports the explorer, Panel or
Bokeh.
"""

from __future__ import annotations

from ..errors import CamsimError

__all__ = ["register", "main", "MISSING_APP_MESSAGE"]

#: What ``camsim serve`` says when the explorer or one of its libraries is not installed.
MISSING_APP_MESSAGE = ("the explorer is not installed ({missing} is missing): "
                       'pip install "camsim-spectral[app]" installs it')

#: Top-level modules whose absence means the ``app`` extra is missing (rather than a fault of the explorer).
_APP_MODULES = ("camsim_explorer", "panel", "bokeh", "param", "tornado")


def register(subparsers):
    """Name ``serve`` in ``camsim --help``; its arguments are parsed by the explorer (see :func:`main`)."""
    subparsers.add_parser("serve", help="start the explorer web app (camsim serve --help lists its flags)",
                          add_help=False)


def explorer_serve():
    """The explorer's ``camsim_explorer.serve`` module.

    Raises
    ------
    CamsimError
        When the explorer or a library it needs is not installed, with the line that installs it.
    """
    try:
        from camsim_explorer import serve
    except ModuleNotFoundError as exc:
        missing = (exc.name or "").partition(".")[0]
        if missing not in _APP_MODULES:
            raise
        raise CamsimError(MISSING_APP_MESSAGE.format(missing=missing)) from None
    return serve


def parse(argv):
    """The parsed ``camsim serve`` arguments ``argv`` (those after ``serve``), by the explorer's parser."""
    from . import OneLineParser

    serve = explorer_serve()
    parser = OneLineParser(prog="camsim")
    serve.register(parser.add_subparsers(dest="command", metavar="COMMAND"))
    return parser.parse_args(["serve", *argv])


def main(argv):
    """Run ``camsim serve`` with ``argv`` (the arguments after ``serve``); see ``camsim serve --help``.

    Parameters
    ----------
    argv : list of str
        The command's arguments, parsed by the explorer's parser (``--help`` and argument errors raise
        ``SystemExit`` as argparse does).

    Returns
    -------
    int
        0 once the server stops.

    Raises
    ------
    CamsimError
        When the explorer is not installed (:data:`MISSING_APP_MESSAGE`), or for a bad flag value.
    """
    args = parse(argv)
    return args.func(args)
