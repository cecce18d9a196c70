"""The tab-order walk: every tab opened before and after each scene and camera change, every view current.

A student clicks through the tabs in any order and changes the scene or the
camera from whichever tab is open. After each change every tab must show the
result of the new design, whichever tab was open when it happened and
whether or not the tab had been built before. The changes come in pairs (a
scene, then a camera, each from another tab, the open tab checked after
each); every tab is then opened in turn: a tab left showing the scene or the
camera of before either change fails. Each tab is checked against
the status pane (the result shown) by a fact it prints:

- Results: the status pane's parameters are the design chosen, with a dE;
- Scene: the scene's name;
- Camera: the camera's name and the size of the image the status pane holds;
- Image quality: the mean dE it quotes is the status pane's;
- Optics & sensor: the exposure it lists is the status pane's;
- Compare designs and Experiments: their message (built, no error);

and on every tab, every plot's title fits over its plot (titles were cut at the toolbar), once the tab's
plots are drawn: Optics & sensor's diffraction MTF at the f-number shown (and the photon transfer of an
electron-level camera), Image quality's MTF on the slanted edge; none on the Experiments tab before a
run. (The check of the titles alone passed on a tab whose plots were not drawn yet.)

A screenshot of the Image quality tab for each chart goes to
``test-artifacts/walk-quality-CHART-CAMERA.png``.
"""

from __future__ import annotations

import pytest

from app_helpers import Page, cut_titles, eventually, pane_text, server_log, shown_titles

pytestmark = pytest.mark.browser

TABS = ("Results", "Scene", "Camera", "Image quality", "Compare designs", "Experiments", "Optics & sensor")
#: The changes, in pairs: (select box, value). Each is made with another tab open; every tab is opened after each pair.
CHANGES = [("w-scene", "macbeth"), ("w-camera", "gaussian-3"), ("w-scene", "slanted-edge"), ("w-camera", "imx174"),
           ("w-scene", "cacaphony290"), ("w-camera", "kodak-dcs200-ir")]
#: The changes made before each walk over every tab (two: a walk after each change took 55 tab visits, 59 s of CPU).
PAIR = 2
CHARTS = ("macbeth", "slanted-edge", "zone-plate", "stripes")
#: The electron-level cameras among CHANGES: the Optics & sensor tab plots their photon transfer.
PHOTON_CAMERAS = ("imx174",)

def _open(page, title):
    page.page.locator(".camsim-tabs .bk-tab").filter(has_text=title).first.click()


def _check_tab(page, title, want):
    """The tab ``title`` (open) shows the result of the design ``want`` ({scene, camera})."""
    s = page.wait_for(lambda s: not s.get("computing") and s.get("mean_de") is not None
                      and s["params"]["camera"] == want["camera"]
                      and s["params"]["scene"].partition(":")[0] == want["scene"])
    rows, cols = s["shape"]

    def check():
        if title == "Scene":
            text = pane_text(page, ".camsim-scene-meta")
            assert f"Name\t{want['scene']}" in text, text[:200]
        elif title == "Camera":
            text = pane_text(page, ".camsim-camera-info")
            assert text.startswith(want["camera"] + " ·"), text[:200]
            assert f"{rows} x {cols}" in text or f"{cols} x {rows}" in text, (text[:200], s["shape"])
        elif title == "Image quality":
            text = pane_text(page, ".camsim-quality")
            assert f"mean dE*ab {s['mean_de']:.2f}" in text, (text[-200:], s["mean_de"])
        elif title == "Optics & sensor":
            text = pane_text(page, ".camsim-physical-table")
            assert f"exposure\t{s['params']['exposure']:.6g}\ts" in text, (text[-120:], s["params"]["exposure"])
        elif title == "Compare designs":
            assert "Pin designs" in pane_text(page, ".camsim-sweep-message")
        elif title == "Experiments":
            assert "Figure 1.14" in pane_text(page, ".camsim-exp-message")
        titles = shown_titles(page)  # the plots each tab draws for this design are there before their titles count
        if title == "Optics & sensor":
            assert any(t.startswith(f"Diffraction MTF at f/{s['params']['f_stop']:g} ") for t in titles), titles
            assert any(t.startswith("Photon transfer") for t in titles) == (want["camera"] in PHOTON_CAMERAS), titles
        elif title == "Image quality" and want["scene"] == "slanted-edge":
            assert any(t.startswith("MTF50 ") for t in titles), titles
        elif title == "Experiments":
            assert titles == [], titles  # no empty axes before a run
        assert cut_titles(page) == []  # every plot's title over its plot, whole

    eventually(check, timeout=60)


def test_every_tab_shows_the_design_chosen_whatever_tab_was_open_and_in_any_order(browser, server):
    page = Page(browser, server)
    try:
        want = {"scene": "cacaphony290", "camera": "kodak-dcs200-ir"}
        for title in TABS:  # every tab once, before any change
            _open(page, title)
            _check_tab(page, title, want)
        for i, (css, value) in enumerate(CHANGES):
            during = TABS[(3 * i + 1) % len(TABS)]  # the tab open when the change is made
            _open(page, during)
            page.select(css, value)
            want[css.split("-")[1]] = value
            _check_tab(page, during, want)
            if (i + 1) % PAIR:
                continue
            walk = i // PAIR
            order = TABS[walk % len(TABS):] + TABS[:walk % len(TABS)]  # then every tab, starting somewhere else each time
            for title in (order if walk % 2 else order[::-1]):
                _open(page, title)
                _check_tab(page, title, want)
                if title == "Image quality" and want["scene"] in CHARTS:
                    page.shot(f"walk-quality-{want['scene']}-{want['camera']}")
        assert page.errors() == []
        # an empty plot (the Scene tab's spectra before a click, Experiments before a run, the photon transfer of a
        # camera in digital units) has ranges to show: Bokeh warned it "could not set initial ranges" at each visit
        assert [m for m in page.console if "initial ranges" in m[1]] == []
        log = server_log(server)
        assert "Traceback" not in log and "Exception" not in log
    finally:
        page.close()
