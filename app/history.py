"""The browser's back and forward buttons show the page of the address they go to.

The explorer writes its design into the page's address (Panel's ``Location``
pushes a history entry per change, once the change's result is shown), but
Panel's ``Location`` does not listen to the browser's ``popstate``: back and
forward changed the address and left the page as it was (the design, its dE
and its tab), under an address that no longer described it. This component
reloads the page when back or forward lands on another address: the page is
then built from that address, as a link is (designs pinned in the address
come back; a scene uploaded in the session does not, as for any link).

Only a change of the path or the query reloads: the address the page last
wrote is noted when Panel (or anything) pushes or replaces a history entry,
so a move between entries that differ only in their fragment does nothing.
Back to an entry of an earlier document (the page before a reload) may be
served from the browser's back-forward cache: the page as it was left, its
session gone; such a page reloads too.

Written as a small :class:`panel.custom.JSComponent`: neither Panel nor
Bokeh follows the browser's history.
"""

from __future__ import annotations

from panel.custom import JSComponent

__all__ = ["HistoryFollower"]


class HistoryFollower(JSComponent):
    """Reloads the page when the browser's back or forward button lands on another address (an invisible
    element of the page).

    Examples
    --------
    >>> follower = HistoryFollower(margin=0, width=0, height=0)
    >>> "popstate" in follower._esm and "location.reload()" in follower._esm
    True
    """

    _esm = """
    export function render({ model }) {
      const here = () => window.location.pathname + window.location.search;
      let shown = here();
      if (!window.__camsimHistory) {
        window.__camsimHistory = { note: () => {} };
        for (const name of ["pushState", "replaceState"]) {
          const own = window.history[name];
          window.history[name] = function (...args) {
            const out = own.apply(this, args);
            window.__camsimHistory.note();
            return out;
          };
        }
      }
      window.__camsimHistory.note = () => { shown = here(); };
      const follow = () => { if (here() !== shown) window.location.reload(); };
      // a page the browser restores from its back-forward cache is the page as it was left, its session gone
      const restored = (event) => { if (event.persisted) window.location.reload(); };
      window.addEventListener("popstate", follow);
      window.addEventListener("pageshow", restored);
      model.on("remove", () => {
        window.removeEventListener("popstate", follow);
        window.removeEventListener("pageshow", restored);
      });
      const span = document.createElement("span");
      span.style.display = "none";
      return span;
    }
    """
