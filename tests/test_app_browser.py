"""The explorer in a real browser (issue 5): Playwright drives the system Chromium
against ``camsim serve`` started on 127.0.0.1. Screenshots go to ``test-artifacts/``.
"""

import pytest

from app_helpers import ARTIFACTS, CHROMIUM_ARGS, Page, chromium_path, explorer_server

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def server():
    ARTIFACTS.mkdir(exist_ok=True)
    with explorer_server() as url:
        yield url


@pytest.fixture(scope="module")
def browser():
    try:
        path = chromium_path()
    except RuntimeError as exc:
        pytest.fail(str(exc))
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture
def page(browser, server):
    pg = Page(browser, server)
    yield pg
    pg.close()


def test_page_loads_without_console_errors(page):
    s = page.status()
    page.shot("explorer-loaded")
    assert page.errors() == []
    assert s["params"]["scene"] == "cacaphony290" and s["params"]["camera"] == "kodak-dcs200-ir"
    assert s["shape"] == [233, 372]  # cacaphony290 through the DCS-200 at 3.32 m
    assert s["mean_de"] > 0 and s["median_de"] > 0
    assert page.alert_text() == ""
    assert "mean dE" in page.text(".camsim-stats")


def test_raising_noise_raises_the_mean_de_shown(page):
    before = page.status()
    assert before["params"]["noise_sigma"] == 0
    page.type_number("w-noise", 10)
    after = page.wait_for(lambda s: s["params"]["noise_sigma"] == 10)
    page.shot("noise-10")
    assert after["mean_de"] > before["mean_de"] + 1.0
    assert f"{after['mean_de']:.2f}" in page.text(".camsim-stats")
    # only the noise stage and later steps ran
    ran = [name for name, _ in after["ran"]]
    assert ran[:2] == ["stage:noise", "stage:digitize"] and "stage:sensor_responses" not in ran


def test_switching_rendering_method_changes_the_rendered_image(page):
    before = page.status()
    img_before = page.shot("rendered-baseline", ".camsim-rendered")
    page.select("w-render", "illuminant")
    after = page.wait_for(lambda s: s["params"]["render_method"] == "illuminant")
    page.page.wait_for_timeout(800)
    img_after = page.shot("rendered-illuminant", ".camsim-rendered")
    assert after["rendered_hash"] != before["rendered_hash"]
    assert after["raw_hash"] == before["raw_hash"]  # the camera image itself did not change
    assert img_after != img_before  # and the picture in the page changed


def test_choosing_the_four_sensor_grid_changes_the_mosaic_view(page):
    # four Gaussian sensors on a custom tile (the grid mirrored), then the 2 x 2 four-sensor grid
    page.select("w-camera", "gaussian-4")
    page.wait_for(lambda s: s["params"]["camera"] == "gaussian-4")
    page.select("w-mosaic", "custom")
    page.wait_for(lambda s: s["params"]["mosaic"] == "custom" or "never samples" in page.alert_text())
    box = page.page.locator(".w-tile input").first
    box.fill("3 2; 1 0")
    box.press("Enter")
    custom = page.wait_for(lambda s: s["tile"] == [[3, 2], [1, 0]])
    page.page.wait_for_timeout(800)
    raw_custom = page.shot("mosaic-gaussian4-custom", ".camsim-raw")
    page.select("w-mosaic", "4-sensor grid")
    grid = page.wait_for(lambda s: s["tile"] == [[0, 1], [2, 3]] and s["params"]["mosaic"] == "4-sensor grid")
    page.page.wait_for_timeout(800)
    raw_grid = page.shot("mosaic-gaussian4-grid", ".camsim-raw")
    assert grid["raw_hash"] != custom["raw_hash"]
    assert raw_grid != raw_custom
    assert page.alert_text() == ""


def test_a_tile_naming_a_missing_sensor_shows_a_message_and_keeps_the_last_result(page):
    good = page.status()  # DCS-200: three sensors
    page.select("w-mosaic", "4-sensor grid")
    page.page.locator(".camsim-alert").first.wait_for(state="visible", timeout=30000)
    page.shot("mosaic-refused")
    text = page.alert_text()
    assert "sensor index 3" in text and "3 sensors" in text
    s = page.status()
    assert s["raw_hash"] == good["raw_hash"] and s["tile"] == good["tile"] == [[1, 0], [2, 1]]
    page.select("w-mosaic", "RGGB")  # a good choice clears the message
    page.wait_for(lambda s: s["tile"] == [[0, 1], [1, 2]])
    page.page.locator(".camsim-alert").first.wait_for(state="hidden", timeout=30000)


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


def test_experiments_tab_runs_a_small_sweep(page):
    page.page.locator(".bk-tab").filter(has_text="Experiments").first.click()
    page.page.locator(".w-exp-alphas input").first.fill("0, 1")
    page.page.locator(".w-exp-alphas input").first.press("Enter")
    page.page.locator(".w-exp-sigmas input").first.fill("0")
    page.page.locator(".w-exp-sigmas input").first.press("Enter")
    page.page.locator(".w-exp-run button").first.click()
    page.page.locator(".camsim-exp-message p", has_text="Done").first.wait_for(timeout=90000)
    page.shot("experiments")
    assert "Done: 2 configurations" in page.text(".camsim-exp-message")
    assert page.errors() == []


_FIGURE_RANGES = """() => {
  const out = {};
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.constructor && m.constructor.__name__ === 'Figure' && m.title) {
      out[m.title.text] = [m.x_range.id, m.y_range.id];
    }
  }
  return out;
}"""


def test_image_views_share_zoom_and_pan(page):
    ranges = page.page.evaluate(_FIGURE_RANGES)
    images = [v for k, v in ranges.items() if k.split(" (")[0] in
              ("Raw mosaic", "Demosaiced", "Rendered", "Ideal image") or k.endswith("dE map")]
    assert len(images) == 5, ranges
    assert all(r == images[0] for r in images)  # one x range and one y range for all five: zoom and pan together
    hist = [v for k, v in ranges.items() if k.startswith("CIELAB dE:")]
    assert hist and hist[0] != images[0]  # the histogram keeps its own axes
