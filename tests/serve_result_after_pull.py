"""``camsim serve`` whose first result lands just after the browser's first pull of the page.

The window between that pull and the page's "document ready" report is where
Panel drops held document changes; this launcher makes the explorer's first
result arrive in it every time (the engine runs, then waits for the pull), so
a test can check that the result still reaches the screen. Usage is that of
``python -m camsim_core.cli`` (the arguments are passed on).
"""

import sys
import threading

from bokeh.server.session import ServerSession

import camsim_core.cache as cache
from camsim_core.cli import main

PULLED = threading.Event()
_pull = ServerSession.pull.__func__
_run = cache.Pipeline.run


def _pull_then_release(cls, message, connection):
    reply = _pull(cls, message, connection)

    async def pulled():
        out = await reply  # the page is serialized for the browser here
        PULLED.set()
        return out

    return pulled()


def _run_then_wait_for_pull(self, *args, **kwargs):
    result = _run(self, *args, **kwargs)
    if threading.current_thread().name.startswith("camsim-session"):  # a page's run, not the server's warm-up
        PULLED.wait(timeout=120)
    return result


ServerSession.pull = classmethod(_pull_then_release)
cache.Pipeline.run = _run_then_wait_for_pull

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
