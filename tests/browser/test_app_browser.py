"""The explorer in a real browser: Playwright drives the system Chromium
against ``camsim serve`` started on 127.0.0.1. Screenshots go to ``test-artifacts/``.
How the server gives pages (built in advance, links, two at once) is in ``test_page_serving_browser.py``.
"""

import time

import numpy as np
import pytest

from playwright.sync_api import TimeoutError as PlaywrightTimeout

from app_helpers import (FIGURES_JS, IMAGE_VIEWS, LABELS_CUT_JS, POLL, SPECTRA_JS, TIMEOUT, Page, active_tab, background_share,
                         eventually, figures, new_page, pane_text, settled_shot, shot_until, shot_until_changed,
                         shows_whole_image, stable_boxes, wait_compare, wait_until)

pytestmark = pytest.mark.browser


@pytest.fixture
def page(shared_page):
    """The module's page, as new for each test (``shared_page``: Start over, checked, between tests)."""
    return shared_page


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
    img_before = settled_shot(page, ".camsim-rendered", name="rendered-baseline")
    page.select("w-render", "illuminant")
    after = page.wait_for(lambda s: s["params"]["render_method"] == "illuminant")
    img_after = shot_until_changed(page, ".camsim-rendered", img_before, name="rendered-illuminant")
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
    raw_custom = settled_shot(page, ".camsim-raw", name="mosaic-gaussian4-custom")
    page.select("w-mosaic", "4-sensor grid")
    grid = page.wait_for(lambda s: s["tile"] == [[0, 1], [2, 3]] and s["params"]["mosaic"] == "4-sensor grid")
    raw_grid = shot_until_changed(page, ".camsim-raw", raw_custom, name="mosaic-gaussian4-grid")
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


def test_image_views_share_zoom_and_pan(page):
    figs = figures(page)
    images = [figs[f"camsim-{k}-figure"]["ranges"] for k in IMAGE_VIEWS]
    assert len(images) == 5
    assert all(r == images[0] for r in images)  # one x range and one y range for all five: zoom and pan together
    assert figs["camsim-hist-figure"]["ranges"] != images[0]  # the histogram keeps its own axes


# -- views follow the image ----------------------------------------------------
def _assert_views_show_whole_image(page, tag):
    s = page.status()
    h, w = s["shape"]
    # large images (13 MB at 0.5 m) may still be decoding when the small status arrives: wait, bounded
    try:
        page.page.wait_for_function(
            "([js, keys, wh]) => { const f = eval(js)(); return keys.every(k => f['camsim-' + k + '-figure'] &&"
            " f['camsim-' + k + '-figure'].dw === wh[0] && f['camsim-' + k + '-figure'].dh === wh[1]); }",
            arg=[FIGURES_JS, list(IMAGE_VIEWS), [w, h]], timeout=30000)
    except PlaywrightTimeout:
        pass  # the checks below say which view holds an old image
    figs = figures(page)
    for key in IMAGE_VIEWS:
        f = figs[f"camsim-{key}-figure"]
        assert (f["dw"], f["dh"]) == (w, h), (key, f)  # the data is the current image
        assert shows_whole_image(f, w, h), (key, f)  # and the view shows all of it
        # the canvas draws the data that arrived
        shot_until(page, f".camsim-{key}-plot", lambda png: background_share(png) < 0.5,
                   f"{key} view not mostly blank after {tag}", name=f"{tag}-{key}")


def test_distance_there_and_back_leaves_every_view_showing_the_whole_image(page):
    page.type_number("w-distance", 0.5)
    near = page.wait_for(lambda s: s["params"]["distance"] == 0.5 and not s["computing"], timeout=120)
    assert near["shape"][0] > 233 * 4  # much closer: many more pixels
    _assert_views_show_whole_image(page, "distance-0.5")
    page.type_number("w-distance", 3.32)
    back = page.wait_for(lambda s: s["params"]["distance"] == 3.32 and not s["computing"], timeout=120)
    assert back["shape"] == [233, 372]
    _assert_views_show_whole_image(page, "distance-3.32")
    assert page.errors() == []


