"""How the server gives pages to a real browser: the page a request builds and the one built in advance, a first
result landing mid-render, two pages at once, links, a change during a long computation, results larger than the
screen. Playwright drives the system Chromium against ``camsim serve`` on 127.0.0.1; screenshots go to
``test-artifacts/``. The controls and views are in ``test_app_browser.py``.
"""

import time

import numpy as np
import pytest

from app_helpers import (ARTIFACTS, POLL, Page, background_share, busy_label, eventually, explorer_server,
                         loading_count, next_frames, pane_text, server_log, settled_shot, shot_until, wait_for_log,
                         wait_until)

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def server(own_server):
    """A server of this file's own: its tests count the pages it builds in advance."""
    return own_server


def test_a_first_result_landing_while_the_page_renders_is_shown(browser):
    """The first result arrives just after the browser pulled the page, before it reports ready
    (a slow first computation, e.g. a cold start): it must still reach the screen."""
    launcher = ARTIFACTS.parent / "tests" / "serve_result_after_pull.py"
    with explorer_server(launcher=launcher) as url:
        pg = Page(browser, url)  # waits for the status pane to hold a dE
        try:
            s = pg.status()
            assert s["mean_de"] > 0
            assert f"{s['mean_de']:.2f}" in pg.text(".camsim-stats")
            assert loading_count(pg) == 0
            for key in ("raw", "rendered"):  # the canvases draw the data that arrived
                shot_until(pg, f".camsim-{key}-plot", lambda png: background_share(png) < 0.5,
                           f"the {key} view is not blank", name=f"first-result-while-rendering-{key}")
        finally:
            pg.close()


def test_a_links_page_sends_its_scripts_before_it_is_built(browser, tmp_path, monkeypatch):
    """A link's page is built for its request (1-2 s with pinned designs). The head of the page, its scripts
    (Bokeh's and Panel's, the same in every page), goes first: the browser has run them before the page is built
    (the build waits here for a gate the test opens only then). Before, nothing came until the page was built.
    A page that does not begin as sent (another title here) is asked for again and comes whole."""
    import urllib.request

    gate = tmp_path / "gate"
    monkeypatch.setenv("CAMSIM_TEST_GATE", str(gate))
    launcher = ARTIFACTS.parent / "tests" / "serve_gated_build.py"
    with explorer_server(launcher=launcher, extra_args=["--no-spare-page", "--no-upload"]) as url:
        for _ in range(2):  # two pages that begin alike: the server then sends that beginning first
            with urllib.request.urlopen(url, timeout=120) as answer:
                assert answer.status == 200

        def scripts_run_before_the_build(pw):
            wait_until(lambda: pw.evaluate("() => typeof Bokeh !== 'undefined' && document.readyState"),
                       until=lambda state: state == "loading", what="Bokeh's script run while the page still loads")
            # Panel's script comes after Bokeh's (its entry is listed once it has loaded): waited for, not read
            # the moment Bokeh's has run (it was missing once, in a run of the whole suite)
            names = wait_until(lambda: pw.evaluate("performance.getEntriesByType('resource').map(r => r.name)"),
                               until=lambda n: any("bokeh.min.js" in x for x in n) and any("panel.min.js" in x for x in n),
                               what="Bokeh's and Panel's scripts loaded while the page still loads")
            assert pw.evaluate("document.readyState") == "loading", names  # the build still waits on the gate
            assert not gate.exists()
            gate.touch()

        pg = Page(browser, url + "?noise_sigma=3", while_loading=scripts_run_before_the_build)
        try:
            assert pg.session_made() == "built"
            assert pg.status()["params"]["noise_sigma"] == 3
            assert pg.errors() == []
        finally:
            pg.close()
        gate.unlink()  # a page whose head is not the one sent first: the browser asks again and gets it whole
        other = Page(browser, url + "?noise_sigma=2&camsim_test_title=Another+head",
                     while_loading=lambda pw: gate.touch())
        try:
            assert other.status()["params"]["noise_sigma"] == 2 and other.page.title() == "Another head"
            assert other.errors() == []
        finally:
            other.close()
        assert "did not begin as its head sent first; the browser asks again" in server_log(url)


