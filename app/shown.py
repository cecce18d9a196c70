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

import threading

__all__ = ["WhenShown", "now", "off_the_loop", "page_being_built", "next_tick", "serve_on"]

#: The event loop serving the pages (``camsim serve`` registers it, :func:`serve_on`) and its thread's ident.
_SERVER = {"loop": None, "thread": None}


def serve_on(loop):
    """Register the server's event loop (a Tornado ``IOLoop``), from the thread that will run it: from then on
    :func:`next_tick` hands other threads' callbacks to it."""
    _SERVER.update(loop=loop, thread=threading.get_ident())


def next_tick(doc, fn, closed=None):
    """Run ``fn`` on the next tick of ``doc``'s session, from any thread; ``closed()`` when the page has closed.

    Bokeh's ``Document.add_next_tick_callback`` is the call its documents take
    from other threads, but it is not safe while the event loop holds the
    document (``pn.io.hold``, each update of a page): the callback's "added"
    event then waits among the document's held events, and a hold that ends at
    that moment loses it (Bokeh's and Panel's unhold copy the list of held
    events, then empty it), so the callback never runs. A link's pinned
    designs, found fast, reported their progress while the page's first
    updates held it, and the tab said "Computing..." for ever. From another
    thread, the call is therefore handed to the server's event loop (Tornado's
    ``add_callback``, which is thread-safe) and made there; on the loop's own
    thread, or without a registered server (a test), it is made at once.

    Examples
    --------
    >>> class Doc:  # a page's document, as far as this goes
    ...     def add_next_tick_callback(self, fn):
    ...         fn()
    >>> next_tick(Doc(), lambda: print("shown"))
    shown
    """

    def add():
        try:
            doc.add_next_tick_callback(fn)
        except Exception:  # the session has closed: nothing to show
            if closed is not None:
                closed()

    loop = _SERVER["loop"]
    if loop is None or threading.get_ident() == _SERVER["thread"]:
        add()
    else:
        loop.add_callback(add)



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


def page_being_built(doc):
    """Whether ``doc`` is a served page still being built: it has a session context but Bokeh has not made its
    session yet (the builder thread runs the explorer's code; what is set now goes with the page's first
    document). Callbacks another thread adds to such a document were lost or ran out of order.

    Examples
    --------
    >>> page_being_built(None)  # no served page (a notebook, a test)
    False
    """
    return doc is not None and doc.session_context is not None and getattr(doc.session_context, "session", None) is None


def off_the_loop(make, then, failed):
    """Run ``make()`` in a session thread and ``then(value)`` on the page's next tick; outside a served page
    (a notebook, a test), and in a page still being built (:func:`page_being_built`: the builder thread, off the
    event loop already), both at once. A ``make`` that raises is logged and ``then(failed(exc))`` shows why
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
    if doc is None or doc.session_context is None or page_being_built(doc):
        then(made())
        return False

    def run():
        value = made()
        next_tick(doc, lambda: then(value))

    SESSION_THREADS.submit(run)
    return True