def test_histogram_and_de_scale_follow_the_data(page):
    js = """() => { const out = {}; for (const m of Bokeh.documents[0]._all_models.values()) {
        if (m.type === 'LinearColorMapper' || (m.constructor && m.constructor.__name__ === 'LinearColorMapper'))
          out[m.id] = m.high; } return out; }"""
    s = page.status()
    highs = list(page.page.evaluate(js).values())
    assert any(abs(v - 20) > 0.5 for v in highs)  # not the fixed 0-20 scale by default
    page.page.locator(".w-de-scale button", has_text="fixed").first.click()
    highs = wait_until(lambda: list(page.page.evaluate(js).values()), 30, "a colour mapper's top is the fixed 20",
                       until=lambda highs: 20 in highs)
    assert 20 in highs
    assert s["mean_de"] > 0
    # back to the data's scale, after a change that widens it: the colour bar under the map follows
    page.page.locator(".w-de-scale button", has_text="data").first.click()
    page.type_number("w-noise", 8)
    page.wait_for(lambda st: st["params"]["noise_sigma"] == 8 and not st["computing"])
    bar = wait_until(lambda: page.page.evaluate("""() => { for (const m of Bokeh.documents[0]._all_models.values()) {
        if (m.name === 'camsim-de-colorbar') return [m.x_range.end, m.renderers[0].glyph.color_mapper.high]; } }"""),
                     30, "the colour bar shows the widened scale, its axis ending where the colours end",
                     until=lambda bar: bar[1] > 25 and bar[0] == pytest.approx(bar[1]))
    assert bar[1] > 25  # noise widened the dE scale
    assert bar[0] == pytest.approx(bar[1])  # the bar's axis ends where the map's colours end


# -- the page never lies --------------------------------------------------------
REFUSED_VALUES = [
    ("w-noise", 80, "noise sigma", "0"),
    ("w-exposure", 100, "exposure", "0.1"),
    ("w-fstop", 40, "f-stop", "11"),
    ("w-distance", -1, "distance", "3.32"),
    ("w-seed", -5, "seed", "0"),
    ("w-light", 5000, "light level", "1"),
]


def test_a_refused_value_gets_a_message_and_the_widget_returns(page):
    """Each value in turn on one page (a refusal leaves the parameters as they were, so each starts from the
    default page): its own message, naming the field and the value, and the widget back at the value shown."""
    shown = ""
    for css, value, name, kept in REFUSED_VALUES:
        if css == "w-seed":  # the seed acts (and is enabled) only with noise
            page.type_number("w-noise", 2)
            page.wait_for(lambda s: s["params"]["noise_sigma"] == 2 and not s["computing"])
        before = page.status()
        page.type_number(css, value)
        page.page.locator(".camsim-alert").first.wait_for(state="visible", timeout=30000)
        # this refusal's message (the one before it may still be on screen until it replaces it)
        text = wait_until(page.alert_text, 30, f"a message about {name} {value}",
                          until=lambda t: t != shown and name in t and str(value) in t)
        assert "Refused" in text and name in text and str(value) in text, css
        box = page.page.locator(f".{css} input").first
        page.page.wait_for_function("([el, v]) => parseFloat(el.value) === parseFloat(v)",
                                    arg=[box.element_handle(), kept], timeout=10000)
        assert page.status()["params"] == before["params"], css
        shown = text


# -- every camera and mosaic runs -------------------------------------------------
FULL_COLOUR = [("human-cones", "preset"), ("stockman-sharpe", "preset"), ("cie1931", "preset"),
               ("kodak-dcs200-ir", "none")]


