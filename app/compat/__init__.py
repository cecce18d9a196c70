"""Every use the explorer makes of Panel's, Bokeh's and Tornado's private internals, in this one package.

The rest of the explorer uses their public API only (``tests/app/test_compat.py``
checks the source of every other module). What is here, and why:

* :mod:`.tuning` - three per-event costs of Panel removed (about 16 ms of the
  shared event loop per change);
* :mod:`.build_off_loop` - pages built in a thread, not on the event loop
  (1-1.4 s per page that every other visitor waited);
* :mod:`.spare_session` - the next visitor's page built while the server is idle;
* :mod:`.early_head` - a page built for its request (a link) sends its scripts
  first, and the browser loads them while the server builds the page;
* :mod:`.bokeh_defaults` - Bokeh sends a model without making the defaults it
  then drops, and makes a plain default once per class (a tab shown again: 30-50 %
  less of the server's CPU);
* :mod:`.plain_text` - a ``Str`` pane whose text is escaped (user text never HTML);
* :mod:`.number_box` - a number box that reads any whole number the browser sends
  (one beyond 64 bits raised in Panel's callback);
* :mod:`.hooks` - no MathJax bundle (1.8 MB per first visit), link values
  Panel cannot parse kept as text (an HTTP 500 before), browser-side links
  of closed sessions dropped (a leak), changes Panel queued and forgot sent
  (lost updates), changes made while a page finishes loading sent (Panel
  dropped them), no 50 ms debounce, the address written once a result is
  shown, a data-URI page icon, the Tornado application for the Host check, and (for
  ``camsim serve`` only) every page's files from this server, never Panel's CDN.

Each checks, when applied, that the internal it needs is still there; when it
is not, the explorer keeps Panel's own behaviour and :func:`apply` logs a
warning naming what is lost. Nothing is patched on import: the server (and
the explorer's ``create_app``) call :func:`apply`. On a Panel or Bokeh other
than :data:`TESTED` :func:`apply` logs a warning too, and
``tests/app/test_compat.py`` fails: an upgrade cannot switch a hook off unnoticed.
"""

from __future__ import annotations

import logging

from . import hooks

__all__ = ["apply", "status", "TESTED", "versions_tested"]

#: The Panel and Bokeh releases (major.minor) these hooks were written and measured against.
TESTED = {"panel": ("1.8", "1.9"), "bokeh": ("3.8", "3.9")}

_log = logging.getLogger("camsim.explorer")
_done: dict = {}


def _minor(version):
    return ".".join(str(version).split(".")[:2])


def versions_tested():
    """``{package: (installed version, whether its major.minor is in TESTED)}`` for Panel and Bokeh."""
    import bokeh
    import panel

    return {name: (mod.__version__, _minor(mod.__version__) in TESTED[name]) for name, mod in
            (("panel", panel), ("bokeh", bokeh))}


def status():
    """``{hook: True when the internals it needs are present}`` for every hook of :mod:`.hooks` and
    :mod:`.tuning`, and whether :mod:`.build_off_loop`'s Bokeh method is the one it was written against."""
    from . import bokeh_defaults, build_off_loop, early_head, tuning

    out = {name: bool(check()) for name, check in hooks.HOOKS.items()}
    out.update(tuning.available())
    out["build_off_loop"] = build_off_loop.matches_bokeh()
    out["early_head"] = early_head.matches_panel()
    out["skip_discarded_defaults"] = bokeh_defaults.matches_bokeh("query_properties_with_values")
    out["plain_defaults_once"] = bokeh_defaults.matches_bokeh("_get_default") and bokeh_defaults.matches_bokeh(
        "themed_values")
    return out


def apply():
    """Apply the process-wide hooks (idempotent); log a warning for each one that does not apply.

    Returns :func:`status`. The server calls this before serving; ``create_app`` calls it too (a
    notebook's or a test's explorer gets the same page as a served one).
    """
    if _done:
        return dict(_done)
    from . import bokeh_defaults, tuning

    for name, (version, known) in versions_tested().items():
        if not known:
            _log.warning("camsim explorer: %s %s is not one of the releases its compat hooks were tested with "
                         "(%s); check `pytest tests/app/test_compat.py`", name, version, ", ".join(TESTED[name]))
    hooks.pages_without_mathjax()
    hooks.link_values_kept_as_text()
    hooks.connected_at_pull()
    tuning.apply()
    bokeh_defaults.skip_discarded_defaults()
    bokeh_defaults.plain_defaults_once()
    result = status()
    lost = {
        "pages_without_mathjax": "pages load Bokeh's MathJax bundle (1.8 MB)",
        "link_values_kept_as_text": "a link value of thousands of digits gives HTTP 500",
        "forget_js_links": "closed sessions' widgets stay in memory",
        "flush_stranded_writes": "a result Panel queued and forgot may not reach the page",
        "connected_at_pull": "a change made while a page finishes loading (a tab opened) may never reach it",
        "undelay": "changes from the browser wait Panel's 50 ms debounce",
        "favicon_type": "the page icon's type is guessed from its name",
        "plain_text": "text in PlainText panes may be shown as HTML",
        "address_writer": "the address is written at every change, before its result is shown",
        "tornado_app": "the Host header is not checked (DNS rebinding)",
        "served_without_cdn": "a page may ask cdn.holoviz.org for its stylesheets",
        "skip_busy_tracking": "Panel's busy counter costs ~9 ms a change",
        "design_only_for_stylesheets": "Panel resolves design stylesheets on every change (~6 ms)",
        "build_off_loop": "pages are built on the event loop (1-1.4 s during which others wait)",
        "early_head": "a link's page sends its scripts only once it is built",
        "skip_discarded_defaults": "Bokeh makes and drops every default of every model it sends (5-7 times slower)",
        "plain_defaults_once": "Bokeh makes a default anew at every read (a tab switch ~20 % dearer on the server)",
    }
    for name, ok in result.items():
        if not ok:
            _log.warning("camsim explorer: compat hook %s does not apply to this Panel/Bokeh: %s", name,
                         lost.get(name, "Panel's own behaviour is kept"))
    _done.update(result)
    return result
