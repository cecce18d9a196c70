"""The explorer inline in a Jupyter notebook: one line.

>>> import camsim_explorer                                                # doctest: +SKIP
>>> camsim_explorer.show(scene="cacaphony290", camera="kodak-dcs200")    # doctest: +SKIP

shows the whole explorer page (controls, results, quality tabs) in the
cell's output, for that scene and camera. The page is the one ``camsim
serve`` serves (:func:`camsim_explorer.main.create_app`), with its own
:class:`~camsim_explorer.state.ExplorerState` (``page.state``): set more
parameters by keyword (``show(..., exposure=0.05, noise_sigma=2)``) or later
on the state (``page.state.f_stop = 4``), and the page follows.

The page loads Panel's notebook support itself (``pn.extension()``, as
:func:`~camsim_explorer.main.create_app` does); outside a notebook, :func:`show`
returns the page without displaying it (``page.show()`` serves it in a browser).
"""

from __future__ import annotations

from camsim_core.errors import ParameterError
from camsim_core.scene.scene import Scene

__all__ = ["show"]


def show(scene="cacaphony290", camera=None, **params):
    """The explorer's page for ``scene`` and ``camera``, which Jupyter shows inline.

    Parameters
    ----------
    scene : str or Scene
        A shipped scene's name (:data:`camsim_core.SCENE_NAMES`), or a
        :class:`~camsim_core.scene.Scene` (e.g. read with
        :func:`camsim_core.load_scene`), offered as ``file:<its name>``.
    camera : str, optional
        A camera preset of the explorer (``"kodak-dcs200"``, ``"kodak-dcs200-ir"``, ...;
        ``ExplorerState.param.camera.objects``); default the explorer's own.
    **params
        Any other parameter of :class:`~camsim_explorer.state.ExplorerState`
        (``exposure`` in s, ``f_stop``, ``distance`` in m, ``noise_sigma`` in
        digital units, ``demosaic_method``, ...).

    Returns
    -------
    panel.template.FastListTemplate
        The page; ``page.state`` is its state, with the result computed for
        the parameters given.

    Raises
    ------
    ParameterError
        For a scene, camera or parameter the explorer does not know (naming it).
    """
    from .main import create_app
    from .state import ExplorerState

    if isinstance(scene, Scene):
        chosen = scene
    elif isinstance(scene, str) and scene in ExplorerState.param.scene.objects:
        chosen = scene
    else:
        raise ParameterError("scene", f"must be a Scene or one of {', '.join(ExplorerState.param.scene.objects)}; "
                                      f"got {scene!r}")
    changes = dict(params)
    if camera is not None:
        changes["camera"] = camera
    for name, value in changes.items():
        p = ExplorerState.param[name] if name in ExplorerState.param else None
        if p is None or p.precedence == -1 or name == "scene":
            raise ParameterError(name, "is not a parameter of the explorer (see camsim_explorer.state.ExplorerState)")
        objects = getattr(p, "objects", None)
        if objects and value not in objects:
            raise ParameterError(name, f"must be one of {', '.join(map(str, objects))}; got {value!r}")
    page = create_app(chosen)
    state = page.state
    if changes:
        try:
            state.param.update(**changes)
        except ValueError as exc:  # param's own refusal (a number out of bounds)
            raise ParameterError(", ".join(changes), str(exc)) from None
    return page

