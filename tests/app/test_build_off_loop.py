"""Pages are built in a thread of their own, not on the server's event loop (app/compat/build_off_loop.py)."""

from __future__ import annotations

import re
import time
import urllib.request

import pytest

from app_helpers import ARTIFACTS, explorer_server


def test_the_replacement_matches_the_installed_bokeh():
    """Fails when an upgrade of Bokeh changes the method the replacement mirrors: pages would then be built on
    the event loop again (the server only logs a warning)."""
    from bokeh.server.contexts import ApplicationContext

    from camsim_explorer.compat import build_off_loop as _build_off_loop

    assert _build_off_loop._digest(ApplicationContext.create_session_if_needed) == _build_off_loop.BOKEH_SOURCE_SHA256
    assert _build_off_loop.install()
    assert ApplicationContext.create_session_if_needed.original is not None


@pytest.mark.slow
def test_a_served_page_is_built_in_the_builder_thread():
    ARTIFACTS.mkdir(exist_ok=True)
    with explorer_server(extra_args=["--no-spare-page"]) as url:
        for _ in range(2):
            page = urllib.request.urlopen(url + "?noise_sigma=2", timeout=90).read().decode()
            assert '"token":"' in page
        log_path = ARTIFACTS / f"server-{url.rsplit(':', 1)[1].strip('/')}.log"
        deadline = time.monotonic() + 30
        while True:
            builds = re.findall(r"a page built in \d+ ms in thread (\S+)", log_path.read_text(errors="replace"))
            if len(builds) >= 2 or time.monotonic() > deadline:
                break
            time.sleep(0.2)
    assert builds and all(name.startswith("camsim-build_") for name in builds), builds



async def _pulled(link, page):
    """Open the websocket of ``page`` (its HTML, fetched from ``link``), pull the document: its status."""
    from ws_session import WsSession

    session = await WsSession.open(link, page=page)
    try:
        return session.pulled_status()
    finally:
        await session.close()


def _count(log_path, text):
    return log_path.read_text(errors="replace").count(text)


@pytest.mark.slow
def test_a_page_built_for_its_link_is_pulled_from_a_serialization_made_off_the_loop(own_server):
    """A link's page (never a spare) is serialized in the builder thread once its first result is in; the
    browser's pull then gets that serialization, a complete document with the result, instead of the event
    loop serializing it while every other page waits."""
    import asyncio

    url = own_server
    # a server of its own: the counts are of this test's page alone
    log_path = ARTIFACTS / f"server-{url.rsplit(':', 1)[1].strip('/')}.log"
    link = url + "?noise_sigma=3"
    before = _count(log_path, "serialized off the event loop")
    answered_before = _count(log_path, "answered with its serialization made off the event loop")
    page = urllib.request.urlopen(link, timeout=90).read().decode()  # the session is built for the link
    deadline = time.monotonic() + 60
    while _count(log_path, "serialized off the event loop") == before:
        assert time.monotonic() < deadline, "the link's page was not serialized off the event loop"
        time.sleep(0.05)

    status = asyncio.run(_pulled(link, page))  # what the page's scripts do once loaded
    answered = _count(log_path, "answered with its serialization made off the event loop") - answered_before
    assert answered == 1
    assert status is not None and status["params"]["noise_sigma"] == 3, status
    assert not status.get("computing") and status.get("mean_de", 0) > 0, status


def test_two_pages_are_never_built_at_once():
    # a visitor's page and a spare page were built in two threads at once, and Panel's param.edit_readonly
    # (shared parameter flags) made one build fail: "Read-only parameter 'hostname' cannot be modified"
    import threading
    import time

    from camsim_explorer.compat import build_off_loop as b

    from overlap import Overlap

    building = Overlap()

    class App:
        def initialize_document(self, doc):
            with building:
                time.sleep(0.05)

    threads = [threading.Thread(target=b._initialize, args=(App(), None)) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert building.most == 1


@pytest.mark.slow
def test_a_pull_that_comes_before_the_pages_serialization_waits_for_it_off_the_loop(own_server):
    """A page built for its request whose browser pulls at once (a class arriving together: its first result
    queued for the cores) gets its first result in the pull, serialized in the builder thread; before, the
    pull was serialized on the event loop (200-560 ms stalls per page in the hostile load test)."""
    import asyncio

    log_path = ARTIFACTS / f"server-{own_server.rsplit(':', 1)[1].strip('/')}.log"
    words = "pull came first and was answered with a serialization made off the event loop"
    before = _count(log_path, words)
    link = own_server + "?noise_sigma=4"

    async def pull():  # no wait between the page and its pull
        page = await asyncio.to_thread(lambda: urllib.request.urlopen(link, timeout=90).read().decode())
        return await _pulled(link, page)

    status = asyncio.run(pull())
    assert _count(log_path, words) - before == 1
    assert status is not None and status["params"]["noise_sigma"] == 4, status
    assert not status.get("computing") and status.get("mean_de", 0) > 0, status
