"""A closed session gives back its memory: its pipeline cache, last result and uploads are dropped
and the state's watchers unlinked (``app.main._release``, run from ``on_session_destroyed``)."""


import panel as pn

from camsim_explorer.main import _release, create_app
from camsim_core.scene import macbeth_scene, save_npz_scene


def test_release_drops_the_sessions_arrays_and_watchers(tmp_path):
    page = create_app()
    state = page.state
    save_npz_scene(macbeth_scene(patch_size=4, border=1), tmp_path / "mine.npz")
    assert state.add_upload("mine.npz", (tmp_path / "mine.npz").read_bytes()), state.message
    assert state._uploads and state.pipeline is not None
    watched = sum(len(w) for group in state.param.watchers.values() for w in group.values())
    assert watched > 0
    _release(state, page)
    assert state.pipeline is None and state.result is None and not state._uploads and not state.preparers
    assert sum(len(w) for group in state.param.watchers.values() for w in group.values()) == 0
    assert page.state is None and len(page.objects) == 0
    # a change after release reaches nothing (no watcher left to recompute)
    state.noise_sigma = 3.0
    assert state.result is None


def test_a_released_session_is_freed_with_its_widgets():
    """Nothing outside the session keeps its state: Panel's registry of browser-side links
    (weak keys, but values that hold the keys) is purged of the session's widgets."""
    import gc
    import weakref

    from panel.links import Callback

    template = create_app()
    state, body = template.state, template.body
    mine = {id(o) for root in [body, *template.sidebar] for o in root.select()}
    # the page makes no browser-side link of its own (test_app_state): one such as a widget may make
    button = next(o for o in template.sidebar[0].select(pn.widgets.Toggle))
    button.jscallback(value="void 0")
    assert any(id(k) in mine for k in Callback.registry.keys())
    ref = weakref.ref(state)
    _release(state, body, template)
    assert not any(id(k) in mine for k in Callback.registry.keys())
    del state, body, template, button
    gc.collect()
    assert ref() is None
