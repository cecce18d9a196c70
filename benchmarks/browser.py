"""Benchmark: the explorer as a user feels it, from an action in the browser to the updated page.

Starts ``camsim serve`` on 127.0.0.1 (one BLAS thread, as ``make serve`` runs
it), drives the system Chromium with Playwright and, per action, times from
the moment the widget is changed (its value set and its ``change`` event
dispatched in the page, on the page's clock) to the frame in which the page shows the
new result: the status pane reports the new parameters and the stats line
has changed, plus one animation frame so the canvases have drawn the data
that arrived in the same message. Printed per action: median and maximum
ms over ``--repeats`` repetitions (values toggled back and forth), the
engine time of the same change (reported by the page: the wall time of
the pipeline's run) and the ratio of the median to the goal.

Actions: noise, exposure, rendering method, demosaicing method, distance,
scene change, first complete render after navigation (page load to stats and
images shown).

Usage: ``python benchmarks/browser.py [--repeats N] [--url URL]`` (``--url``
measures an already running server instead of starting one).
The machine's load average is printed with the table: on a shared machine,
read medians, not maxima.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from app_helpers import CHROMIUM_ARGS, chromium_path, explorer_server  # noqa: E402

#: Goals (median ms) per action.
GOALS = {"noise": 150, "exposure": 150, "render method": 150, "demosaic method": 150, "distance": 300,
         "scene change": None, "first render": 1500}

# JS: find an element through shadow roots (Panel renders panes inside them).
_DEEP = """
function deep(sel, root) {
  root = root || document;
  const hit = root.querySelector(sel);
  if (hit) return hit;
  for (const el of root.querySelectorAll('*')) {
    if (el.shadowRoot) { const f = deep(sel, el.shadowRoot); if (f) return f; }
  }
  return null;
}
function camsimHost(cls) {
  window._camsimHosts = window._camsimHosts || {};
  let h = window._camsimHosts[cls];
  if (!h || !h.isConnected) { h = deep('.' + cls); window._camsimHosts[cls] = h; }
  return h;
}
function camsimStatus() {
  const host = camsimHost('camsim-status');
  const pre = host && (host.shadowRoot ? deep('pre', host.shadowRoot) : host.querySelector('pre'));
  if (!pre) return null;
  try { return JSON.parse(pre.textContent); } catch (e) { return null; }
}
function camsimStats() {
  const host = camsimHost('camsim-stats');
  if (!host) return '';
  return (host.shadowRoot || host).textContent;
}
"""

# wait until the status shows `params[key] == value` and the stats text differs from `before`
_DONE = "([key, value, before]) => {" + _DEEP + """
  const s = camsimStatus();
  if (!s || !s.params || s.params[key] !== value || s.computing) return false;
  if (before !== null && camsimStats() === before) return false;
  return new Promise(r => requestAnimationFrame(() => r({t: performance.now(), engine: s.engine_ms})));
}
"""

_FIRST = "() => {" + _DEEP + """
  const s = camsimStatus();
  if (!s || s.mean_de === null || s.mean_de === undefined || s.computing) return false;
  return new Promise(r => requestAnimationFrame(() => r({t: performance.now(), engine: s.engine_ms})));
}
"""


def _input(page, css):
    return page.locator(f".{css} input").first


# The change is made in the page, as a user's Enter or choice makes it: the element's value is set and its
# ``change`` event dispatched, and the clock starts there. (Playwright's fill and press add two round trips
# to the browser, about 45 ms, that no user waits for.)
_DISPATCH = """(el, value) => {
  const t = performance.now();
  el.value = value;
  el.dispatchEvent(new Event('change', {bubbles: true}));
  return t;
}"""


def _change(page, css, kind, value):
    """Set a number box or a select in the page; returns the page's clock (ms) at the change."""
    el = _input(page, css) if kind == "number" else page.locator(f".{css} select").first
    return el.evaluate(_DISPATCH, str(value))


#: (label, status key, widget class, kind, the two values toggled)
ACTIONS = [
    ("noise", "noise_sigma", "w-noise", "number", (2.0, 0.0)),
    ("exposure", "exposure", "w-exposure", "number", (0.12, 0.1)),
    ("render method", "render_method", "w-render", "select", ("illuminant", "baseline")),
    ("demosaic method", "demosaic_method", "w-demosaic", "select", ("freeman", "bilinear")),
    ("distance", "distance", "w-distance", "number", (3.0, 3.32)),
    ("scene change", "scene", "w-scene", "select", ("bfgb128", "cacaphony290")),
]


def _stats_text(page):
    return page.evaluate("() => {" + _DEEP + "\n return camsimStats(); }")


def time_action(page, key, css, kind, value):
    """ms from the widget change to the frame showing the result, and the engine ms reported."""
    before = _stats_text(page)
    t0 = _change(page, css, kind, value)
    handle = page.wait_for_function(_DONE, arg=[key, value, before], polling="raf", timeout=120000)
    done = handle.json_value()
    return done["t"] - t0, done["engine"]


def time_first_render(browser, url):
    page = browser.new_page(viewport={"width": 1366, "height": 768})
    page.set_default_timeout(180000)  # a loaded machine can take long; the table says how long
    try:
        t0 = time.perf_counter()
        page.goto(url)
        handle = page.wait_for_function(_FIRST, polling="raf", timeout=120000)
        done = handle.json_value()
        # performance.now() counts from navigation start: the page's own clock
        return done["t"], done["engine"], 1000 * (time.perf_counter() - t0)
    finally:
        page.close()


def run(url, repeats):
    from playwright.sync_api import sync_playwright

    rows = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium_path(), args=CHROMIUM_ARGS)
        # first render: a fresh page each time
        firsts = [time_first_render(browser, url) for _ in range(repeats)]
        page = browser.new_page(viewport={"width": 1366, "height": 768})
        page.set_default_timeout(180000)
        page.goto(url)
        page.wait_for_function(_FIRST, polling="raf", timeout=120000)
        for label, key, css, kind, values in ACTIONS:
            times, engines = [], []
            # one warm-up round trip, then `repeats` timed changes alternating the two values
            for v in values:
                time_action(page, key, css, kind, v)
            for i in range(repeats):
                ms, engine = time_action(page, key, css, kind, values[i % 2])
                times.append(ms)
                engines.append(engine or 0.0)
            rows.append((label, times, engines))
        page.close()
        browser.close()
    rows.append(("first render", [f[0] for f in firsts], [f[1] or 0.0 for f in firsts]))
    return rows


def report(rows, repeats):
    load = os.getloadavg()
    print(f"explorer in Chromium at 1366 x 768, default scene; {repeats} repetitions per action; "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores")
    print(f"{'action':<16} {'median ms':>9} {'max ms':>8} {'engine ms':>9} {'goal ms':>8} {'median/goal':>11}")
    print("-" * 66)
    for label, times, engines in rows:
        med, mx = statistics.median(times), max(times)
        goal = GOALS.get(label)
        ratio = f"{med / goal:.2f}" if goal else "-"
        print(f"{label:<16} {med:9.0f} {mx:8.0f} {statistics.median(engines):9.1f} {goal or '-':>8} {ratio:>11}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="repetitions per action (>= 5)")
    ap.add_argument("--url", default=None, help="measure a running explorer instead of starting one")
    args = ap.parse_args()
    if args.url:
        rows = run(args.url, args.repeats)
    else:
        with explorer_server() as url:
            rows = run(url, args.repeats)
    report(rows, args.repeats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