def test_full_colour_cameras_run_without_demosaicing(page):
    """Each camera in turn on one page, each time from a mosaiced camera (DCS-200, GRBG) whose demosaicing
    label and enabled demosaic control are checked first, so each full-colour run must change them again."""
    for camera, mosaic in FULL_COLOUR:
        page.select("w-camera", camera)
        page.select("w-mosaic", mosaic)
        s = page.wait_for(lambda s: s["params"]["camera"] == camera and s["params"]["mosaic"] == mosaic
                          and not s["computing"])
        assert s["skipped"] == ["demosaic"] and s["tile"] is None and s["mean_de"] is not None, camera
        assert page.alert_text() == "", camera
        page.page.wait_for_function(_SHOWS_TEXT, arg=["LABEL", "not needed"], timeout=10000)
        assert page.page.locator(".w-demosaic select").first.is_disabled(), camera
        # the raw view's title says what it shows, and says it again when a mosaic is back
        page.page.wait_for_function(_SHOWS_TEXT, arg=["*", "Raw, no mosaic"], timeout=10000)
        page.select("w-camera", "kodak-dcs200-ir")
        page.select("w-mosaic", "GRBG")
        page.wait_for(lambda s: s["params"]["camera"] == "kodak-dcs200-ir" and s["params"]["mosaic"] == "GRBG"
                      and s["tile"] is not None and not s["computing"])
        page.page.wait_for_function(_SHOWS_TEXT, arg=["*", "Raw mosaic"], timeout=10000)
        assert not page.page.evaluate(_SHOWS_TEXT, ["*", "Raw, no mosaic"]), camera
        # back to a camera that demosaics: the next camera's checks are its own
        page.page.wait_for_function(f"() => !({_SHOWS_TEXT})(['LABEL', 'not needed'])", timeout=10000)
        page.page.wait_for_function("el => !el.disabled",
                                    arg=page.page.locator(".w-demosaic select").first.element_handle(), timeout=10000)


#: Whether an element (a tag name, or "*") anywhere in the page, shadow roots included, shows a text.
_SHOWS_TEXT = """([tag, text]) => { function deep(root) { for (const el of root.querySelectorAll('*')) {
    if ((tag === '*' || el.tagName === tag) && el.children.length === 0 && el.textContent.includes(text)) return true;
    if (el.shadowRoot && deep(el.shadowRoot)) return true; } return false; } return deep(document); }"""


def test_a_refused_combination_puts_the_widgets_back(page):
    page.select("w-demosaic", "malvar2004")
    page.wait_for(lambda s: s["params"]["demosaic_method"] == "malvar2004")
    page.select("w-camera", "gaussian-4")  # its 4-sensor grid is not a Bayer tile: malvar2004 refuses it
    page.page.locator(".camsim-alert").first.wait_for(state="visible", timeout=60000)
    assert "malvar2004" in page.alert_text()
    page.page.wait_for_function("el => el.value === 'kodak-dcs200-ir'",
                                arg=page.page.locator(".w-camera select").first.element_handle(), timeout=10000)
    assert page.status()["params"]["camera"] == "kodak-dcs200-ir"


# -- layout -------------------------------------------------------------------------
LAYOUT_SELECTORS = [f".camsim-{k}-plot" for k in IMAGE_VIEWS] + [".camsim-hist", ".camsim-tabs"]


def test_no_horizontal_scroll_and_images_use_the_width(page):
    """Each window size in turn on one page (the layout follows every resize)."""
    for width, height in [(1366, 768), (1920, 1080)]:
        page.page.set_viewport_size({"width": width, "height": height})

        def check():  # once the layout has followed the resize and settled
            *boxes, hist, tabs = stable_boxes(page, LAYOUT_SELECTORS)  # hist: the right column, below the dE map
            assert page.page.evaluate("document.documentElement.scrollWidth") <= width
            assert sum(b["width"] for b in boxes[:3]) > 0.55 * width, width  # three views per row fill the main area
            assert all(b["x"] + b["width"] <= width for b in boxes), width
            assert hist["x"] + hist["width"] <= tabs["x"] + tabs["width"] + 1, width

        eventually(check, timeout=30)
        page.shot(f"layout-{width}")


