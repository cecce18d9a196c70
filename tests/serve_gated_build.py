"""``camsim serve`` whose pages built for a request with arguments (a link) wait for a gate, a file.

While the gate (the path in ``CAMSIM_TEST_GATE``) does not exist, a link's page
build waits (at most 120 s): a test sees what the browser gets before the page
is built. A link with ``camsim_test_title`` gets that title (its head is not the
other pages'). Pages without
arguments (the spare pages) are built at once. Usage is that of
``python -m camsim_core.cli`` (the arguments are passed on).
"""

import os
import sys
import time

import camsim_explorer.main as explorer
from camsim_core.cli import main

GATE = os.environ["CAMSIM_TEST_GATE"]
_create_app = explorer.create_app


def _gated_create_app(*args, **kwargs):
    import panel as pn

    context = pn.state.curdoc.session_context if pn.state.curdoc is not None else None
    arguments = context.request.arguments if context is not None and context.request is not None else {}
    if arguments:
        deadline = time.monotonic() + 120
        while not os.path.exists(GATE) and time.monotonic() < deadline:
            time.sleep(0.02)
    app = _create_app(*args, **kwargs)
    if "camsim_test_title" in arguments:
        app.title = arguments["camsim_test_title"][0].decode()  # the page's template's title
    return app


explorer.create_app = _gated_create_app

if __name__ == "__main__":
    sys.exit(main())
