"""A file upload that checks the size in the browser and sends the bytes in small pieces.

Panel's ``FileInput`` sends a whole file as one websocket message; a file
over Bokeh's message limit closes the connection and the page goes dead
without a word. :class:`BoundedUpload` reads the file's size in the
browser first: a file over ``max_bytes`` is refused there, with a message
the page shows, and nothing is sent. A file within the limit travels in
pieces of ``chunk_bytes`` (base64), each far below the websocket limit;
the server counts the bytes it receives and refuses more than
``max_bytes`` whatever the browser claims.

Written as a small :class:`panel.custom.JSComponent` because no Panel
widget checks the size before sending (``FileDropper`` does, but needs
the FilePond library from a CDN).
"""

from __future__ import annotations

import base64

import param
from panel.custom import JSComponent

__all__ = ["BoundedUpload"]


class BoundedUpload(JSComponent):
    """One file, at most ``max_bytes``: ``value`` (bytes) and ``filename`` are set when it has arrived.

    ``refused`` holds the message for a file refused by its size (in the
    browser or on arrival); it changes, with a counter, at every refusal.
    """

    accept = param.String(default="", doc="File types offered, e.g. '.npz,.zip'")
    max_bytes = param.Integer(default=16 * 2**20, bounds=(1, None), doc="Largest file accepted, bytes")
    chunk_bytes = param.Integer(default=2**20, bounds=(1024, None), doc="Bytes per websocket message")
    filename = param.String(default="", doc="Name of the last file received")
    value = param.Parameter(default=None, doc="Bytes of the last file received")
    refused = param.String(default="", doc="Why the last file was refused (empty when accepted)")
    label = param.String(default="Choose a file")

    _esm = """
    export function render({ model, el }) {
      const wrap = document.createElement("div");
      const input = document.createElement("input");
      input.type = "file";
      input.accept = model.accept;
      const note = document.createElement("span");
      note.className = "bounded-upload-note";
      note.style.marginLeft = "6px";
      wrap.append(input, note);
      function toBase64(bytes) {
        let s = "";
        for (let i = 0; i < bytes.length; i += 32768) {
          s += String.fromCharCode.apply(null, bytes.subarray(i, i + 32768));
        }
        return btoa(s);
      }
      input.addEventListener("change", async () => {
        const file = input.files[0];
        if (!file) return;
        if (file.size > model.max_bytes) {
          const mb = (n) => (n / 1048576).toFixed(1) + " MiB";
          note.textContent = "refused: larger than " + mb(model.max_bytes);
          model.send_msg({kind: "too_large", name: file.name, size: file.size});
          input.value = "";
          return;
        }
        note.textContent = "sending...";
        const step = model.chunk_bytes;
        const total = Math.max(1, Math.ceil(file.size / step));
        for (let i = 0; i < total; i++) {
          const part = new Uint8Array(await file.slice(i * step, (i + 1) * step).arrayBuffer());
          model.send_msg({kind: "chunk", name: file.name, size: file.size, index: i, total: total, data: toBase64(part)});
        }
        note.textContent = "";
        input.value = "";
      });
      return wrap;
    }
    """

    def __init__(self, **params):
        super().__init__(**params)
        self._parts = []
        self._received = 0
        self._refusals = 0

    def _refuse(self, name, size):
        self._parts, self._received = [], 0
        self._refusals += 1
        self.refused = (f"{name}: is {size / 2**20:.1f} MiB, more than the {self.max_bytes / 2**20:.1f} MiB "
                        f"an upload may be (refusal {self._refusals})")

    def _handle_msg(self, msg):
        if not isinstance(msg, dict):
            return
        name = str(msg.get("name", "upload"))[:200]
        if msg.get("kind") == "too_large":
            self._refuse(name, float(msg.get("size", 0) or 0))
            return
        if msg.get("kind") != "chunk":
            return
        index, total = int(msg.get("index", 0)), int(msg.get("total", 1))
        if index == 0:
            self._parts, self._received = [], 0
        elif index != len(self._parts):  # a piece lost or out of order: start again with the next file
            self._parts, self._received = [], 0
            return
        try:
            part = base64.b64decode(str(msg.get("data", "")), validate=True)
        except ValueError:
            self._parts, self._received = [], 0
            return
        self._received += len(part)
        if self._received > self.max_bytes:
            self._refuse(name, self._received)
            return
        self._parts.append(part)
        if index + 1 >= total:
            data, self._parts, self._received = b"".join(self._parts), [], 0
            with param.parameterized.discard_events(self):
                self.value = None  # the same file twice still counts as a new upload
            self.param.update(refused="", filename=name)
            self.value = data