def test_presentation_mode_has_large_type_and_images(page):
    page.page.set_viewport_size({"width": 1366, "height": 768})
    small = stable_boxes(page, [".camsim-rendered-plot"])[0]["width"]
    page.page.locator(".w-present button").first.click()
    size = lambda sel: float(page.page.locator(sel).first.evaluate("e => parseFloat(getComputedStyle(e).fontSize)"))
    titles = page.page.locator(".camsim-tabs .bk-tab")

    def check():  # once the page has switched to presentation mode and its layout has settled
        assert size(".camsim-stats p") >= 18
        assert size(".camsim-rendered-label div") >= 18 or size(".camsim-rendered-label") >= 18
        assert size(".w-noise label") >= 18
        rendered, tabs = stable_boxes(page, [".camsim-rendered-plot", ".camsim-tabs"])
        assert rendered["width"] > 1.3 * small
        assert page.page.evaluate("document.documentElement.scrollWidth") <= 1366
        # every tab title is in sight (a second row of titles rather than one cut off at the edge)
        assert titles.count() == 7
        for i in range(titles.count()):
            box = titles.nth(i).bounding_box()
            assert box["x"] >= tabs["x"] - 1 and box["x"] + box["width"] <= tabs["x"] + tabs["width"] + 1, (
                titles.nth(i).text_content(), box, tabs)

    eventually(check, timeout=30)
    page.shot("presentation-mode")


def test_chart_options_make_the_chart_a_link_reproduces_and_bad_ones_are_refused(browser, page):
    options = page.page.locator(".w-chart input").first
    assert not options.is_visible()  # a photo has no chart options
    page.select("w-scene", "slanted-edge")
    fitted = page.wait_for(lambda s: s["params"]["scene"].startswith("slanted-edge:") and not s["computing"])
    h, w = fitted["shape"]  # the camera image covers the chart: at least 80 % of the DCS-200's 1012 x 1524 frame
    assert h >= 0.8 * 1012 and w >= 0.8 * 1524, fitted["shape"]
    assert options.is_visible() and "angle=5.0" in options.get_attribute("placeholder")
    options.fill("angle=10, contrast=2, size=96")
    options.press("Enter")
    chosen = page.wait_for(lambda s: s["params"]["scene"] == "slanted-edge:angle=10,contrast=2,size=96")
    # the box then shows the options as the chart's name writes them (it arrives after the status, on a loaded
    # machine seconds after: waited for, not read once)
    wait_until(lambda: options.input_value() == "angle=10,contrast=2,size=96", 60,
               "the options box showing the chart's own spelling of its options")
    page.shot("chart-options")
    page.page.wait_for_function("() => window.location.search.includes('contrast%3D2') "
                                "|| window.location.search.includes('contrast=2')", timeout=30000)
    second = Page(browser, page.page.url)
    try:
        restored = second.wait_for(lambda s: s["params"]["scene"] == chosen["params"]["scene"])
        assert restored["mean_de"] == chosen["mean_de"] and restored["rendered_hash"] == chosen["rendered_hash"]
    finally:
        second.close()
    options.fill("size=100000")
    options.press("Enter")
    page.wait_for_alert("more than the")
    # the box shows the chart in use again: set on the tick after the refusal, so it may arrive after the alert
    wait_until(lambda: options.input_value() == "angle=10,contrast=2,size=96", 60,
               "the options box showing the chart in use again after a refusal")
    assert page.params()["scene"] == chosen["params"]["scene"]


def test_light_level_and_diffraction_optics_from_the_sidebar(page):
    before = page.status()
    page.type_number("w-light", 0.25)
    dim = page.wait_for(lambda s: s["params"]["light"] == 0.25 and not s["computing"])
    assert dim["raw_hash"] != before["raw_hash"] and dim["ran"][0][0] == "stage:sensor_responses"
    assert "mean level 6 %" in page.text(".camsim-warnings")  # a quarter of the default's 25 %
    page.select("w-optics", "diffraction")
    blurred = page.wait_for(lambda s: s["params"]["optics"] == "diffraction" and not s["computing"])
    assert blurred["ran"][0][0] == "stage:lens_sensor_responses" and blurred["raw_hash"] != dim["raw_hash"]
    assert page.alert_text() == "" and page.errors() == []


