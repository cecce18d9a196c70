"""The explorer's "monkey" test: a seeded random walk over its controls in a real browser.

After each change settles: no message unless the engine documents the combination as
invalid (then the widgets are back at the values shown); every image view shows the
current image (its data has the current size, its view the whole image, and at least
half of its pixels differ from the background); the parameters the page reports as
computed equal those set. A screenshot every 25 steps goes to ``test-artifacts/``.

``make test`` runs a short walk; ``CAMSIM_MONKEY_STEPS=150`` runs the full one
(``CAMSIM_MONKEY_SEED`` picks another walk).
"""

import io
import os
import random

import numpy as np
import pytest
from PIL import Image

from app_helpers import ARTIFACTS, FIGURES_JS, IMAGE_VIEWS, Page, eventually, figures, next_frames, shows_whole_image
from playwright.sync_api import TimeoutError as PlaywrightTimeout

pytestmark = pytest.mark.browser

STEPS = int(os.environ.get("CAMSIM_MONKEY_STEPS", "10"))
SEED = int(os.environ.get("CAMSIM_MONKEY_SEED", "11"))

SELECTS = {
    "scene": ("w-scene", ["cacaphony290", "bfgb128", "macbeth", "stripes", "slanted-edge", "zone-plate", "uniform",
                          "munsell", "photo-coffee"]),
    "camera": ("w-camera", ["kodak-dcs200", "kodak-dcs200-ir", "human-cones", "stockman-sharpe", "cie1931",
                            "gaussian-3", "gaussian-4", "mixture", "imx174", "phone-1.4um"]),
    "mosaic": ("w-mosaic", ["preset", "GRBG", "RGGB", "BGGR", "GBRG", "4-sensor grid", "none"]),
    "demosaic_method": ("w-demosaic", ["bilinear", "freeman", "bayesian", "malvar2004", "menon2007"]),
    "render_method": ("w-render", ["baseline", "illuminant"]),
    "illuminant": ("w-illuminant", ["known", "gray-world", "max-rgb"]),
    "monitor": ("w-monitor", ["simtoolbox-test", "brainard-crt"]),
}
#: Refusals the engine documents: Bayer-only demosaicing on another tile; a tile naming a
#: sensor the camera lacks; a tile that never samples one of its sensors; a sensor field out of
#: its range, or a full well not above the read noise; a scene seen on under two mosaic tiles a side.
DOCUMENTED = ("Bayer", "sensor index", "never samples", "must be a number of", "not above the read noise",
              "too small to demosaic")
#: The Sensor card's fields (electron-level cameras): CSS class, and values a student might type
#: (in range, at the ends, beyond them; none is a shipped sheet's own value, which the design drops).
SENSOR = {
    "pixel_pitch_um": ("w-sensor-pitch", [0.5, 1.1, 2.93, 9, 20, 0.1, 50]),
    "full_well_e": ("w-sensor-well", [10, 2000, 50000, 1e7, 5, -1]),
    "read_noise_e": ("w-sensor-read", [0, 1.5, 30, 1000, 5000]),
    "prnu_pct": ("w-sensor-prnu", [0, 2.5, 10, 100, 150]),
    "dark_current_e_per_s": ("w-sensor-dark", [0, 50, 1e6, -3]),
}


def _widget_value(page, key):
    """The value a select or number box shows in the page (None for other controls)."""
    if key in SELECTS:
        return page.page.locator(f".{SELECTS[key][0]} select").first.input_value()
    if key in ("distance", "alpha"):
        return page.page.locator(f".w-{key} input").first.input_value()
    return None


def _sensor_set(status, field, number):
    """Whether the design's sensor text (``"full_well_e=8000, read_noise_e=2"``) holds ``field`` at ``number``."""
    pairs = dict(item.split("=") for item in status["params"]["sensor"].split(", ") if item)
    return field in pairs and float(pairs[field]) == number


def _box_number(page, css):
    """The number a sensor field's box shows (thousands separators dropped)."""
    text = page.page.locator(f".{css} input").first.input_value().replace(",", "")
    try:
        return float(text)
    except ValueError:
        return None


def _views_show_the_image(page, status, step, settle=20.0):
    h, w = status["shape"]
    # the browser may still be drawing what arrived with the status: give it a bounded time,
    # then check (a view that never received the image fails below)
    try:
        page.page.wait_for_function(
            "([js, keys, wh]) => { const f = eval(js)(); return keys.every(k => f['camsim-' + k + '-figure'] &&"
            " f['camsim-' + k + '-figure'].dw === wh[0] && f['camsim-' + k + '-figure'].dh === wh[1]); }",
            arg=[FIGURES_JS, list(IMAGE_VIEWS), [w, h]], timeout=settle * 1000)
    except PlaywrightTimeout:
        pass

    def check():
        figs = figures(page)
        next_frames(page)  # what arrived is drawn
        png = Image.open(io.BytesIO(page.page.screenshot()))
        page_rgb = np.asarray(png.convert("RGB"), int)
        for key in IMAGE_VIEWS:
            f = figs[f"camsim-{key}-figure"]
            assert (f["dw"], f["dh"]) == (w, h), f"step {step}: {key} holds an old image {f}"
            assert shows_whole_image(f, w, h), f"step {step}: {key} does not show the whole image {f}"
            box = page.page.locator(f".camsim-{key}-plot").first.bounding_box()
            x0, y0 = int(box["x"]), int(box["y"])
            crop = page_rgb[y0:y0 + int(box["height"]), x0:x0 + int(box["width"])]
            assert crop.size, f"step {step}: {key} view is off screen"
            blank = float(np.mean(np.all(np.abs(crop - 255) <= 8, axis=-1)))
            # a view of a saturated camera image is white where it clips (the warning line says so): the
            # camera's views may then look like the background; the ideal image and the dE map may not
            saturated = status["clipped"] > 0.25 and key in ("raw", "demosaiced", "rendered")
            assert blank < 0.5 or saturated, f"step {step}: {key} view is {100 * blank:.0f} % background"

    # the canvases draw the data that arrived (a view that never draws it fails after the bounded time)
    eventually(check, timeout=settle)


