"""camsim in a notebook (issue 40): scenes and camera images show themselves, the explorer opens inline,
and the example notebook script runs.

The previews' colours are checked against colour-science's own spectral integration (``sd_to_XYZ``, ASTM
E308 weights) and against physics (D65 is sRGB's white), not against the code under test.
"""

from __future__ import annotations

import base64
import io
import re
import subprocess
import sys
from pathlib import Path

import colour
import numpy as np
import pytest
from PIL import Image

import camsim_core as cs
from camsim_core.datasets.illuminants import illuminant
from camsim_core.errors import ParameterError
from camsim_core.image import CameraImage
from camsim_core.scene import Scene

ROOT = Path(__file__).resolve().parents[2]
W = np.arange(400.0, 701.0, 10.0)


def _png(data):
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGB"))


def _html_png(text):
    """The one inline PNG of an HTML preview, decoded."""
    found = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", text)
    assert len(found) == 1
    return _png(base64.b64decode(found[0]))


def _white_and_red():
    """Left half a perfect white reflector under D65, right half the ColorChecker's red (Ohta) under D65."""
    red = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]["red"].copy().align(colour.SpectralShape(400, 700, 10))
    e = illuminant("D65").on(W)
    cube = np.empty((8, 8, W.size))
    cube[:, :4] = e
    cube[:, 4:] = e * red.values
    return Scene(cube, W, name="white & red <test>"), red


def test_scene_preview_is_srgb_of_the_radiance():
    scene, red = _white_and_red()
    rgb = _png(scene._repr_png_()).astype(float)
    # D65 is sRGB's white: the perfect reflector is white
    np.testing.assert_allclose(rgb[:, :4], 255, atol=1)
    # the red patch: colour-science's XYZ of the reflectance under D65 (white Y = 1), to sRGB
    xyz = colour.sd_to_XYZ(red, illuminant=colour.SDS_ILLUMINANTS["D65"]) / 100
    expected = np.clip(colour.XYZ_to_sRGB(xyz), 0, 1) * 255
    np.testing.assert_allclose(rgb[:, 4:].reshape(-1, 3), np.broadcast_to(expected, (32, 3)), atol=2)
    # and near the published sRGB of the ColorChecker's red (BabelColor: 175, 54, 60)
    assert np.abs(rgb[0, 7] - (175, 54, 60)).max() < 10


def test_scene_html_is_small_escaped_and_describes_the_scene():
    scene = Scene(np.ones((600, 300, W.size)), W, name="<script>alert(1)</script>", unit="W/sr/m^2 per band")
    text = scene._repr_html_()
    assert "<script>" not in text and "&lt;script&gt;alert(1)&lt;/script&gt;" in text
    for shown in ("600 x 300 pixels x 31 bands", "400-700 nm, 31 samples", "W/sr/m^2 per band"):
        assert shown in text
    picture = _html_png(text)
    assert max(picture.shape[:2]) <= 256 and picture.shape[0] == 2 * picture.shape[1]


def test_raw_mosaic_preview_colours_each_pixel_by_its_sensor():
    tile = np.array([[1, 0], [2, 1]])  # G R / B G
    raw = CameraImage(np.full((6, 6), 255.0), W, np.ones((3, W.size)), ("R", "G", "B"), tile=tile, bits=8,
                      mosaiced=True, name="raw")
    rgb = _png(raw._repr_png_())
    assert tuple(rgb[0, 1]) == (255, 0, 0) and tuple(rgb[0, 0]) == (0, 255, 0) and tuple(rgb[1, 0]) == (0, 0, 255)
    # half full scale, display gamma 2.2: 255 * 0.5 ** (1 / 2.2) = 186
    half = raw.replace(data=np.full((6, 6), 127.5))
    assert tuple(_png(half._repr_png_())[0, 1]) == (186, 0, 0)


def test_reduced_raw_preview_averages_whole_tiles():
    """A large uniform raw, reduced to 256 px: every preview pixel holds whole tiles, so no stripes."""
    raw = CameraImage(np.full((300, 900), 255.0), W, np.ones((3, W.size)), ("R", "G", "B"),
                      tile=np.array([[1, 0], [2, 1]]), bits=8, mosaiced=True)
    rgb = raw.preview()
    assert max(rgb.shape[:2]) <= 256
    np.testing.assert_allclose(rgb, np.broadcast_to([0.25, 0.5, 0.25], rgb.shape), atol=1e-6)


