"""A tab's view: a Panel component that follows the session's state through its tab's gate.

The views of the Scene, Camera, Image quality and Optics & sensor tabs are
each a :class:`TabView`: a ``pn.viewable.Viewer`` over the session's
:class:`~camsim_explorer.state.ExplorerState`, whose ``update`` runs when the
state changes (``param.depends``), at once while the tab is shown and once
when it is next shown otherwise (:class:`~camsim_explorer.shown.WhenShown`).
"""

from __future__ import annotations

import panel as pn
import param

from .shown import now
from .state import ExplorerState

__all__ = ["TabView"]


class TabView(pn.viewable.Viewer):
    """A view of one tab, following the state's result; a subclass builds ``_layout`` and defines ``update``.

    A subclass that follows something else than the result declares its own
    ``_on_change`` with ``@param.depends(..., watch=True)``. Its ``__init__``
    makes its widgets, calls ``super().__init__(state, when_shown)``, sets
    ``self._layout`` and shows the state (``self.update()``).

    Parameters
    ----------
    state : ExplorerState
        The session's state, which the view shows.
    when_shown : callable, optional
        The tab's gate: ``when_shown(fn)`` is ``fn`` run now, or when the tab is next shown
        (:class:`~camsim_explorer.shown.WhenShown`); by default always now (a notebook, a test).

    Examples
    --------
    >>> import panel as pn
    >>> from camsim_explorer.shown import WhenShown
    >>> class Name(TabView):
    ...     def __init__(self, state, when_shown=now):
    ...         self.text = pn.pane.Str("")
    ...         super().__init__(state, when_shown)
    ...         self._layout = pn.Column(self.text)
    ...         self.update()
    ...     def update(self):
    ...         self.text.object = self.state.result.camera.name
    >>> gate = WhenShown(shown=False)
    >>> view = Name(ExplorerState(camera="kodak-dcs200"), gate)
    >>> view.state.camera = "imx174"  # a new result: the tab is hidden, the view waits
    >>> view.text.object
    'kodak-dcs200'
    >>> gate.show(True); view.text.object
    'imx174'
    """

    state = param.ClassSelector(class_=ExplorerState, doc="The session's state, which the view shows.")

    def __init__(self, state, when_shown=now, **params):
        self._update_when_shown = when_shown(self.update)
        self._tab_shown = lambda: getattr(when_shown, "shown", True)
        super().__init__(state=state, **params)

    @param.depends("state.result", watch=True)
    def _on_change(self):
        self._update_when_shown()

    def update(self):
        """Show the state (the subclass's)."""
        raise NotImplementedError

    def __panel__(self):
        return self._layout

    def panel(self):
        """The view's layout (what Panel shows for the view itself)."""
        return self._layout
