"""Views of a hidden tab wait: their updates run when the tab is next shown.

Each tab of the explorer other than Results holds views that follow the
design (the scene's facts and planes, the sensor curves, the image-quality
measures, the optics and sensor table, the comparison). Updated on every
change while hidden, they made a change cost the work of every tab a student
had opened once: picking the Macbeth chart took 11.7 s with every tab built
against 2.9 s with the Results tab alone. A :class:`WhenShown` gate holds a
hidden tab's updates and runs each once, newest state, when the tab is shown.
"""

from __future__ import annotations

__all__ = ["WhenShown", "now"]


def now(fn):
    """The gate of a view that is always shown: ``fn`` runs at once."""
    return fn


class WhenShown:
    """The gate of one tab: ``gate(fn)`` is ``fn`` run now while the tab is shown, else once when it is shown.

    Examples
    --------
    >>> gate = WhenShown(shown=False)
    >>> calls = []
    >>> update = gate(lambda: calls.append("update"))
    >>> update(); update()
    >>> calls
    []
    >>> gate.show(True)
    >>> calls
    ['update']
    """

    def __init__(self, shown=True):
        self.shown = shown
        self._pending = {}  # id(fn) -> fn, in the order they were first held

    def __call__(self, fn):
        def run(*_):
            if self.shown:
                fn()
            else:
                self._pending.setdefault(id(fn), fn)

        return run

    def show(self, shown):
        """The tab is shown (True) or hidden (False); shown, the updates held meanwhile run, each once."""
        self.shown = bool(shown)
        while self.shown and self._pending:
            fn = self._pending.pop(next(iter(self._pending)))  # the first held first
            fn()
