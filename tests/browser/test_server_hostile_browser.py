"""``camsim serve`` facing a hostile page, in a real browser (issue 36, items 4 and 7).

A page's script can change anything the browser holds: the upload widget's limit, the size its pieces
claim, the address Panel reads parameters from. The server's limits must hold whatever it does, and a
value that used to raise in the server gets a message naming the field. HTTP and unit checks of the same
items are in ``tests/app/test_server_hostile.py``.
"""

import pytest

from app_helpers import ARTIFACTS, Page, explorer_server, server_log, wait_until

pytestmark = pytest.mark.browser

MiB = 2**20

#: Page script: set every upload limit the scene upload's model has (``max_bytes`` was one) to 1 TiB.
RAISE_THE_CAP_JS = """() => {
  const raised = [];
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.class_name === 'BoundedUpload' && (m.css_classes || []).includes('w-upload')) {
      for (const k of ['max_bytes', 'browser_max_bytes']) {
        if (m.data[k] !== undefined) { m.data[k] = 2 ** 40; raised.push(k); }
      }
    }
  }
  return raised;
}"""

#: Page script: every upload piece sent from now on claims a file of 1 byte.
CLAIM_ONE_BYTE_JS = """() => {
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    // Bokeh writes the piece as a map: ["size",N] (or "size":N)
    if (typeof data === 'string' && data.includes('"chunk"')) data = data.replace(/("size"\\s*[,:]\\s*)\\d+/, (m, key) => key + '1');
    return send.call(this, data);
  };
  return true;
}"""

#: Page script: set the address's query the way the browser's back button does (Panel's Location model).
SET_SEARCH_JS = """(search) => {
  for (const m of Bokeh.documents[0]._all_models.values()) {
    if (m.search !== undefined && m.pathname !== undefined && m.hash !== undefined) { m.search = search; return true; }
  }
  return false;
}"""


def _rss(pid):
    """Resident memory of process ``pid``, bytes."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    raise AssertionError("no VmRSS")


def test_a_page_script_cannot_lift_the_upload_cap(browser, tmp_path):
    ARTIFACTS.mkdir(exist_ok=True)
    big = tmp_path / "big.npz"
    big.write_bytes(bytes(48 * MiB))
    procs = []
    # no spare page: the next visitor's page, built while idle, would show in the memory measured
    with explorer_server(extra_args=["--max-upload-mb", "3", "--no-spare-page"], on_start=procs.append) as url:
        page = Page(browser, url)
        try:
            assert page.page.evaluate(RAISE_THE_CAP_JS)
            assert page.page.evaluate(CLAIM_ONE_BYTE_JS)
            before = _rss(procs[0].pid)
            page.page.locator(".w-upload input[type=file]").first.set_input_files(str(big))
            text = page.wait_for_alert("Upload refused: big.npz")
            # refused on the bytes received (4 pieces of 1 MiB), against the server's limit, unchanged
            assert "big.npz: is 4.0 MiB, more than the 3.0 MiB an upload may be" in text
            # the page sends the whole file (its note empties when done); then a round trip through the same
            # websocket: the server has read every piece before it answers
            note = page.page.locator(".w-upload .bounded-upload-note").first
            wait_until(lambda: note.text_content() == "", what="the page sent the whole file")
            page.page.locator(".w-diagnostics input").first.check()
            page.page.locator(".camsim-status").first.wait_for(state="visible")
            grew = _rss(procs[0].pid) - before
            print(f"RSS grew {grew / MiB:.1f} MiB")
            page.shot("hostile-upload-cap")
            assert grew < 24 * MiB, f"the server's memory grew by {grew / MiB:.0f} MiB for a refused 48 MiB file"
            # the page stays connected and a file within the cap still arrives
            page.type_number("w-noise", 3)
            assert page.wait_for(lambda s: s["params"]["noise_sigma"] == 3)["mean_de"] > 0
            assert "Traceback" not in server_log(url)
        finally:
            page.close()


def test_a_five_thousand_digit_link_value_gets_a_message_naming_it(browser, server):
    page = Page(browser, server + "?seed=" + "9" * 5000 + "&noise_sigma=2")
    try:
        assert page.response.status == 200
        text = page.wait_for_alert("The link's values for seed are longer than 256 characters and were ignored")
        assert "Traceback" not in text and "Exceeds" not in text
        assert page.status()["params"]["seed"] == 0
        assert "Traceback" not in server_log(server)
    finally:
        page.close()


@pytest.mark.parametrize("search, words", [
    ("?viewing=" + "x" * 100_000, "Refused: viewing: is 100000 characters long; at most 256 are allowed"),
    ("?viewing=spd:1e-300", "Refused: viewing: 'spd:1e-300' gives 1e-300 samples per degree; the explorer takes 0.01 to 10000"),
    ("?seed=" + "9" * 5000, "The link held parameters that were refused: seed '9999"),
    ("?wavelength=nan", "The link held parameters that were refused: wavelength nan"),
], ids=["long-viewing", "spd-1e-300", "5000-digit-seed", "nan-wavelength"])
def test_values_the_page_puts_in_its_address_are_refused_by_name(browser, server, search, words):
    """The address read again (as after the back button) with a value no link could carry: refused with a
    message naming it, the parameters kept at those of the result shown, no traceback anywhere.
    (One page each: the page rewrites its address after a refusal, and a change the page's script makes
    meanwhile may be lost in Panel's syncing of the address.)"""
    page = Page(browser, server)
    try:
        assert page.page.evaluate(SET_SEARCH_JS, search)
        text = page.wait_for_alert(words)
        assert len(text) < 500  # a long value is quoted cut short
        for bad in ("Traceback", "Error", "Exceeds"):
            assert bad not in text
        s = page.status()
        assert s["params"]["viewing"] == "camera" and s["params"]["seed"] == 0 and s["params"]["wavelength"] == 550
        assert "Traceback" not in server_log(server)
        page.type_number("w-noise", 4)  # the page still works
        assert page.wait_for(lambda s: s["params"]["noise_sigma"] == 4)["mean_de"] > 0
    finally:
        page.close()
