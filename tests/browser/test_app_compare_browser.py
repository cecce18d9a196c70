"""The Compare designs tab in a real browser: pin DCS-200 and human cones, share the comparison by link,
sweep noise sigma. Numbers are checked against the engine's results for each configuration alone."""

import json

import pytest

from app_helpers import (ARTIFACTS, Page, active_tab, background_share, compare_status, eventually, next_frames,
                         shot_until, wait_compare, wait_until)
from camsim_core.review import evaluate_design

pytestmark = pytest.mark.browser

CAMERAS = {"DCS-200": "kodak-dcs200-ir", "human cones": "human-cones"}
SIGMAS = [0.0, 2.0, 4.0, 6.0, 8.0]


def open_tab(page):
    page.page.locator(".bk-tab").filter(has_text="Compare designs").first.click()


def pin(page, name):
    box = page.page.locator(".w-pin-name input").first
    box.fill(name)
    box.press("Enter")
    page.page.locator(".w-pin button").first.click()


@pytest.fixture(scope="module")
def compared(browser, server):
    """A page with DCS-200 and human cones pinned (the live design is human cones)."""
    page = Page(browser, server)
    open_tab(page)
    pin(page, "DCS-200")
    wait_compare(page, lambda s: s["pinned"] == ["DCS-200"])
    page.select("w-camera", "human-cones")
    page.wait_for(lambda s: s["params"]["camera"] == "human-cones")
    pin(page, "human cones")
    wait_compare(page, lambda s: [d["name"] for d in s["designs"]] == ["DCS-200", "human cones"] and not s["busy"])
    yield page
    page.close()


@pytest.fixture(scope="module")
def engine():
    return {name: evaluate_design({"camera": cam}, name) for name, cam in CAMERAS.items()}


_FIGURES = """() => {
  const out = {};
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.constructor && m.constructor.__name__ === 'Figure' && m.title && m.title.text) {
      const legends = m.center.filter(c => c.constructor.__name__ === 'Legend');
      const labels = legends.flatMap(l => l.items.map(i => i.label && (i.label.value || i.label.field)));
      const scatters = m.renderers.filter(r => r.visible && r.glyph && r.glyph.constructor.__name__ === 'Scatter').map(
        r => ({x: Array.from(r.data_source.data[r.glyph.x.field]), y: Array.from(r.data_source.data[r.glyph.y.field])}));
      const mappers = m.renderers.filter(r => r.glyph && r.glyph.color_mapper).map(r => [r.glyph.color_mapper.low, r.glyph.color_mapper.high]);
      out[m.title.text] = {x: m.x_range.id, y: m.y_range.id, legend: labels, scatters: scatters, mappers: mappers,
                           xr: [m.x_range.start, m.x_range.end], yr: [m.y_range.start, m.y_range.end]};
    }
  }
  return out;
}"""


def test_two_pinned_designs_side_by_side(compared, engine):
    page = compared
    s = compare_status(page)

    def check_figures():  # once the browser has the comparison's figures (they follow the status)
        figures = page.page.evaluate(_FIGURES)
        rendered = [k for k in figures if k.endswith(": rendered")]
        maps = [k for k in figures if " dE, 0 to " in k and ":" in k]
        assert sorted(rendered) == ["DCS-200: rendered", "human cones: rendered"]
        assert page.page.locator(".camsim-compare-rendered").filter(has=page.page.locator("canvas")).count() >= 2
        # shared zoom and pan: one x range and one y range for every image view
        ranges = {(figures[k]["x"], figures[k]["y"]) for k in rendered + maps}
        assert len(ranges) == 1
        # ... showing the whole image (not the corner of a placeholder's extent)
        h, w = next(iter(engine.values())).shape
        h, w = h / w, 1.0  # the tab shows every image in scene widths (designs of other pixel counts line up)
        xr, yr = figures[rendered[0]]["xr"], figures[rendered[0]]["yr"]
        assert xr[0] <= 0.05 * w and xr[1] >= 0.95 * w and yr[0] <= 0.05 * h and yr[1] >= 0.95 * h, (xr, yr, w, h)
        # one colour scale for every dE map, the one their titles say
        assert len(maps) == 2
        (scale,) = {tuple(m) for k in maps for m in figures[k]["mappers"]}
        assert all(k.endswith(f" dE, 0 to {scale[1]:g}") for k in maps) and scale[0] == 0, (maps, scale)
        # two histogram curves, each labelled with its mean and median
        hist = next(v for k, v in figures.items() if k.startswith("Overlaid"))
        labels = [lab for lab in hist["legend"] if lab]
        assert len(labels) == 2
        for (name, r), label in zip(engine.items(), labels):
            m = r.measures["cielab"]
            assert label == f"{name}: mean {m['mean']:.2f}, median {m['median']:.2f}"

    eventually(check_figures, timeout=30)
    # the table: the camera difference and two different mean dEs, equal to the engine's for each design alone
    assert s["differ"] == ["camera"]
    for d in s["designs"]:
        assert d["camera"] == CAMERAS[d["name"]] and d["measures"] == engine[d["name"]].measures
    means = [engine[n].measures["cielab"]["mean"] for n in CAMERAS]
    assert means[0] != means[1]
    table = page.page.locator(".camsim-compare-table table").first.inner_text()
    assert "kodak-dcs200-ir" in table and "human-cones" in table
    assert all(f"{m:.2f}" in table for m in means)
    assert page.errors() == []
    # the designs' progress bar, idle: in the page (its place kept, so filling it lays nothing out again) but not
    # drawn (an empty box beside the download button meant nothing to a reader)
    wait_until(lambda: page.page.locator(".camsim-compare-progress progress").first.evaluate(
        "e => getComputedStyle(e).visibility === 'hidden' && e.getClientRects().length > 0"),
        what="the idle progress bar kept in place and not drawn")
    next_frames(page)  # the figures checked above are drawn
    page.shot("compare-two-designs")
    page.page.locator(".camsim-tabs").first.screenshot(path=str(ARTIFACTS / "compare-tab.png"))  # docs/compare.png