def _sensor_box(page, css):
    return page.page.locator(f".{css} input").first


def _number(text):
    """The number a box shows, or None for text that is not one (yet)."""
    try:
        return float(text)
    except ValueError:
        return None


def _box_shows(page, css, predicate, timeout=30.0):
    """Wait until the input of ``css`` shows a value (commas dropped) for which ``predicate`` holds."""
    box = _sensor_box(page, css)
    deadline = time.monotonic() + timeout
    while True:
        text = box.input_value().replace(",", "")
        if predicate(text, box):
            return text
        if time.monotonic() > deadline:
            raise AssertionError(f"{css} shows {text!r}")
        time.sleep(POLL)


def test_sensor_fields_of_an_electron_level_camera_from_the_sidebar(browser, page):
    from app_helpers import open_card

    open_card(page, "Sensor (electrons)", ".w-sensor-note")
    well = _sensor_box(page, "w-sensor-well")
    assert not well.is_visible()  # the chapter's DCS-200 is calibrated in digital units: no sensor fields
    note = page.page.locator(".w-sensor-note").first
    assert "digital units" in note.evaluate("e => (e.shadowRoot || e).textContent")
    page.select("w-camera", "imx174")
    own = page.wait_for(lambda s: s["params"]["camera"] == "imx174" and not s["computing"])
    _box_shows(page, "w-sensor-well", lambda text, box: box.is_visible() and text != "")
    _box_shows(page, "w-sensor-pitch", lambda text, box: _number(text) == 5.86)  # the sheet's values
    _box_shows(page, "w-sensor-well", lambda text, box: _number(text) == 32000)
    assert page.page.locator(".w-noise input").first.is_disabled()  # the sensor's own noise applies
    # half the pitch on the same sensor: twice the pixels a side, a quarter of the well
    page.type_number("w-sensor-pitch", 2.93)
    fine = page.wait_for(lambda s: s["params"]["sensor"] == "pixel_pitch_um=2.93" and not s["computing"])
    assert [round(f / o, 1) for f, o in zip(fine["shape"], own["shape"])] == [2.0, 2.0]
    _box_shows(page, "w-sensor-well", lambda text, box: text == "8000")
    # a full well below the read noise is refused, naming the field, and the box goes back
    page.type_number("w-sensor-well", 5)
    page.wait_for_alert("full_well_e")
    _box_shows(page, "w-sensor-well", lambda text, box: text == "8000")
    page.type_number("w-sensor-read", 2)
    quiet = page.wait_for(lambda s: s["params"]["sensor"] == "pixel_pitch_um=2.93, read_noise_e=2" and not s["computing"])
    assert quiet["raw_hash"] != fine["raw_hash"]
    # the link carries the sensor: another page shows the same raw
    page.page.wait_for_function("() => window.location.search.includes('read_noise_e')", timeout=30000)
    second = Page(browser, page.page.url)
    try:
        assert second.wait_for(lambda s: s["params"]["sensor"] == quiet["params"]["sensor"])["raw_hash"] == quiet["raw_hash"]
    finally:
        second.close()
    # back to a camera in digital units: the fields go, none left showing "NaN" (issue 38 defect 11)
    page.select("w-camera", "kodak-dcs200-ir")
    page.wait_for(lambda s: s["params"]["camera"] == "kodak-dcs200-ir" and not s["computing"])
    eventually(lambda: [_sensor_box(page, c).is_visible() for c in ("w-sensor-well", "w-sensor-pitch")] == [False, False])
    assert "digital units" in note.evaluate("e => (e.shadowRoot || e).textContent")
    page.shot("sensor-fields")
    # another camera starts from its own sheet
    page.select("w-camera", "phone-1.4um")
    phone = page.wait_for(lambda s: s["params"]["camera"] == "phone-1.4um" and not s["computing"])
    assert phone["params"]["sensor"] == ""
    _box_shows(page, "w-sensor-pitch", lambda text, box: text == "1.4")
    assert page.errors() == []


