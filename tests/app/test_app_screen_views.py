"""Results larger than the screen: image views send block means of the image, and the region in view in
full detail when zoomed in (the full array is never sent)."""

import numpy as np
import pytest

import camsim_explorer.state as state_module
from camsim_explorer.state import ExplorerState, ServerLimits
from camsim_explorer.views import ResultsView, screen_part

SIDE = 100  # the default scene's raw is 233 x 372: 4 x 4 blocks fit it in 100 x 100


@pytest.fixture
def small_screen(monkeypatch):
    monkeypatch.setattr(state_module, "LIMITS", ServerLimits(max_view_side=SIDE))


@pytest.fixture
def view(small_screen):
    return ResultsView(ExplorerState())


def sent(view, key):
    d = view.sources[key].data
    return d["image"][0], (d["x"][0], d["y"][0], d["dw"][0], d["dh"][0]), d


def block_means(a, k):
    """Means of the whole k x k blocks of a (H, W[, C]) array, written out with reshape (independent of to_screen)."""
    h, w = (a.shape[0] // k) * k, (a.shape[1] // k) * k
    b = a[:h, :w].astype(float)
    return b.reshape(h // k, k, w // k, k, *a.shape[2:]).mean(axis=(1, 3))


def test_a_result_larger_than_the_screen_is_sent_as_block_means(view):
    raw = np.asarray(view.state.result.raw.data, float)[::-1]  # views hold the bottom row first
    h, w = raw.shape
    for key in ResultsView.KEYS:
        image, place, _ = sent(view, key)
        assert max(image.shape) <= SIDE and place == (0, 0, w, h)  # block means, stretched over the whole image
    _, _, data = sent(view, "raw")
    value = data["value"][0]
    assert value.shape == (-(-h // 4), -(-w // 4))
    np.testing.assert_allclose(value[: h // 4, : w // 4], block_means(raw, 4), rtol=1e-6)
    assert not data["sensor"][0].any() and "mean of 4 x 4 pixels" in view.sensor_hover.args["names"][0]
    rendered = np.asarray(view.state.result.rendered.data, float)[::-1]
    rgba = sent(view, "rendered")[0].view(np.uint8).reshape(-1, -(-w // 4), 4)
    np.testing.assert_allclose(rgba[: h // 4, : w // 4, :3], block_means(np.clip(np.rint(rendered), 0, 255), 4), atol=0.51)


def test_zooming_in_fetches_the_region_in_full_detail_and_zooming_out_the_whole_again(view):
    view.zoom_to(100, 160, 50, 100)  # 60 x 50 image pixels in view: they fit the screen one to one
    top, left, height, width = view.region
    assert top <= 50 and left <= 100 and top + height >= 100 and left + width >= 160  # the view, and a margin
    assert height <= SIDE and width <= SIDE
    raw = np.asarray(view.state.result.raw.data, float)[::-1]
    image, place, data = sent(view, "raw")
    assert place == (left, top, width, height) and image.shape == (height, width)
    np.testing.assert_array_equal(data["value"][0], raw[top : top + height, left : left + width])
    assert view.sensor_hover.args["names"] == list(view.state.result.raw.sensor_names)  # each pixel's sensor again
    for key in ResultsView.KEYS:
        assert sent(view, key)[1] == place
    view.zoom_to(-10, 400, -20, 250)  # all of it again
    assert view.region is None and sent(view, "raw")[1] == (0, 0, raw.shape[1], raw.shape[0])
    assert max(sent(view, "raw")[0].shape) <= SIDE


def test_a_small_pan_inside_the_margin_sends_nothing_new(view):
    view.zoom_to(100, 160, 50, 100)
    region = view.region
    before = sent(view, "rendered")[0]
    view.zoom_to(104, 164, 52, 102)
    assert view.region == region and sent(view, "rendered")[0] is before


def test_a_new_result_keeps_the_zoom_and_a_new_image_size_shows_the_whole(view):
    view.zoom_to(100, 160, 50, 100)
    top, left, height, width = view.region
    view.state.noise_sigma = 3.0  # same size: the region stays, with the new pixels
    raw = np.asarray(view.state.result.raw.data, float)[::-1]
    np.testing.assert_array_equal(sent(view, "raw")[2]["value"][0], raw[top : top + height, left : left + width])
    view.state.distance = 5.0  # another size: the whole new image
    h, w = np.asarray(view.state.result.raw.data).shape[:2]
    assert view.region is None and sent(view, "raw")[1] == (0, 0, w, h)


def test_an_image_that_fits_the_screen_is_sent_as_it_is():
    view = ResultsView(ExplorerState())  # the default limit, 1280 a side
    raw = np.asarray(view.state.result.raw.data, np.float32)[::-1]
    image, place, data = sent(view, "raw")
    assert image.shape == raw.shape and place == (0, 0, raw.shape[1], raw.shape[0])
    np.testing.assert_array_equal(data["value"][0], raw)
    view.zoom_to(100, 160, 50, 100)
    assert view.region is None  # nothing finer to fetch


def test_screen_part_of_packed_rgba_averages_each_channel():
    rgba = np.zeros((4, 6, 4), np.uint8)
    rgba[:2, :2] = [10, 20, 30, 255]
    rgba[:2, 2:4] = [0, 0, 0, 255]
    rgba[2:, :2] = [200, 100, 0, 255]
    packed = rgba.view(np.uint32)[..., 0]
    part, block = screen_part(packed, 3)
    assert block == 2 and part.shape == (2, 3)
    channels = part.view(np.uint8).reshape(2, 3, 4)
    assert channels[0, 0].tolist() == [10, 20, 30, 255] and channels[1, 0].tolist() == [200, 100, 0, 255]
    same, one = screen_part(packed, 6, (1, 2, 2, 3))
    assert one == 1 and np.array_equal(same, packed[1:3, 2:5])


def test_de_map_is_coloured_as_bokehs_linear_mapper_would_colour_it():
    """The dE map leaves the server coloured: the colours are those of LinearColorMapper(Inferno256, low, high)
    (index floor((v - low) / (high - low) * 256), clipped to the ends; NaN grey), written out here from the palette."""
    from bokeh.palettes import Inferno256

    from camsim_explorer.views import de_rgba

    low, high = 2.0, 12.0
    values = np.array([[-5.0, 2.0, 2.03, 4.5, 7.0, 11.99, 12.0, 40.0, np.nan]], np.float32)
    got = de_rgba(values, low, high).view(np.uint8).reshape(1, -1, 4)[0]
    for v, rgba in zip(values[0], got):
        if np.isnan(v):
            assert rgba.tolist() == [128, 128, 128, 255]
            continue
        k = int(np.clip(np.floor((v - low) / (high - low) * 256), 0, 255))
        hexa = Inferno256[k]
        assert rgba.tolist() == [int(hexa[1:3], 16), int(hexa[3:5], 16), int(hexa[5:7], 16), 255], v


def test_de_view_sends_colours_and_values_and_follows_the_scale():
    view = ResultsView(ExplorerState())  # the default screen: the map fits, sent as it is
    state = view.state
    de = state.result.delta_e
    image, _, data = sent(view, "de")
    assert image.dtype == np.uint32 and data["value"][0].dtype == np.float32
    np.testing.assert_allclose(data["value"][0], np.asarray(de, np.float32)[::-1])  # the hover's values, as computed
    state.de_scale = "fixed 0-20"
    fixed, _, _ = sent(view, "de")
    assert not np.array_equal(fixed, image)  # new colours for the new scale
    assert (view.mapper.low, view.mapper.high) == (0.0, 20.0)


def test_a_large_results_views_are_made_at_once_on_the_block_threads_with_the_same_numbers(monkeypatch):
    """``ResultsView.prepare`` makes a frame-sized chart's views on the engine's block threads (each view in
    one of them): the arrays sent are the ones made in turn, to the bit."""
    import threading

    import camsim_core._parallel as parallel

    state = ExplorerState()
    state.scene = "slanted-edge"  # picked: fitted to the default camera's frame, ~860 x 1295 pixels
    res = state.result
    assert np.prod(res.raw.data.shape[:2]) * 5 >= parallel.PARALLEL_VALUES  # large enough for the threads

    def prepared():
        view = ResultsView(state)  # which shows the result at once, in this thread
        view._memos.clear()
        view._screens.clear()
        threads.clear()
        view.prepare(res)
        return view

    threads = set()
    original = ResultsView._raw_view

    def noting(self, raw):
        threads.add(threading.current_thread().name)
        return original(self, raw)

    monkeypatch.setattr(ResultsView, "_raw_view", noting)
    at_once = prepared()
    assert threads and all(name.startswith("camsim-block") for name in threads), threads
    monkeypatch.setattr(parallel, "PARALLEL_VALUES", 1 << 62)  # everything in turn, in this thread
    in_turn = prepared()
    assert threads == {threading.current_thread().name}
    assert set(at_once._screens) == set(in_turn._screens) == {"raw", "demosaiced", "rendered", "ideal", "de"}
    for key, (_, _, (view, columns, block)) in in_turn._screens.items():
        other_view, other_columns, other_block = at_once._screens[key][2]
        assert block == other_block
        np.testing.assert_array_equal(view, other_view)
        assert set(columns) == set(other_columns)
        for name in columns:
            np.testing.assert_array_equal(columns[name], other_columns[name])
    for name in ("exposure", "flags", "rendered_y", "level", "raw_hash", "rendered_hash"):
        assert at_once._memos[name][1] == in_turn._memos[name][1], name
