"""The server's messages to a page refer only to models the page already has.

A change sent ahead of the message that brings its model is dropped by the
browser ("reference p2578 isn't known"): the browser fuzz saw it on the
Compare tab under load, where the histogram (a Bokeh figure changed in place)
was changed while Panel still queued the message bringing the figure. A
:class:`ws_session.WsSession` checks every message it receives; here it
drives the Compare tab (pins, live changes, a sweep, an unpin) as a page
does. The drop was a race (one run of the suite in a few); this walk makes
each kind of change the Compare tab sends and asserts the order every time.
"""

from __future__ import annotations

import asyncio
import json

from ws_session import WsSession, _status, until

COMPARE_TAB = 4


def _compare(session):
    return _status(session.text("camsim-compare-status")) or {}


async def _walk(url):
    s = await WsSession.open(url)
    try:
        tabs = s.find("camsim-tabs", "Tabs")
        await s._send("PATCH-DOC", {"events": [{"kind": "ModelChanged", "model": {"id": tabs}, "attr": "active",
                                                "new": COMPARE_TAB}]})
        await s.wait_for_model("w-pin", "Button")
        for pinned, noise in enumerate((1.0, 2.0, 3.0), start=1):
            sent = await s.change("w-noise", noise)
            await s.shown("noise_sigma", noise, sent)
            await s.click("w-pin")
            await until(lambda: len(_compare(s).get("pinned", [])) == pinned and not _compare(s).get("busy"),
                         f"{pinned} design(s) pinned and shown")
        sweep = s.find("w-sweep-values")
        await s._send("PATCH-DOC", {"events": [{"kind": "ModelChanged", "model": {"id": sweep}, "attr": "value",
                                                "new": "0, 4"}]})
        await s.click("w-sweep-run")
        await until(lambda: "Done:" in s.text("camsim-sweep-message"), "the sweep done")
        await s.click("w-unpin")
        await until(lambda: len(_compare(s).get("pinned", [])) == 2, "one design unpinned")
        return s.patches, list(s.unknown_references), _compare(s)
    finally:
        await s.close()


def test_the_compare_tab_never_sends_a_change_before_its_model(server):
    patches, unknown, status = asyncio.run(_walk(server))
    assert patches > 20 and len(status["designs"]) >= 2, (patches, json.dumps(status)[:300])
    assert unknown == [], f"messages referring to models not yet sent: {unknown[:5]}"
