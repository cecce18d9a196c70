"""The explorer inline in a Jupyter notebook: one line.

>>> import camsim_explorer                                                # doctest: +SKIP
>>> camsim_explorer.show(scene="cacaphony290", camera="kodak-dcs200")    # doctest: +SKIP

shows the explorer (its controls beside its results, image quality and
comparison tabs) in the cell's output, for that scene and camera. It is
the page that ``camsim serve`` serves (:func:`camsim_explorer.main.create_app`),
laid out as a plain Panel row that fits a notebook cell (a page template
takes the whole browser window), with its own
:class:`~camsim_explorer.state.ExplorerState` (``.state``): set more
parameters by keyword (``show(..., exposure=0.05, noise_sigma=2)``) or later
on the state (``view.state.f_stop = 4``), and the view follows.
``show(..., page=True)`` returns the whole page instead (``.show()`` opens it
in a browser tab).

The page loads Panel's notebook support itself (``pn.extension()``, as
:func:`~camsim_explorer.main.create_app` does); outside a notebook, :func:`show`
returns the view without displaying it.
"""

from __future__ import annotations

from camsim_core.errors import ParameterError
from camsim_core.scene.scene import Scene

__all__ = ["show"]


def show(scene="cacaphony290", camera=None, *, page=False, **params):
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
    page : bool
        False (default): the controls and the results side by side in a
        ``panel.Row``, which a notebook cell shows inline; True: the
        explorer's whole page (a ``FastListTemplate``, as ``camsim serve`` serves it).
    **params
        Any other parameter of :class:`~camsim_explorer.state.ExplorerState`
        (``exposure`` in s, ``f_stop``, ``distance`` in m, ``noise_sigma`` in
        digital units, ``demosaic_method``, ...).

    Returns
    -------
    panel.Row or panel.template.FastListTemplate
        The view (Jupyter shows it when it is a cell's last expression);
        ``.state`` is its :class:`~camsim_explorer.state.ExplorerState`, with
        the result computed for the parameters given, and ``.page`` the whole page.

    Raises
    ------
    ParameterError
        For a scene, camera or parameter the explorer does not know (naming it).

    Examples
    --------
    >>> view = show(scene="macbeth", camera="kodak-dcs200", exposure=0.05)
    >>> view.state.camera, view.state.shown["camera"], view.state.exposure
    ('kodak-dcs200', 'kodak-dcs200', 0.05)
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
    template = create_app(chosen)
    state = template.state
    if changes:
        try:
            state.param.update(**changes)
        except ValueError as exc:  # param's own refusal (a number out of bounds)
            raise ParameterError(", ".join(changes), str(exc)) from None
    if page:
        template.page = template
        return template
    import panel as pn

    view = pn.Row(pn.Column(*template.sidebar, width=330), pn.Column(*template.main, sizing_mode="stretch_width"),
                  sizing_mode="stretch_width")
    view.state, view.page = state, template
    return view

