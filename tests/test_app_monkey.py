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

from app_helpers import (ARTIFACTS, CHROMIUM_ARGS, FIGURES_JS, IMAGE_VIEWS, Page, chromium_path, explorer_server,
                         figures, shows_whole_image)
from playwright.sync_api import TimeoutError as PlaywrightTimeout

pytestmark = pytest.mark.browser

STEPS = int(os.environ.get("CAMSIM_MONKEY_STEPS", "10"))
SEED = int(os.environ.get("CAMSIM_MONKEY_SEED", "11"))

SELECTS = {
    "scene": ("w-scene", ["cacaphony290", "bfgb128", "macbeth", "stripes", "slanted-edge", "zone-plate", "uniform",
                          "munsell", "photo-coffee"]),
    "camera": ("w-camera", ["kodak-dcs200", "kodak-dcs200-ir", "human-cones", "stockman-sharpe", "cie1931",
                            "gaussian-3", "gaussian-4", "mixture"]),
    "mosaic": ("w-mosaic", ["preset", "GRBG", "RGGB", "BGGR", "GBRG", "4-sensor grid", "none"]),
    "demosaic_method": ("w-demosaic", ["bilinear", "freeman", "bayesian", "malvar2004", "menon2007"]),
    "render_method": ("w-render", ["baseline", "illuminant"]),
    "illuminant": ("w-illuminant", ["known", "gray-world", "max-rgb"]),
    "monitor": ("w-monitor", ["simtoolbox-test", "brainard-crt"]),
}
#: Refusals the engine documents: Bayer-only demosaicing on another tile; a tile naming a
#: sensor the camera lacks; a tile that never samples one of its sensors.
DOCUMENTED = ("Bayer", "sensor index", "never samples")


def _widget_value(page, key):
    """The value a select or number box shows in the page (None for other controls)."""
    if key in SELECTS:
        return page.page.locator(f".{SELECTS[key][0]} select").first.input_value()
    if key in ("distance", "alpha"):
        return page.page.locator(f".w-{key} input").first.input_value()
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
    figs = figures(page)
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
        assert blank < 0.5, f"step {step}: {key} view is {100 * blank:.0f} % background"


def test_random_walk_over_the_controls():
    rng = random.Random(SEED)
    ARTIFACTS.mkdir(exist_ok=True)
    from playwright.sync_api import sync_playwright

    with explorer_server() as url, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_path(), args=CHROMIUM_ARGS)
        page = Page(browser, url)
        page.page.set_viewport_size({"width": 1920, "height": 1080})
        try:
            expected = dict(page.status()["params"])
            for step in range(1, STEPS + 1):
                key = rng.choice(list(SELECTS) + ["distance", "metric", "alpha"])
                if key == "distance":
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
                s = page.wait_for(lambda s, k=key, v=value: not s["computing"] and
                                  (s["params"][k] == v or ("Refused" in page.alert_text() and
                                                           _widget_value(page, k) in (None, str(expected[k])))),
                                  timeout=240)
                if s["params"][key] == value:
                    expected[key] = value
                    assert page.alert_text() == "", f"step {step}: {key}={value!r}: {page.alert_text()}"
                else:  # refused: documented, and the widgets are back at the values shown
                    text = page.alert_text()
                    assert any(d in text for d in DOCUMENTED), f"step {step}: {key}={value!r}: {text}"
                    if key in SELECTS:
                        css = SELECTS[key][0]
                        page.page.wait_for_function("([el, v]) => el.value === v", arg=[
                            page.page.locator(f".{css} select").first.element_handle(), expected[key]])
                if key == "camera":  # a camera brings its own Gaussian defaults: take them as set
                    expected.update({k: s["params"][k] for k in ("gaussian_centers", "gaussian_widths")})
                assert s["params"] == expected, f"step {step}: computed {s['params']} != set {expected}"
                page.page.wait_for_timeout(200)
                _views_show_the_image(page, s, step)
                if step % 25 == 0 or step == STEPS:
                    page.shot(f"monkey-{step:03d}")
            assert page.errors() == []
        finally:
            page.close()
            browser.close()
