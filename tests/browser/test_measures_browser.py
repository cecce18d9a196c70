"""The explorer's measures in a real browser (issue 37): raising the light step by step never renders the image
darker nor, once the raw clips, gives a better score; a black frame's headline carries its warning, as large as
the dE. Playwright drives the system Chromium against ``camsim serve`` on 127.0.0.1; the page's status pane
(``.camsim-status``) gives the rendered image's mean luminance, the mean dE and the flags."""

import pytest

from app_helpers import server_log, wait_until

pytestmark = pytest.mark.browser


@pytest.fixture
def page(shared_page):
    """The module's page, as new for each test (``shared_page``: Start over, checked, between tests)."""
    return shared_page

#: Light levels (x the scene's) of the ladder: the default, then up to the widget's largest.
LIGHTS = (1, 2, 4, 8, 16, 32, 1000)


def _settled(page, name, value):
    """The status once the result for ``name == value`` is shown and nothing newer is computing."""
    return page.wait_for(lambda s: s["params"][name] == value and not s["computing"] and s.get("mean_de") is not None)


def test_more_light_never_renders_darker_nor_scores_better_once_clipped(page, server):
    first = _settled(page, "light", 1)
    assert first["params"]["exposure"] == 0.1 and first["flags"] == [] and first["clipped"] == 0
    ladder = [first]
    for light in LIGHTS[1:]:
        page.type_number("w-light", light)
        ladder.append(_settled(page, "light", light))
    page.shot("measures-light-1000")
    ys = [s["rendered_mean_y"] for s in ladder]
    des = [s["mean_de"] for s in ladder]
    assert all(b >= a for a, b in zip(ys, ys[1:])), ys  # never darker
    assert ys[-1] > 5 * ys[0]  # light 1000: a white frame, not a dark purple one
    clipped = [s["clipped"] > 0 for s in ladder]
    start = clipped.index(True)
    assert start >= 1 and all(clipped[start:])
    # once the raw clips the score never improves, and each clipped frame's headline says so
    assert all(b >= a for a, b in zip(des[start - 1:], des[start:])), des
    assert des[-1] > des[0]
    for s in ladder[start:]:
        assert any("clipped" in f for f in s["flags"]), s["flags"]
    stats = page.text(".camsim-stats")
    assert f"{des[-1]:.2f}" in stats and "fully clipped" in stats
    assert page.errors() == [] and "Traceback" not in server_log(server)


def test_a_black_frame_headline_carries_its_warning_as_large_as_the_de(page):
    good = _settled(page, "exposure", 0.1)
    page.type_number("w-exposure", 0.0001)
    black = _settled(page, "exposure", 0.0001)
    page.shot("measures-black-frame")
    assert black["flags"] and black["flags"][0].startswith("black frame: 100 % of pixels at the black level")
    assert black["rendered_mean_y"] < 0.01 * good["rendered_mean_y"]
    # the warning stands beside the number, in the same paragraph and at the same size
    flag = page.page.locator(".camsim-stats strong.camsim-flag").first
    flag.wait_for(state="attached")
    number = page.page.locator(".camsim-stats p strong").nth(1)  # the metric's name, then the mean dE
    wait_until(lambda: number.inner_text() == f"{black['mean_de']:.2f}" and "black frame" in flag.inner_text(),
               what=f"the stats showing {black['mean_de']:.2f} and the black frame flag")
    size = "e => parseFloat(getComputedStyle(e).fontSize)"
    weight = "e => getComputedStyle(e).fontWeight"
    assert flag.evaluate(size) >= number.evaluate(size) and flag.evaluate(weight) == number.evaluate(weight)
    text = page.text(".camsim-stats")
    assert text.index(f"{black['mean_de']:.2f}") < text.index("black frame") < text.index("median")
    # back to the chapter's exposure: no warning left
    page.type_number("w-exposure", 0.1)
    again = _settled(page, "exposure", 0.1)
    assert again["flags"] == [] and page.page.locator(".camsim-stats strong.camsim-flag").count() == 0
