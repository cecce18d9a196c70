"""A class on the page's ``<body>`` that follows a setting of the session.

Presentation mode restyles the whole page (the sidebar, the template's
header, every tab) through one class on the body (``camsim-present``). A
``jscallback`` on the toggle did it in the browser, but a Panel ``Callback``
makes Panel look for links every time a part of a page is rendered anew:
it installs a hook that selects every Panel object of the page and every
Bokeh model of the part (16 % of the server's work at a tab switch). This
component sets the class from the server's value instead: the same class,
one round trip later, and no hook.

Written as a small :class:`panel.custom.JSComponent`: Panel has no
component for a class on the body.
"""

from __future__ import annotations

import param
from panel.custom import JSComponent

__all__ = ["BodyClass"]


class BodyClass(JSComponent):
    """Puts ``css_class`` on the page's ``<body>`` while ``active`` is True (an invisible element of the page).

    Parameters
    ----------
    css_class : str
        The class (letters, digits, ``-`` and ``_``).
    active : bool
        Whether the body has the class; removed when the component leaves the page.

    Examples
    --------
    >>> marker = BodyClass(css_class="camsim-present")
    >>> marker.active = True
    >>> marker.active
    True
    """

    css_class = param.String(default="", regex=r"^[A-Za-z0-9_-]*$", constant=True, doc="The class set on the body")
    active = param.Boolean(default=False, doc="Whether the body has the class")

    _esm = """
    export function render({ model }) {
      const set = () => { if (model.css_class) document.body.classList.toggle(model.css_class, model.active); };
      set();
      model.on("active", set);
      model.on("remove", () => { if (model.css_class) document.body.classList.remove(model.css_class); });
      const span = document.createElement("span");
      span.style.display = "none";
      return span;
    }
    """