def test_a_link_reproduces_the_comparison_and_opens_on_it(browser, compared):
    """A link made on the Compare tab opens on it (the tab is in the address): whoever opens a comparison shared
    sees it, without finding the tab; a tab opened later is written into the address in turn."""
    page = compared
    # the address follows the status in a message of its own: read it once it holds both designs (read once it
    # held "pinned=", it could still name the first alone, and the link then restored one design)
    page.page.wait_for_function("() => { const q = new URLSearchParams(window.location.search);"
                                " const p = q.get('pinned') || '';"
                                " return q.get('tab') === 'compare' && p.includes('DCS-200') && p.includes('human cones'); }",
                                timeout=30000)
    url = page.page.url
    first = compare_status(page)
    second = Page(browser, url)
    try:
        assert active_tab(second) == "Compare designs"  # no click: the link's tab
        s = wait_compare(second, lambda s: [d["name"] for d in s["designs"]] == ["DCS-200", "human cones"]
                         and not s["busy"])
        for css in (".camsim-compare-rendered", ".camsim-compare-de"):  # the designs drawn, not only counted
            shot_until(second, css, lambda png: background_share(png) < 0.5, f"the link's first design in {css} is drawn")
        second.shot("compare-shared-link")
        assert s["designs"] == first["designs"] and s["differ"] == ["camera"]
        second.page.locator(".bk-tab").filter(has_text="Scene").first.click()
        second.page.wait_for_function("() => window.location.search.includes('tab=scene')", timeout=30000)
        # the address rewritten keeps the designs in JSON, as the docs say (Panel's writer made them a Python repr)
        pinned = second.page.evaluate("() => new URLSearchParams(window.location.search).get('pinned')")
        assert [d["name"] for d in json.loads(pinned)] == ["DCS-200", "human cones"], pinned
        assert second.errors() == []
    finally:
        second.close()


def test_sweep_of_noise_gives_one_curve_per_design_with_the_engines_points(compared):
    page = compared
    page.select("w-sweep-parameter", "noise_sigma")
    box = page.page.locator(".w-sweep-values input").first
    box.fill(", ".join(f"{v:g}" for v in SIGMAS))
    box.press("Enter")
    page.page.locator(".w-sweep-run button").first.click()
    wait_compare(page, lambda s: s["sweep"] and len(s["sweep"]["points"]) == 2 * len(SIGMAS), timeout=240)
    expected = []
    for name, cam in CAMERAS.items():
        ys = [evaluate_design({"camera": cam, "noise_sigma": v}, name, metrics=("cielab",)).measures["cielab"]["mean"]
              for v in SIGMAS]
        expected.append((tuple(SIGMAS), tuple(ys)))
    expected.sort()

    def check_plot():  # once the browser has the sweep's plot (it follows the status)
        figures = page.page.evaluate(_FIGURES)
        plot = next((v for k, v in figures.items() if k.startswith("Mean CIELAB dE against")), None)
        assert plot is not None, "no sweep plot"
        assert len(plot["scatters"]) == 2  # two curves (points drawn as scatter over the lines)
        shown = sorted((tuple(c["x"]), tuple(c["y"])) for c in plot["scatters"])
        for (xs, ys), (ex, ey) in zip(shown, expected):
            assert list(xs) == list(ex) and ys == pytest.approx(ey, rel=1e-12, abs=1e-12)
        assert "Done: 10 points" in page.text(".camsim-sweep-message")

    eventually(check_plot, timeout=30)
    next_frames(page)  # the plot checked above is drawn
    page.shot("compare-sweep")
    assert page.errors() == []


_POINT_ON_SCREEN = """([title, x, y]) => {
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.constructor && m.constructor.__name__ === 'Figure' && m.title && m.title.text.startsWith(title)) {
      const view = Bokeh.index.find_one(m);  // a replaced plot may linger in the document without a view
      if (!view) continue;
      const box = view.el.getBoundingClientRect();
      return [box.left + view.frame.x_scale.compute(x), box.top + view.frame.y_scale.compute(y)];
    }
  }
  return null;
}"""


def test_a_click_on_a_sweep_point_loads_its_configuration(compared):
    page = compared
    s = wait_compare(page, lambda s: s["sweep"] and len(s["sweep"]["points"]) == 2 * len(SIGMAS))
    point = next(p for p in s["sweep"]["points"] if p["design"] == "DCS-200" and p["value"] == 6.0)
    mean = point["measures"]["cielab"]["mean"]
    page.page.locator(".camsim-sweep-plot").first.scroll_into_view_if_needed()
    xy = page.page.evaluate(_POINT_ON_SCREEN, ["Mean CIELAB dE against", 6.0, mean])
    assert xy is not None
    page.page.mouse.click(*xy)
    after = page.wait_for(lambda s: s["params"]["camera"] == "kodak-dcs200-ir" and s["params"]["noise_sigma"] == 6.0)
    assert after["mean_de"] == pytest.approx(mean, abs=1e-4)  # the live design is that point's configuration
