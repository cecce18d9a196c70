"""``camsim serve`` that, once it serves, writes to a page's websocket after the page has closed: a task whose
exception (Tornado's ``WebSocketClosedError``) nobody retrieves, as a tab closed mid-update leaves. The server's
log must say so in one line, with no traceback. Usage is that of ``python -m camsim_core.cli``.
"""

import asyncio
import gc
import sys

import camsim_explorer.serve as serve
from camsim_core.cli import main

_serving_loop = serve.serving_loop


async def _write_to_a_closed_page():
    from tornado.websocket import WebSocketClosedError

    raise WebSocketClosedError()


def _unretrieved():
    task = asyncio.ensure_future(_write_to_a_closed_page())

    def drop():  # nobody retrieved its exception: asyncio reports it when the task goes
        nonlocal task
        task = None
        gc.collect()

    asyncio.get_running_loop().call_later(0.2, drop)


def _writing_once_serving():
    loop = _serving_loop()
    loop.call_later(1.0, _unretrieved)  # on the loop the server runs, once it runs
    return loop


serve.serving_loop = _writing_once_serving

if __name__ == "__main__":
    sys.exit(main())