def test_page_loads_without_console_errors(page):
    s = page.status()
    page.shot("explorer-loaded")
    assert page.errors() == []
    assert s["params"]["scene"] == "cacaphony290" and s["params"]["camera"] == "kodak-dcs200-ir"
    assert s["shape"] == [233, 372]  # cacaphony290 through the DCS-200 at 3.32 m
    assert s["mean_de"] > 0 and s["median_de"] > 0
    assert page.alert_text() == ""
    assert "mean dE" in page.text(".camsim-stats")
    scripts = page.page.evaluate("performance.getEntriesByType('resource').map(r => r.name)")
    assert any("bokeh.min.js" in name for name in scripts)  # the list is the page's resources
    assert not [name for name in scripts if "mathjax" in name.lower()]  # 1.8 MB the page does not need
    # the icon is in the page: Chromium fetched a linked one again after every change of the address (one
    # request to the server's event loop per move, made by the browser itself, so not among the page's)
    icons = page.page.evaluate("[...document.querySelectorAll('link[rel~=icon]')].map(l => l.href)")
    assert icons and all(href.startswith("data:image/svg+xml,") for href in icons)


SPARE_BUILT = "a spare page for / built"


def _png(data):
    from io import BytesIO

    from PIL import Image

    return np.asarray(Image.open(BytesIO(data)).convert("RGB"), dtype=float)


def test_a_page_built_in_advance_is_the_page_a_request_builds(browser, server):
    """The plain address gets a session the server built while idle; a link with parameters gets one built for
    it. Both show the same result, pixel for pixel; the prepared one loads its styles from this server, answers
    changes, and the server prepares the next one once the page has connected."""
    built_before = wait_for_log(server, SPARE_BUILT)
    spare = Page(browser, server)
    try:
        assert spare.session_made() == "spare"
        assert spare.errors() == []  # a stylesheet from elsewhere would be a failed load here
        names = spare.page.evaluate("performance.getEntriesByType('resource').map(r => r.name)")
        foreign = [n for n in names if not n.startswith(server.rstrip("/")) and not n.startswith("data:")]
        assert foreign == []
        linked = Page(browser, server + "?scene=cacaphony290")  # the default scene, named in the link
        try:
            assert linked.session_made() == "built"
            assert linked.status()["params"] == spare.status()["params"]
            assert linked.status()["mean_de"] == spare.status()["mean_de"]
            for key in ("raw", "rendered", "de"):  # once both canvases have drawn the data that arrived
                def same(key=key):
                    a = _png(settled_shot(spare, f".camsim-{key}-plot", name=f"spare-page-{key}"))
                    b = _png(settled_shot(linked, f".camsim-{key}-plot"))
                    assert a.shape == b.shape and np.abs(a - b).mean() < 0.5, key

                eventually(same, timeout=30)
        finally:
            linked.close()
        before = spare.status()["mean_de"]
        spare.type_number("w-noise", 6)
        s = spare.wait_for(lambda s: s["params"]["noise_sigma"] == 6 and not s.get("computing"))
        assert s["mean_de"] > before
        wait_for_log(server, SPARE_BUILT, built_before + 1)  # the next visitor's page
    finally:
        spare.close()
    assert "Traceback" not in server_log(server)


def test_a_shared_url_restores_the_same_parameters(browser, page, server):
    page.type_number("w-noise", 3)
    page.select("w-render", "illuminant")
    page.select("w-mosaic", "RGGB")
    first = page.wait_for(lambda s: s["params"]["noise_sigma"] == 3 and s["params"]["render_method"] == "illuminant"
                          and s["params"]["mosaic"] == "RGGB")
    page.page.wait_for_function("() => window.location.search.includes('mosaic=RGGB')", timeout=30000)
    url = page.page.url
    assert "noise_sigma=3" in url and "render_method=illuminant" in url and "mosaic=RGGB" in url
    second = Page(browser, url)
    try:
        restored = second.wait_for(lambda s: s["params"]["mosaic"] == "RGGB")
        second.shot("shared-url")
        assert restored["params"] == first["params"]
        assert restored["mean_de"] == first["mean_de"] and restored["rendered_hash"] == first["rendered_hash"]
    finally:
        second.close()


