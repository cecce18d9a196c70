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

__all__ = ["WhenShown", "now", "off_the_loop"]


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


def off_the_loop(make, then, failed):
    """Run ``make()`` in a session thread and ``then(value)`` on the page's next tick; outside a served page
    (a notebook, a test), both at once. A ``make`` that raises is logged and ``then(failed(exc))`` shows why
    (never a view waiting for ever). Returns True when ``make`` was sent to a thread (the view can say it is
    working meanwhile).

    The event loop serves every page of the server: a view's measure (an SSIM, a photon-transfer curve)
    made in its callbacks held every page for its time.

    Examples
    --------
    >>> shown = []
    >>> off_the_loop(lambda: 6 * 7, shown.append, str), shown  # no page here: made at once
    (False, [42])
    >>> off_the_loop(lambda: 1 / 0, shown.append, lambda exc: f"not made: {exc}"), shown[-1]
    (False, 'not made: division by zero')
    """
    import logging

    import panel as pn

    from .state import SESSION_THREADS

    def made():
        try:
            return make()
        except Exception as exc:
            logging.getLogger("camsim.explorer").exception("a view's measure failed")
            return failed(exc)

    doc = pn.state.curdoc
    if doc is None or doc.session_context is None:
        then(made())
        return False

    def run():
        value = made()
        try:
            doc.add_next_tick_callback(lambda: then(value))  # Bokeh's one thread-safe call
        except Exception:  # the page has closed
            pass

    SESSION_THREADS.submit(run)
    return True
