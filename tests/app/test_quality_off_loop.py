"""The Image quality tab measures off the server's event loop, over a websocket session (no browser).

An SSIM or an MTF of a frame-sized chart takes 0.1-0.5 s on a quiet machine; measured on the event loop it
held every page of the server (the suite's logs showed 0.6-5 s under load). The tab, opened on a chart,
measures in a session thread and says "Measuring" meanwhile; while it is shown, a new result is measured
in the computing thread. The server's stall lines (``event loop blocked N ms in f (file) from g (file)``)
must name none of the measures.
"""

from __future__ import annotations

import asyncio
import re

from ws_session import WsSession, until

QUALITY_TAB = 3
#: A stall line naming a measure: the engine's or scikit-image's metrics innermost, or the view's measuring
#: functions under it (the view's drawing, ``_show`` and ``_plot_mtf``, stays on the loop: the tab's first
#: MTF plot took 340 ms there, its later ones are new data for the same plot).
MEASURES = re.compile(r"event loop blocked \d+ ms in \S+ \((metrics|report)/|from (_measure|update|prepare) \(app/quality\.py\)")


async def _walk(url):
    s = await WsSession.open(url)
    try:
        sent = await s.change("w-scene", "slanted-edge")
        await until(lambda: any(t >= sent and not st.get("computing")
                                 and str(st.get("params", {}).get("scene", "")).startswith("slanted-edge:")
                                 for t, st in s.statuses), "the chart fitted and shown", timeout=120)
        tabs = s.find("camsim-tabs", "Tabs")
        await s._send("PATCH-DOC", {"events": [{"kind": "ModelChanged", "model": {"id": tabs}, "attr": "active",
                                                "new": QUALITY_TAB}]})
        await s.wait_for_model("camsim-quality", "HTML")
        await until(lambda: "MTF50" in s.text("camsim-quality"), "the chart's MTF in the tab")
        first = s.text("camsim-quality")
        sent = await s.change("w-noise", 4.0)
        await s.shown("noise_sigma", 4.0, sent)
        await until(lambda: "MTF50" in s.text("camsim-quality") and s.text("camsim-quality") != first,
                     "the tab's numbers following the new result")
        return first, s.text("camsim-quality")
    finally:
        await s.close()


def test_the_image_quality_tab_measures_off_the_event_loop(own_server):
    from app_helpers import RUNNING

    first, after = asyncio.run(_walk(own_server))
    assert "SSIM" in first and "SSIM" in after
    log = open(RUNNING[own_server][1], errors="replace").read()
    stalls = [line for line in log.splitlines() if MEASURES.search(line)]
    assert stalls == [], stalls