def test_random_walk_over_the_controls(browser, server):
    rng = random.Random(SEED)
    ARTIFACTS.mkdir(exist_ok=True)
    page = Page(browser, server)
    page.page.set_viewport_size({"width": 1920, "height": 1080})
    try:
        expected = dict(page.status()["params"])
        walked = []
        for step in range(1, STEPS + 1):
            key = rng.choice(list(SELECTS) + ["distance", "metric", "alpha", "sensor"])
            field = None
            if key == "sensor" and expected["camera"] not in ("imx174", "phone-1.4um"):
                # the fields are disabled for the chapter's cameras: go to an electron-level one first
                key, value = "camera", rng.choice(["imx174", "phone-1.4um"])
                page.select("w-camera", value)
            elif key == "sensor":
                header = page.page.locator(".card-header", has_text="Sensor (electrons)").first
                if not page.page.locator(".w-sensor-well input").count():
                    header.click()  # the card makes its fields when first opened
                field = rng.choice(list(SENSOR))
                css, values = SENSOR[field]
                number = float(rng.choice(values))
                page.type_number(css, number)
                value = (field, number)
            elif key == "distance":
                value = round(rng.uniform(0.5, 10.0), 2)
                page.type_number("w-distance", value)
            elif key == "metric":
                value = "S-CIELAB" if expected["metric"] == "CIELAB" else "CIELAB"
                page.page.locator(".w-metric button", has_text=value).first.click()
            elif key == "alpha" and expected["camera"] == "mixture":
                value = round(rng.uniform(0, 1), 1)
                page.type_number("w-alpha", value)
            elif key == "alpha":
                key, value = "camera", "mixture"
                page.select("w-camera", value)
            else:
                css, values = SELECTS[key]
                value = rng.choice([v for v in values if v != expected[key]])
                if page.page.locator(f".{css} select").first.is_disabled():
                    continue  # an inert control (e.g. the illuminant under baseline rendering)
                page.select(css, value)
            # settled: computed as set, or refused with the widget back at the value shown (an
            # earlier refusal may still be on screen, so the message alone does not say this one came)
            def settled(s, k=key, v=value):
                if k == "sensor":  # the field is in the design's sensor text, or refused with the box put back
                    return not s["computing"] and (_sensor_set(s, *v) or ("Refused" in page.alert_text() and
                                                                          _box_number(page, SENSOR[v[0]][0]) != v[1]))
                return not s["computing"] and (s["params"][k] == v or ("Refused" in page.alert_text() and
                                                                       _widget_value(page, k) in (None, str(expected[k]))))

            try:
                s = page.wait_for(settled, timeout=240)
            except AssertionError as exc:
                raise AssertionError(f"step {step}: {key}={value!r} never settled (walk: {walked}); "
                                     f"alert {page.alert_text()!r}; {exc}") from None
            if key == "sensor" and _sensor_set(s, *value):
                expected["sensor"] = s["params"]["sensor"]  # the field joins the others set before
                assert page.alert_text() == "", f"step {step}: {value}: {page.alert_text()}"
            elif key == "sensor":
                text = page.alert_text()
                # the message names the field typed, or says the full well would not be above the read noise
                assert field in text or "not above the read noise" in text, f"step {step}: {value}: {text}"
                assert any(d in text for d in DOCUMENTED), f"step {step}: {value}: {text}"
                assert s["params"]["sensor"] == expected["sensor"]
            elif s["params"][key] == value:
                expected[key] = value
                assert page.alert_text() == "", f"step {step}: {key}={value!r}: {page.alert_text()}"
            else:  # refused: documented, and the widgets are back at the values shown
                text = page.alert_text()
                assert any(d in text for d in DOCUMENTED), f"step {step}: {key}={value!r}: {text}"
                if key in SELECTS:
                    css = SELECTS[key][0]
                    page.page.wait_for_function("([el, v]) => el.value === v", arg=[
                        page.page.locator(f".{css} select").first.element_handle(), expected[key]])
            if key == "camera":  # a camera brings its own Gaussian defaults and sensor sheet: take them as set
                expected.update({k: s["params"][k] for k in ("gaussian_centers", "gaussian_widths")})
                assert s["params"]["sensor"] == ""
                expected["sensor"] = ""
            assert s["params"] == expected, f"step {step}: computed {s['params']} != set {expected}"
            walked.append(key if key != "sensor" else field)
            _views_show_the_image(page, s, step)
            if step % 25 == 0 or step == STEPS:
                page.shot(f"monkey-{step:03d}")
        print(f"\nwalk (seed {SEED}): {', '.join(walked)}")
        assert page.errors() == []
    finally:
        page.close()