def test_save_and_share_downloads_what_the_page_shows_and_loads_parameters(page, tmp_path):
    import json as _json

    import tifffile
    from PIL import Image

    shown = page.status()
    page.page.locator(".card-header", has_text="Save and share").first.click()
    files = {}
    for css in ("w-png", "w-tiff", "w-csv", "w-json-download"):
        with page.page.expect_download(timeout=60000) as info:
            page.page.locator(f".{css} button").first.click()
        files[css] = tmp_path / info.value.suggested_filename
        info.value.save_as(files[css])
    h, w = shown["shape"]
    png = np.asarray(Image.open(files["w-png"]))
    assert files["w-png"].name == "rendered.png" and png.shape == (h, w, 3) and png.std() > 5  # a picture, not a flat field
    raw = tifffile.imread(files["w-tiff"])
    assert raw.shape == (h, w) and raw.dtype == np.uint16 and raw.max() <= 255  # the 8-bit raw as digital values
    de = np.loadtxt(files["w-csv"], delimiter=",")
    assert de.shape == (h, w) and abs(de.mean() - shown["mean_de"]) < 1e-3
    params = _json.loads(files["w-json-download"].read_text())
    assert {k: params[k] for k in shown["params"]} == shown["params"]
    # the file, edited, loads back: the page computes its parameters
    params["noise_sigma"] = 3.0
    edited = tmp_path / "edited.json"
    edited.write_text(_json.dumps(params))
    page.page.locator(".w-json-upload input[type=file]").first.set_input_files(str(edited))
    loaded = page.wait_for(lambda s: s["params"]["noise_sigma"] == 3.0 and not s["computing"])
    assert loaded["mean_de"] > shown["mean_de"] and page.alert_text() == ""
    # a file that is not JSON is refused with a message, the parameters stay
    (tmp_path / "bad.json").write_text("{not json")
    page.page.locator(".w-json-upload input[type=file]").first.set_input_files(str(tmp_path / "bad.json"))
    page.wait_for_alert("not JSON")
    assert page.params()["noise_sigma"] == 3.0


@pytest.fixture
def own_page(browser, server):
    """A page of its own, with a history of its own: the module's page (``shared_page``) holds the addresses of
    the tests before (going back twice from this test once landed on another test's ``noise_sigma=3``)."""
    from app_helpers import Page

    pg = Page(browser, server)
    yield pg
    pg.close()


def test_back_and_forward_show_the_page_of_the_address_they_go_to(own_page):
    """Panel's Location writes each design into the address but does not follow the browser's history: back and
    forward changed the address and left the page (design, dE, tab) as it was. Each now shows its address's
    page, as a link does."""
    from app_helpers import wait_until

    page = own_page

    def address():  # read in the page (Playwright's own URL may lag a same-document move)
        return page.page.evaluate("() => window.location.href")

    def following():  # the page's history follower has rendered (its script loads after the status is shown)
        wait_until(lambda: _evaluate_or_none(page, "() => !!window.__camsimHistory"), what="the history follower")

    first = page.wait_for(lambda s: not s.get("computing"))
    following()
    page.select("w-camera", "human-cones")
    cones = page.wait_for(lambda s: s["params"]["camera"] == "human-cones" and not s.get("computing"))
    wait_until(lambda: "camera=human-cones" in address(), what="the camera in the address")
    page.type_number("w-noise", 2)
    page.wait_for(lambda s: s["params"]["noise_sigma"] == 2 and not s.get("computing"))
    wait_until(lambda: "noise_sigma=2" in address(), what="the noise in the address")
    page.page.go_back()
    back = page.wait_for(lambda s: s["params"]["camera"] == "human-cones" and s["params"]["noise_sigma"] == 0
                         and not s.get("computing"))
    assert back["mean_de"] == cones["mean_de"] and "noise_sigma=2" not in address()
    following()  # the page reloaded
    page.page.go_back()
    start = page.wait_for(lambda s: s["params"]["camera"] == "kodak-dcs200-ir" and not s.get("computing"))
    assert start["mean_de"] == first["mean_de"] and start["raw_hash"] == first["raw_hash"]
    following()
    page.page.go_forward()
    page.wait_for(lambda s: s["params"]["camera"] == "human-cones" and s["params"]["noise_sigma"] == 0
                  and not s.get("computing"))
    wait_until(lambda: "camera=human-cones" in address(), what="forward's address")
    assert page.errors() == []