def test_two_pages_at_once_keep_separate_states(browser, server):
    a, b = Page(browser, server), Page(browser, server)
    try:
        a.type_number("w-noise", 8)
        sa = a.wait_for(lambda s: s["params"]["noise_sigma"] == 8)
        b.select("w-render", "illuminant")
        sb = b.wait_for(lambda s: s["params"]["render_method"] == "illuminant")
        sa2 = a.status()
        a.shot("session-a")
        b.shot("session-b")
        assert sb["params"]["noise_sigma"] == 0 and sa2["params"]["render_method"] == "baseline"
        assert sa2["params"]["noise_sigma"] == 8 and sa2["mean_de"] == sa["mean_de"]
        assert sa["raw_hash"] != sb["raw_hash"]
    finally:
        a.close()
        b.close()


#: Counts, in the browser, the layouts of the page's roots: Bokeh lays a root (and every view in it) out again
#: when one of its elements changes size, visibility or classes. ``window.__bodyLayouts`` counts those of the
#: root holding the views (the body), ``window.__rootLayouts`` those of every root.
_COUNT_LAYOUTS_JS = """() => {
  const V = Bokeh.require("models/layouts/layout_dom").LayoutDOMView;
  const doc = Bokeh.documents[0];
  const body = doc.roots().find(r => [...r.references()].some(m => (m.css_classes || []).includes('camsim-grid')));
  if (!body) return false;
  window.__bodyLayouts = 0; window.__rootLayouts = 0;
  const invalidate = V.prototype.invalidate_layout;
  V.prototype.invalidate_layout = function() {
    if (!(this.parent instanceof V)) { window.__rootLayouts++; if (this.model === body) window.__bodyLayouts++; }
    return invalidate.apply(this, arguments);
  };
  return true; }"""


def test_notices_refusals_and_the_busy_mark_leave_the_views_unlaid_out(page):
    """A chart pick (its notice, the busy mark over the views, the result) and a refused value (the alert shown,
    then cleared) change no size in the page's body: the browser does not lay the views out again for them
    (each layout of the body is 80-160 ms of a 2-core machine's browser; a chart pick made four, while the
    engine computed beside it). The alert and the notice are roots of their own; the busy mark is a style."""
    assert page.page.evaluate(_COUNT_LAYOUTS_JS), "no root of the page holds the views' grid"
    page.select("w-scene", "slanted-edge")
    page.wait_for(lambda s: str(s["params"]["scene"]).startswith("slanted-edge") and not s["computing"])
    wait_until(lambda: page.page.evaluate("window.__rootLayouts") >= 1, 30, "the notice is laid out")
    assert "Chart sized to the frame" in pane_text(page, ".camsim-notice")
    page.type_number("w-noise", "abc")
    page.wait_for_alert("Noise sigma")
    page.type_number("w-noise", 3)
    page.wait_for(lambda s: s["params"]["noise_sigma"] == 3 and not s["computing"])
    wait_until(page.alert_text, 30, "the alert is cleared", until=lambda text: text == "")
    next_frames(page)
    assert page.page.evaluate("window.__bodyLayouts") == 0


