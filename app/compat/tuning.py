"""Three per-event costs of Panel that the explorer does not use, removed once per process.

Measured with py-spy on ``camsim serve`` (Panel 1.9), one noise move from the
browser held the event loop for about 65 ms of Python; the event loop is
shared by every session, so this is what a class of thirty waits on.

* **The global busy counter.** Every widget event adds and then removes an
  entry in ``pn.state._busy_counter``, a parameter of the process-wide
  ``pn.state`` with watchers, to drive the template's busy spinner. The
  explorer has no such spinner (``busy_indicator=None``: its result panes show
  their own loading state), yet the bookkeeping cost ~9 ms a move, and it
  is one object shared by all sessions. :func:`skip_busy_tracking` makes the
  two calls do nothing; ``pn.state.busy`` then stays False.
* **Design modifiers on every property change.** ``Reactive._update_properties``
  asks the design for the widget's modifiers (resolving its stylesheet files
  on disk) on every change of any property, and uses them only when the change
  is to ``stylesheets``. :func:`design_only_for_stylesheets` asks only then;
  the properties sent are the same (``tests/app/test_panel_tuning.py`` checks both
  cases against Panel's own method). ~6 ms a move.
* **Debug records nobody reads.** Panel sets its ``panel`` logger to DEBUG and
  filters in its handler (at WARNING), so every event builds debug log records
  that are then dropped (~1.5 ms a move). :func:`quiet_debug_logging` sets the
  logger to INFO, the level below the handler's; what the log shows is unchanged.

Written by hand: these are settings Panel does not offer. Each patch checks
that Panel still has the method it replaces and does nothing otherwise.
"""

from __future__ import annotations

__all__ = ["skip_busy_tracking", "design_only_for_stylesheets", "quiet_debug_logging", "available", "apply"]

_applied = set()


def skip_busy_tracking():
    """Make Panel's per-event busy bookkeeping a no-op (the explorer shows no busy spinner)."""
    from panel.io.state import _state

    if "busy" in _applied or not hasattr(_state, "_add_busy_event") or not hasattr(_state, "_remove_busy_event"):
        return False
    _state._add_busy_event = lambda self, event_id: None
    _state._remove_busy_event = lambda self, event_id: None
    _applied.add("busy")
    return True


def design_only_for_stylesheets():
    """Ask the design for a component's modifiers only when its ``stylesheets`` change."""
    from panel.reactive import Reactive

    original = getattr(Reactive, "_update_properties", None)
    if "design" in _applied or original is None:
        return False

    def _update_properties(self, *events, doc):
        if any(event.name == "stylesheets" for event in events):
            return original(self, *events, doc=doc)
        return self._process_param_change({event.name: event.new for event in events})

    _update_properties.original = original
    Reactive._update_properties = _update_properties
    _applied.add("design")
    return True


def quiet_debug_logging():
    """Panel's logger at INFO: its debug records were built on every event, then dropped by its handler."""
    import logging

    logger = logging.getLogger("panel")
    if logger.level and logger.level < logging.INFO:
        logger.setLevel(logging.INFO)
        return True
    return False


def available():
    """``{patch: True when the Panel internal it replaces is there}`` (applied or not)."""
    from panel.io.state import _state
    from panel.reactive import Reactive

    return {"skip_busy_tracking": hasattr(_state, "_add_busy_event") and hasattr(_state, "_remove_busy_event"),
            "design_only_for_stylesheets": hasattr(Reactive, "_update_properties")}


def apply():
    """All three (:func:`camsim_explorer.compat.apply` calls this).

    Examples
    --------
    >>> from camsim_explorer.compat import tuning
    >>> tuning.apply()
    >>> from panel.io.state import state
    >>> state.busy
    False
    """
    skip_busy_tracking()
    design_only_for_stylesheets()
    quiet_debug_logging()
