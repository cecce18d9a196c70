"""The server under a class: many browser sessions at once, and one long session.

* Load: 10 sessions make 20 noise changes each, in rounds, while an 11th
  runs slow changes (Bayesian demosaicing and S-CIELAB); every session's
  median response (change typed -> status pane shows it, both on the page's
  own clock) must stay under 1.5 s, each session must see only its own values, and after all close
  and the idle timeout passes the server's memory must come back within
  100 MB of its level at start, and of its level after one warm-up session
  (shipped data read once per process are not session memory).
* Soak: 200 changes in one session; resident memory may grow by less than
  50 MB after the first 20.

Both drive Chromium for minutes on this 2-core machine shared by several
jobs, so they run only with ``CAMSIM_LOAD_TEST=1`` (``make test`` shows
them as skipped with that reason).
"""

from __future__ import annotations

import os
import statistics
import time

import psutil
import pytest

from app_helpers import ARTIFACTS, Page, explorer_server

pytestmark = [
    pytest.mark.browser,
    pytest.mark.slow,
    pytest.mark.skipif(os.environ.get("CAMSIM_LOAD_TEST") != "1",
                       reason="load and soak tests drive 11 browser sessions for minutes: run with CAMSIM_LOAD_TEST=1"),
]

IDLE_S = 2.0

#: In a page: note the page's clock and the noise shown each time its status pane shows a computed result
#: (``window.camsimShown``). Event-driven (no polling), so the eleven pages cost the machine nothing more.
_NOTE_RESULTS = """host => {
  const root = host.shadowRoot || host;
  window.camsimShown = [];
  new MutationObserver(() => {
    const pre = root.querySelector('pre');
    try {
      const s = JSON.parse(pre.textContent);
      if (s.params && !s.computing) window.camsimShown.push([performance.now(), s.params.noise_sigma]);
    } catch (e) {}
  }).observe(root, {childList: true, characterData: true, subtree: true});
  return true;
}"""


def _type_noise(pg, value):
    """Type ``value`` into the noise box; returns the page's clock (ms) just before the Enter that sends it."""
    box = pg.page.locator(".w-noise input").first
    box.fill(str(value))
    sent = pg.page.evaluate("performance.now()")
    box.press("Enter")
    return sent


def _shown_after(pg, value, sent):
    """ms on the page's clock from ``sent`` to its status pane first showing the result for ``value``."""
    shown = pg.page.evaluate("window.camsimShown.splice(0)")
    times = [t - sent for t, v in shown if v is not None and abs(v - value) < 1e-9 and t >= sent]
    assert times, f"the page noted no result for noise {value} after its change (noted: {shown[-3:]})"
    return min(times)


@pytest.fixture
def server():
    ARTIFACTS.mkdir(exist_ok=True)
    holder = {}
    with explorer_server(extra_args=["--session-idle", str(IDLE_S)], on_start=lambda p: holder.setdefault("proc", p)) as url:
        holder["url"] = url
        holder["ps"] = psutil.Process(holder["proc"].pid)
        yield holder


def _rss_mb(ps):
    return ps.memory_info().rss / 2**20


def _settle(ps, target_mb, timeout=60.0):
    """Resident memory once it is within ``target_mb`` (or the last reading after ``timeout`` s)."""
    deadline = time.monotonic() + timeout
    while True:
        rss = _rss_mb(ps)
        if rss <= target_mb or time.monotonic() > deadline:
            return rss
        time.sleep(1.0)


def test_ten_sessions_stay_responsive_and_are_freed(browser, server):
    ps = server["ps"]
    start = _rss_mb(ps)
    warm = Page(browser, server["url"])
    warm.close()
    time.sleep(IDLE_S + 3)
    baseline = _rss_mb(ps)
    slow = Page(browser, server["url"])
    pages = [Page(browser, server["url"]) for _ in range(10)]
    for pg in pages:
        pg.page.locator(".camsim-status").first.evaluate(_NOTE_RESULTS)  # the pane's host element
    times = [[] for _ in pages]
    on_page = [[] for _ in pages]
    slow_methods = [("w-demosaic", "bayesian")]
    for round_ in range(20):
        if round_ % 5 == 0:  # the slow session starts a heavy change every few rounds
            slow.select(*slow_methods[0])
            slow.page.locator(".w-metric button", has_text="S-CIELAB").first.click()
            slow.type_number("w-noise", 1 + round_)
        sent = []
        for j, pg in enumerate(pages):
            value = round(0.5 * j + 0.1 * (round_ + 1), 2)
            t_page = _type_noise(pg, value)
            sent.append((time.monotonic(), value, t_page))
        for j, pg in enumerate(pages):
            t0, value, t_page = sent[j]
            pg.wait_for(lambda s, v=value: s["params"]["noise_sigma"] == v)
            times[j].append(time.monotonic() - t0)
            on_page[j].append(_shown_after(pg, value, t_page) / 1000)
    # the response each student sees: from their Enter to their result, on their page's clock. (The driver's
    # clock adds, for the first page, the time it takes the driver to type into the nine others and poll.)
    medians = [statistics.median(t) for t in on_page]
    print(f"\nload: medians per session (s), on each page's clock: {[round(m, 2) for m in medians]}; "
          f"worst single {max(max(t) for t in on_page):.2f}")
    print(f"load: the same as the test driver sees them: {[round(statistics.median(t), 2) for t in times]}; "
          f"worst single {max(max(t) for t in times):.2f}")
    # no cross-session leak: each page still shows its own last value
    for j, pg in enumerate(pages):
        assert pg.params()["noise_sigma"] == round(0.5 * j + 0.1 * 20, 2)
    for pg in pages + [slow]:
        pg.close()
    after = _settle(ps, baseline + 100)
    print(f"load: server RSS at start {start:.0f} MB, after a warm-up session {baseline:.0f} MB, "
          f"after 11 sessions closed and {IDLE_S:g} s idle {after:.0f} MB")
    assert max(medians) < 1.5, medians
    assert after - baseline < 100
    assert after - start < 100  # and within 100 MB of the server's level at start, the shipped data read since included


def test_soak_of_200_changes_in_one_session(browser, server):
    ps = server["ps"]
    page = Page(browser, server["url"])
    readings = {}
    for k in range(200):
        value = round(0.5 + (k % 40) * 0.25, 2)
        page.type_number("w-noise", value)
        page.wait_for(lambda s, v=value: s["params"]["noise_sigma"] == v)
        if k + 1 in (20, 100, 200):
            readings[k + 1] = _rss_mb(ps)
    page.close()
    print(f"\nsoak: server RSS after 20, 100, 200 changes: {', '.join(f'{v:.0f}' for v in readings.values())} MB")
    assert readings[200] - readings[20] < 50