def test_a_change_during_a_long_computation_ends_with_the_last_change(page):
    page.type_number("w-distance", 0.5)  # a long computation (about 20 x the pixels)
    # the panes show it running (the busy mark comes once it has run 250 ms) before the next change is made
    running = wait_until(lambda: (loading_count(page), bool(page.status().get("computing"))), 60,
                         "the long computation shows as running", until=lambda r: r[0] > 0 or r[1])
    page.type_number("w-noise", 7)  # made while it runs
    seen_loading, seen_computing, most = running[0] > 0, running[1], running[0]
    label = busy_label(page) if running[0] else None
    deadline = 120
    t0 = time.monotonic()
    while time.monotonic() - t0 < deadline:
        s = page.status()
        seen_computing |= bool(s.get("computing"))
        marks = loading_count(page)
        seen_loading |= marks > 0
        most = max(most, marks)
        if marks and label is None:
            label = busy_label(page)  # what the grid draws over the previous images
        if s["params"]["distance"] == 0.5 and s["params"]["noise_sigma"] == 7 and not s["computing"]:
            break
        time.sleep(POLL)
    final = page.status()
    assert final["params"]["distance"] == 0.5 and final["params"]["noise_sigma"] == 7 and not final["computing"]
    # The panes' loading state is what the user sees; the status pane's "computing" flag may be
    # sent only with the result on a fast machine, so it is recorded but not required.
    assert seen_loading, f"no loading state seen (status computing seen: {seen_computing})"
    # one mark over the views, not one a view: each mark lays the whole page out again in the browser (six of
    # them took 0.3 s to show and 0.3 s to clear, half of a chart pick)
    assert most == 1, most
    # the mark is drawn: a still label over a veil on the grid (not Panel's spinner, which repaints every frame)
    assert label is not None and "Computing..." in label[0] and label[1] != "none", label
    assert loading_count(page) == 0 and busy_label(page) == ["none", "none"]
    assert page.alert_text() == ""


RAW_SOURCE_JS = """() => {
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.name === 'camsim-raw-figure') {
      const d = m.renderers.find(g => g.data_source && g.data_source.data.dw).data_source.data;
      const img = d.image[0];
      return {shape: img.shape ? Array.from(img.shape) : [img.length, img[0].length],
              x: d.x[0], y: d.y[0], dw: d.dw[0], dh: d.dh[0], x_range: [m.x_range.start, m.x_range.end]};
    }
  }
  return null;
}"""


def test_a_result_larger_than_the_screen_is_sent_averaged_and_zooming_in_fetches_detail(browser):
    """With views of at most 120 pixels a side, the default 233 x 372 raw arrives as 4 x 4 block means over the
    whole image; wheel-zooming into the raw view brings the region in view in more detail, placed where it lies."""
    with explorer_server(extra_args=["--max-view-side", "120"]) as url:
        pg = Page(browser, url)
        try:
            whole = pg.page.evaluate(RAW_SOURCE_JS)
            assert max(whole["shape"]) <= 120 and (whole["dw"], whole["dh"]) == (372, 233)
            assert whole["dw"] / whole["shape"][1] == pytest.approx(4, rel=0.02)  # 4 image pixels a view pixel
            for key in ("raw", "rendered"):  # once the canvas has drawn the data that arrived
                shot_until(pg, f".camsim-{key}-plot", lambda png: background_share(png) < 0.5,
                           f"the averaged {key} view is not mostly blank", name=f"averaged-{key}")
            box = pg.page.locator(".camsim-raw-plot").first.bounding_box()
            pg.page.mouse.move(box["x"] + box["width"] * 0.4, box["y"] + box["height"] * 0.5)
            for _ in range(3):  # about three times closer: ~120 of the 372 columns in view
                start = pg.page.evaluate(RAW_SOURCE_JS)["x_range"]
                pg.page.mouse.wheel(0, -250)
                wait_until(lambda: pg.page.evaluate(RAW_SOURCE_JS)["x_range"], 30, "the wheel zooms the raw view in",
                           until=lambda r: r[1] - r[0] < start[1] - start[0])
            near = wait_until(lambda: pg.page.evaluate(RAW_SOURCE_JS), 30, "detail arrives after zooming in",
                              until=lambda near: near["dw"] < 372 and near["dw"] / near["shape"][1] < 2)
            span = near["x_range"][1] - near["x_range"][0]
            print(f"zoomed in to {span:.0f} columns: {near}")
            assert span < 240 and near["x"] <= near["x_range"][0] and near["x"] + near["dw"] >= near["x_range"][1]
            shot_until(pg, ".camsim-raw-plot", lambda png: background_share(png) < 0.5,
                       "the zoomed raw view is not mostly blank", name="zoomed-detail-raw")
            assert pg.errors() == []
        finally:
            pg.close()