def test_rendered_and_spectral_images_show_themselves():
    rendered = CameraImage(np.array([[[255.0, 0, 0], [0, 0, 0]]]), np.array([]), space="monitor", name="shown")
    assert _png(rendered._repr_png_()).tolist() == [[[255, 0, 0], [0, 0, 0]]]
    text = rendered._repr_html_()
    assert "Rendered image" in text and "monitor" in text
    scene, _ = _white_and_red()
    spectral = cs.image_from_scene(scene)
    np.testing.assert_array_equal(_png(spectral._repr_png_()), _png(scene._repr_png_()))


def test_a_simulated_pipeline_shows_every_stage():
    scene = cs.load_scene("macbeth")
    camera = cs.load_camera("kodak-dcs200")
    raw = cs.simulate(scene, camera, exposure=cs.auto_exposure(scene, camera))
    shown = cs.render(cs.demosaic(raw), "simtoolbox-test")
    for image in (raw, shown):
        text = image._repr_html_()
        picture = _html_png(text)
        assert max(picture.shape[:2]) <= 256 and picture.std() > 0
        assert "x".join(str(v) for v in image.data.shape).replace("x", " x ") in text


def test_explorer_opens_for_a_scene_and_camera():
    pn = pytest.importorskip("panel")
    from camsim_explorer import show

    view = show(scene="macbeth", camera="kodak-dcs200", exposure=0.05)
    assert isinstance(view, pn.viewable.Viewable) and hasattr(view, "_repr_mimebundle_")  # what Jupyter shows
    state = view.state
    assert (state.scene, state.camera, state.exposure) == ("macbeth", "kodak-dcs200", 0.05)
    assert state.shown["camera"] == "kodak-dcs200" and state.shown["scene"] == "macbeth"
    assert state.result is not None and not state.message
    assert view.page.state is state and isinstance(view.page, pn.template.base.BaseTemplate)
    root = view.get_root()  # the Bokeh models a notebook cell receives, built without a browser
    assert type(root).__name__ == "Row" and len(root.children) == 2
    # later changes on the state are computed for the view
    state.camera = "cie1931"
    assert state.shown["camera"] == "cie1931"


def test_explorer_whole_page_on_request():
    pn = pytest.importorskip("panel")
    from camsim_explorer import show

    page = show(scene="macbeth", camera="kodak-dcs200", page=True)
    assert isinstance(page, pn.template.base.BaseTemplate) and page.state.shown["camera"] == "kodak-dcs200"


def test_explorer_refuses_unknown_names():
    pytest.importorskip("panel")
    from camsim_explorer import show

    with pytest.raises(ParameterError, match="camera"):
        show(scene="macbeth", camera="no-such-camera")
    with pytest.raises(ParameterError, match="scene"):
        show(scene="no-such-scene")
    with pytest.raises(ParameterError, match="colour"):
        show(scene="macbeth", colour="red")


def test_notebook_tour_example_runs(tmp_path):
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "notebook_tour.py"), str(tmp_path)],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "(233, 372) raw, mean S-CIELAB dE 12.87" in out.stdout  # the README's numbers
    for name in ("scene", "raw", "rendered", "ideal"):
        picture = _png((tmp_path / f"{name}.png").read_bytes())
        assert max(picture.shape[:2]) <= 256 and picture.std() > 0
        assert "data:image/png;base64," in (tmp_path / f"{name}.html").read_text(encoding="utf-8")


def test_empty_and_unshowable_images_still_describe_themselves():
    empty = Scene(np.zeros((0, 3, W.size)), W, name="empty")
    assert "0 x 3 pixels x 31 bands" in empty._repr_html_() and "base64" not in empty._repr_html_()
    assert empty._repr_png_() is None  # Jupyter then shows the text instead
    odd = CameraImage(np.ones((3, 4, 5, 6)), np.array([]), space="sensor", name="4-D")
    assert "3 x 4 x 5 x 6" in odd._repr_html_() and odd._repr_png_() is None