def _evaluate_or_none(page, script):
    """``page.page.evaluate(script)``, or None while the page navigates."""
    from playwright.sync_api import Error as PlaywrightError

    try:
        return page.page.evaluate(script)
    except PlaywrightError:
        return None


def test_start_over_gives_back_a_new_pages_design_and_keeps_the_pinned_ones(shared_page):
    """Start over: the design, the images, the tab and the address of a page just opened (the status the shared
    page had when it was opened, new, is the reference); the pinned designs stay."""
    page, new = shared_page, shared_page.fresh
    page.page.locator(".bk-tab").filter(has_text="Compare designs").first.click()
    box = page.page.locator(".w-pin-name input").first
    box.fill("before")
    box.press("Enter")
    page.page.locator(".w-pin button").first.click()
    wait_compare(page, lambda s: s["pinned"] == ["before"] and not s["busy"])
    wait_until(lambda: page.page.evaluate("() => window.location.search"), what="the pinned design in the address",
               until=lambda q: "pinned=" in q)
    page.select("w-scene", "bfgb128")  # a small scene: the pinned design is computed again for it
    page.wait_for(lambda s: s["params"]["scene"] == "bfgb128" and not s["computing"])
    page.select("w-camera", "gaussian-3")
    page.type_number("w-noise", 7)
    page.page.locator(".w-de-scale button").filter(has_text="fixed 0-20").first.click()
    changed = page.wait_for(lambda s: s["params"]["noise_sigma"] == 7 and s["params"]["camera"] == "gaussian-3"
                            and not s["computing"])
    assert changed["rendered_hash"] != new["rendered_hash"]
    page.page.locator(".bk-tab").filter(has_text="Scene").first.click()
    plane = page.page.locator(".camsim-scene-plane .bk-Canvas, .camsim-scene-plane canvas").first
    plane.wait_for(state="visible")
    box = wait_until(plane.bounding_box, what="the radiance plane laid out")
    page.page.mouse.click(box["x"] + 0.4 * box["width"], box["y"] + 0.4 * box["height"])
    wait_until(lambda: page.page.evaluate(SPECTRA_JS), what="a clicked pixel's spectrum")
    page.page.locator(".w-start-over button").first.click()
    back = page.wait_for(lambda s: s["params"] == new["params"] and not s["computing"])
    assert (back["raw_hash"], back["rendered_hash"], back["mean_de"]) == (new["raw_hash"], new["rendered_hash"],
                                                                          new["mean_de"])
    wait_until(lambda: active_tab(page), what="the Results tab shown", until=lambda t: t == "Results")
    # the widgets show the design computed, and the address the pinned design and the new page's values
    assert page.page.locator(".w-camera select").first.input_value() == "kodak-dcs200-ir"
    assert float(page.page.locator(".w-noise input").first.input_value()) == 0
    assert page.page.locator(".w-de-scale button.bk-active").first.inner_text() == "data"
    url = eventually(lambda: _address_of(new)(page.page.evaluate("() => window.location.href")))
    assert "before" in url
    settled_shot(page, name="start-over")
    # the Scene tab: the scene of a new page, and no spectra
    page.page.locator(".bk-tab").filter(has_text="Scene").first.click()
    wait_until(lambda: pane_text(page, ".camsim-scene-meta"), what="the Scene tab's table of the new page's scene",
               until=lambda text: "Name\tcacaphony290" in text)
    wait_until(lambda: page.page.evaluate(SPECTRA_JS), what="the Scene tab's spectra, none",
               until=lambda labels: labels == [])
    settled_shot(page, name="start-over-scene")
    assert page.errors() == []


