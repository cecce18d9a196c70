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
            builds = re.findall(r"a page built in \d+ ms \(\d+ ms of its thread.s CPU\) in thread (\S+)", log_path.read_text(errors="replace"))
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
    # a first result that takes the engine longer than a change (the scene at 0.5 m: four times the pixels, and
    # S-CIELAB): the pull comes first even when this test's process is slowed by a loaded machine
    link = own_server + "?distance=0.5&metric=S-CIELAB"

    async def pull():  # no wait between the page and its pull
        page = await asyncio.to_thread(lambda: urllib.request.urlopen(link, timeout=90).read().decode())
        return await _pulled(link, page)

    status = asyncio.run(pull())
    assert _count(log_path, words) - before == 1
    assert status is not None and status["params"]["distance"] == 0.5, status
    assert status["params"]["metric"] == "S-CIELAB", status
    assert not status.get("computing") and status.get("mean_de", 0) > 0, status


def _slots_shown(session):
    """How many of the Compare tab's design slots the session's document shows."""
    return sum(1 for m in session.models.values()
               if "camsim-compare-slot" in (m.get("attributes", {}).get("css_classes") or [])
               and m["attributes"].get("visible", True))


@pytest.mark.slow
def test_a_links_designs_another_page_holds_come_with_its_first_document(own_server):
    """A class opens its teacher's link: the pinned designs the teacher's page holds are in each student's page
    as it is pulled (designs, plots and their data, made in the builder thread), not added afterwards on the
    event loop (1.5-2.5 s of every page's waiting per link, and 2-3 s later on the screen)."""
    import asyncio
    import json
    import urllib.parse

    from ws_session import WsSession, _status, until

    pinned = [{"name": "cones", "params": {"camera": "human-cones"}},
              {"name": "xyz", "params": {"camera": "cie1931", "noise_sigma": 2.0}}]
    link = own_server + "?" + urllib.parse.urlencode({"pinned": json.dumps(pinned), "tab": "compare"})
    log_path = ARTIFACTS / f"server-{own_server.rsplit(':', 1)[1].strip('/')}.log"

    def compare(session):
        return _status(session.text("camsim-compare-status")) or {}

    async def run():
        teacher = await WsSession.open(link)
        try:
            await until(lambda: [d["name"] for d in compare(teacher).get("designs", []) if d["name"] != "live"] == ["cones", "xyz"]
                        and not compare(teacher).get("busy") and not compare(teacher).get("measuring"),
                        "the teacher's designs computed and measured", timeout=120)
            before = _count(log_path, "serialization made off the event loop")
            student = await WsSession.open(link)  # pulls at once: nothing after the build has run yet
            try:
                return compare(student), _slots_shown(student), _count(log_path, "serialization made off the event loop") - before
            finally:
                await student.close()
        finally:
            await teacher.close()

    status, slots, off_the_loop = asyncio.run(run())
    names = [d["name"] for d in status.get("designs", [])]
    assert [n for n in names if n != "live"] == ["cones", "xyz"] and not status["busy"], json.dumps(status)[:400]
    assert slots == len(names), (slots, names)
    # the page as built: nothing changed it after its build (the designs added on the event loop did, and the pull
    # was then serialized there too)
    assert off_the_loop == 1
