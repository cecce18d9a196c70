"""The explorer as a newcomer finds it (issue 38): each defect found by a walk in Chromium, as a browser test."""

from __future__ import annotations

import time

import pytest

from app_helpers import ARTIFACTS, TIMEOUT, Page, explorer_server, server_log

pytestmark = [pytest.mark.browser, pytest.mark.slow]

# the MTF curves' colours, as the browser draws them (Bokeh's models in the page)
_MTF_LINES = """() => {
  const out = {};
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.constructor && m.constructor.__name__ === 'Legend') {
      for (const item of m.items) {
        const label = item.label && (item.label.value || item.label.field);
        const glyph = item.renderers[0] && item.renderers[0].glyph;
        if (label && glyph && glyph.line_color) out[label] = String(glyph.line_color.value || glyph.line_color);
      }
    }
  }
  return out;
}"""


@pytest.fixture(scope="module")
def server():
    ARTIFACTS.mkdir(exist_ok=True)
    with explorer_server() as url:
        yield url


def _until(fn, what, timeout=TIMEOUT):
    deadline = time.monotonic() + timeout
    while True:
        value = fn()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"never happened: {what}")
        time.sleep(0.1)


def test_image_quality_tab_opened_before_the_chart_follows_it(browser, server):
    """Defect 1: with the tab open, picking the slanted-edge chart broke the tab (AttributeError on the server,
    "cannot find a view for Legend" in the browser, the previous scene's text kept). Defect 8: the MTF curves
    are drawn R red, G green, B blue."""
    page = Page(browser, server)
    try:
        page.page.locator(".bk-tab").filter(has_text="Image quality").first.click()
        # the pane's paragraphs and tables (in its shadow root)
        quality = lambda: " ".join(page.page.locator(".camsim-quality p, .camsim-quality table").all_inner_texts())  # noqa: E731
        _until(lambda: "Pick the" in quality(), "the tab's hint for a scene without a chart")
        page.select("w-scene", "slanted-edge")
        page.wait_for(lambda s: s["params"]["scene"].startswith("slanted-edge") and not s["computing"])
        text = _until(lambda: (t := quality()) and "MTF50" in t and t, "the MTF table in the tab")
        assert "Pick the" not in text
        page.page.locator(".camsim-mtf").first.wait_for(state="visible")
        colours = _until(lambda: page.page.evaluate(_MTF_LINES) or None, "the MTF plot's legend")
        page.shot("quality-tab-slanted-edge")
        expect = {"R": "#d62728", "G": "#2ca02c", "B": "#1f77b4", "luminance": "black"}
        assert {k: v for k, v in colours.items() if k in expect} == {k: expect[k] for k in colours if k in expect}
        assert set(colours) & {"R", "G", "B"}, colours
        # and back to a scene without a chart, then the chart again: the tab still follows
        page.select("w-scene", "cacaphony290")
        _until(lambda: "Pick the" in quality(), "the hint again")
        page.select("w-scene", "slanted-edge")
        _until(lambda: "MTF50" in quality(), "the MTF table again")
        errors = [e for e in page.errors() if "Legend" in e[1] or "view" in e[1]]
        assert errors == []
        assert "Traceback" not in server_log(server) and "AttributeError" not in server_log(server)
    finally:
        page.close()