def _address_of(new):
    """A check: the address holds the pinned designs, and every other parameter it holds at the value of the
    design ``new`` (a page's status); returns the address."""
    import json
    from urllib.parse import parse_qs, urlsplit

    def check(url):
        query = {k: v[0] for k, v in parse_qs(urlsplit(url).query).items()}
        assert "pinned" in query, url
        wanted = dict(new["params"], tab="results", de_scale="data")
        for key, text in query.items():
            if key == "pinned":
                continue
            want = wanted[key]
            assert (text if isinstance(want, str) else json.loads(text)) == want, (key, text, want)
        return url

    return check


def test_the_wavelength_slider_names_its_band_in_nm_and_shows_that_plane(page):
    # the slider counts the scene's bands; its title shows the band's wavelength, formatted in the browser
    page.page.locator(".bk-tab").filter(has_text="Scene").first.click()
    title = page.page.locator(".w-wavelength .bk-slider-title").first
    wait_until(lambda: title.inner_text().replace("\xa0", " "), what="the slider's title",
               until=lambda text: text.startswith("Wavelength (nm)") and text.rstrip().endswith(": 550"))
    page.page.locator(".w-wavelength .noUi-handle").first.focus()
    page.page.keyboard.press("ArrowRight")  # the next band, as a student's arrow key moves it
    wait_until(lambda: title.inner_text(), what="the title naming the next band",
               until=lambda text: text.rstrip().endswith(": 560"))
    wait_until(lambda: pane_text(page, ".camsim-scene-plane-label"), what="the plane at 560 nm",
               until=lambda text: text.startswith("Radiance at 560 nm"))
    # the tab's one-line labels whole, the plane's with the grey scale's top (it ran on past the view and was cut
    # there), here and in a 1366 px window
    for width in (page.viewport["width"], 1366):
        page.page.set_viewport_size({"width": width, "height": page.viewport["height"]})
        wait_until(lambda: page.page.evaluate(LABELS_CUT_JS), what=f"the Scene tab's labels whole at {width} px",
                   until=lambda t: t["labels"] >= 2 and not t["cut"])
    settled_shot(page, name="scene-wavelength")
    assert page.errors() == []




# Clicks the Scene tab from the page's first script on, as soon as its header is drawn (a student clicking while
# the page is still being laid out), and records whether Bokeh's document was still loading at that moment.
_CLICK_SCENE_AT_ONCE = """(() => {
  const timer = setInterval(() => {
    const tabs = [];
    const walk = root => { for (const el of root.querySelectorAll('*')) {
      if (el.classList.contains('bk-tab')) tabs.push(el); if (el.shadowRoot) walk(el.shadowRoot); } };
    walk(document);
    const scene = tabs.find(el => el.textContent.includes('Scene'));
    if (!scene) return;
    clearInterval(timer);
    const doc = window.Bokeh && Bokeh.documents && Bokeh.documents[0];
    window.camsimClickedWhileLoading = !!doc && !doc.is_idle;
    scene.click();
  }, 5);
})();"""


def test_a_tab_clicked_while_the_page_is_still_loading_shows_its_views(browser, server):
    # The page pulls its document, draws it and then reports itself ready. Panel dropped the changes a click
    # made in between (counting on the pull to carry them, which had gone): the tab stayed empty for good.
    page = new_page(browser)
    try:
        page.add_init_script(_CLICK_SCENE_AT_ONCE)
        page.goto(server)
        page.wait_for_function("() => window.camsimClickedWhileLoading !== undefined", timeout=TIMEOUT * 1000)
        assert page.evaluate("() => window.camsimClickedWhileLoading"), "the click came after the page was ready"
        meta = page.locator(".camsim-scene-meta").first
        meta.wait_for(state="visible", timeout=30_000)
        eventually(lambda: "cacaphony290" in meta.inner_text())
    finally:
        page.close()
