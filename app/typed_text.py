"""Text typed into a number box that the box throws away, told to the server.

Bokeh's number boxes (``NumericInput``, inside Panel's ``FloatInput``,
``IntInput`` and the editable sliders) check each keystroke in the browser
and put the previous text back when a character cannot be part of a number:
"abc" typed into the exposure box vanishes, and the server, which never saw
it, cannot say why. :class:`TypedTextWatch` listens to the page's ``input``
events in their capture phase, before the box's own check, applies the same
test Bokeh applies (its ``int_regex`` / ``float_regex``), and sends the
server the box's CSS class and the text refused. The server names the field
and the value kept (``refused`` holds the message): a message in the page,
like every other refusal, never a silent revert.

What the page sends is only a report: the server accepts it for the number
boxes it was given (``fields``), cuts the text to :data:`MAX_TEXT` characters
and changes no value because of it.

Written as a small :class:`panel.custom.JSComponent`: neither Bokeh nor
Panel reports the characters a number box drops.
"""

from __future__ import annotations

import param
from panel.custom import JSComponent

__all__ = ["TypedTextWatch", "MAX_TEXT"]

#: The longest text quoted back in a message (characters).
MAX_TEXT = 40


class TypedTextWatch(JSComponent):
    """Watches the page's number boxes named in ``fields`` (CSS class -> label) and ``integer_fields``; sets
    ``refused`` to a message naming the field when the browser throws typed text away."""

    fields = param.Dict(default={}, doc="CSS class of a number box -> its label, for the message")
    integer_fields = param.List(default=[], item_type=str, doc="CSS classes of the boxes taking whole numbers")
    refused = param.String(default="", precedence=-1, doc="Why the last typed text was thrown away")

    _rename = {"refused": None}

    _esm = """
    const INT = /^[-+]?\\d*$/;  // Bokeh's own tests (NumericInput), applied before it applies them
    const FLOAT = /^[-+]?\\d*\\.?\\d*(?:(?:\\d|\\d.)[eE][-+]?)*\\d*$/;
    export function render({ model, el }) {
      const fieldOf = (path) => {
        for (const node of path) {
          if (node.classList) for (const c of node.classList) if (c in model.fields) return c;
        }
        return null;
      };
      const onInput = (event) => {
        const path = event.composedPath();
        const input = path[0];
        if (!(input instanceof HTMLInputElement) || input.type !== "text") return;
        const field = fieldOf(path);
        if (field === null) return;
        const test = model.integer_fields.includes(field) ? INT : FLOAT;
        if (!test.test(input.value)) model.send_msg({field: field, text: input.value.slice(0, 200)});
      };
      document.addEventListener("input", onInput, true);
      model.on("remove", () => document.removeEventListener("input", onInput, true));
      const span = document.createElement("span");
      span.style.display = "none";
      return span;
    }
    """

    def __init__(self, values=None, **params):
        super().__init__(**params)
        self._values = values  # field -> () -> the value the box keeps, for the message

    def _handle_msg(self, msg):
        if not isinstance(msg, dict):
            return
        field = msg.get("field")
        if not isinstance(field, str) or field not in self.fields:
            return  # not a box of this page's: ignored
        text = str(msg.get("text", ""))
        quoted = text if len(text) <= MAX_TEXT else text[:MAX_TEXT] + "..."
        kept = ""
        if self._values and field in self._values:
            kept = f"; it keeps {self._values[field]()}"
        with param.parameterized.discard_events(self):
            self.refused = f"{self.fields[field]}: “{quoted}” is not a number{kept}. Type digits, a point, an exponent (1e-3)."
        self.param.trigger("refused")  # told each time, the same text again included
