"""A file upload that checks the size in the browser and sends the bytes in small pieces.

Panel's ``FileInput`` sends a whole file as one websocket message; a file
over Bokeh's message limit closes the connection and the page goes dead
without a word. :class:`BoundedUpload` reads the file's size in the
browser first: a file over ``browser_max_bytes`` is refused there, with a
message the page shows, and nothing is sent. A file within it travels in
pieces of ``chunk_bytes`` (base64), each far below the websocket limit.

The browser's check is a convenience for honest pages: a page's script
can change anything the browser holds. What protects the server is
``max_bytes``, a parameter the browser neither sees nor sets (not synced
to the page's model): the server counts the bytes it receives, piece by
piece, and refuses the file as soon as they pass it, whatever the browser
claims or sends. ``value``, ``filename`` and ``refused`` stay on the
server too: the bytes are never sent back to the page, and no page can
hand the server a file by setting them. ``value`` holds the file only
while its watchers run (the page parses it there): it is ``None`` again
afterwards, success or failure, so a session keeps the scene, not its bytes.

Written as a small :class:`panel.custom.JSComponent` because no Panel
widget checks the size before sending (``FileDropper`` does, but needs
the FilePond library from a CDN).
"""

from __future__ import annotations

import base64
import binascii

import param
from panel.custom import JSComponent

__all__ = ["BoundedUpload"]


class BoundedUpload(JSComponent):
    """One file, at most ``max_bytes``: ``value`` (bytes) and ``filename`` are set when it has arrived.

    ``refused`` holds the message for a file refused by its size (in the
    browser or on arrival); it changes, with a counter, at every refusal.
    Watch ``value`` and take ``event.new``: the widget lets go of the bytes
    once its watchers have returned.
    """

    # server-side only (precedence -1 keeps them out of the page's model, ``_rename`` out of its messages)
    _rename = {"max_bytes": None, "filename": None, "value": None, "refused": None}

    accept = param.String(default="", doc="File types offered, e.g. '.npz,.zip'")
    max_bytes = param.Integer(default=16 * 2**20, bounds=(1, None), precedence=-1,
                              doc="Largest file accepted, bytes: the server's limit, checked on the bytes received "
                                  "(never sent to the browser nor taken from it)")
    browser_max_bytes = param.Integer(default=None, allow_None=True, bounds=(1, None),
                                      doc="The limit the browser checks before sending (a convenience; default "
                                          "max_bytes): a page may change it, the server never reads it back")
    chunk_bytes = param.Integer(default=2**20, bounds=(1024, None), doc="Bytes per websocket message")
    filename = param.String(default="", precedence=-1, doc="Name of the last file received")
    value = param.Parameter(default=None, precedence=-1,
                            doc="Bytes of the file received, while the watchers of ``value`` run; None otherwise")
    refused = param.String(default="", precedence=-1, doc="Why the last file was refused (empty when accepted)")
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
        if (file.size > model.browser_max_bytes) {
          const mb = (n) => (n / 1048576).toFixed(1) + " MiB";
          note.textContent = "refused: larger than " + mb(model.browser_max_bytes);
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
        if self.browser_max_bytes is None:
            self.browser_max_bytes = self.max_bytes
        self._parts = []
        self._received = 0
        self._refusals = 0
        self._refused_file = False  # the pieces still coming of a file already refused are dropped quietly

    def _drop(self):
        self._parts, self._received = [], 0

    def _refuse(self, name, size):
        self._drop()
        self._refusals += 1
        self.refused = (f"{name}: is {size / 2**20:.1f} MiB, more than the {self.max_bytes / 2**20:.1f} MiB "
                        f"an upload may be (refusal {self._refusals})")

    def _handle_msg(self, msg):
        if not isinstance(msg, dict):
            return
        name = str(msg.get("name", "upload"))[:200]
        try:
            size = float(msg.get("size", 0) or 0)
            index, total = int(msg.get("index", 0)), int(msg.get("total", 1))
        except (TypeError, ValueError, OverflowError):  # not what the page's script sends: dropped
            self._drop()
            return
        if msg.get("kind") == "too_large":
            self._refuse(name, size)
            return
        if msg.get("kind") != "chunk":
            return
        if index == 0:
            self._drop()
            self._refused_file = False
            if size > self.max_bytes:  # the file's own size says it is too large: refused before any piece is kept
                self._refused_file = True
                self._refuse(name, size)
                return
        elif self._refused_file or index != len(self._parts):  # a refused file, or a piece lost or out of order
            self._drop()
            return
        try:
            part = base64.b64decode(str(msg.get("data", "")), validate=True)
        except (ValueError, binascii.Error):
            self._drop()
            return
        self._received += len(part)
        if self._received > self.max_bytes:  # counted on what arrived: the limit holds whatever the page claims
            self._refused_file = True
            self._refuse(name, self._received)
            return
        self._parts.append(part)
        if index + 1 >= total:
            data = b"".join(self._parts)
            self._drop()
            with param.parameterized.discard_events(self):
                self.value = None  # the same file twice still counts as a new upload
            self.param.update(refused="", filename=name)
            try:
                self.value = data  # the watchers (the page's parser) take it here
            finally:
                with param.parameterized.discard_events(self):
                    self.value = None  # let go of the bytes, parsed or refused
