"""Benchmark: the explorer as a user feels it, from an action in the browser to the updated page.

Starts ``camsim serve`` on 127.0.0.1 (one BLAS thread, as ``make serve`` runs
it), drives the system Chromium as a user's browser runs (through the DevTools
protocol's Runtime alone, :mod:`_cdp`: Playwright's Network instrumentation
copies every WebSocket frame to its driver, a cost no user pays; ``--driver
playwright`` times the same actions with it on) and, per action, times from
the moment the widget is changed (its value set and its ``change`` event
dispatched in the page, on the page's clock) to the frame in which the page shows the
new result: the status pane reports the new parameters and the stats line
has changed, plus one animation frame so the canvases have drawn the data
that arrived in the same message. The page itself watches for the result
(a MutationObserver on the two panes; for the first render a 5 ms timer):
nothing polls it frame by frame, which would keep the browser drawing frames
on the cores the server and the page share. Printed per action: median and maximum
ms over ``--repeats`` repetitions (values toggled back and forth), the
engine time of the same change (reported by the page: the wall time of
the pipeline's run) and the ratio of the median to the goal.

Actions: noise, exposure, rendering method, demosaicing method, distance,
scene change, camera switch (to human cones, and to the electron-level
phone-1.4um), chart pick (the slanted edge, fitted to the frame of the default
camera, and of phone-1.4um: 1074 x 1432 samples through its diffraction
optics); each row starts from the default design (the row before put back
untimed); tab switches (Scene, Camera, Optics & sensor and Image quality, each and back to Results, nothing
changed since the tab was last shown: from the click to the tab's own pane shown and the browser idle) and
the Camera tab opened after a camera switch made on the Results tab (to its pane naming the new camera); on the
Compare designs tab: pinning each of four cameras (to the design shown, and to
its image-quality measures in the table), a sweep of the four over
six noise values, and a link that restores the four pinned designs (from
navigation to all four shown); first complete render after navigation (page load to stats and
images shown; each in a new browser context, so nothing is cached): pages opened
``FIRST_PAUSE_S`` apart, and pages opened back to back (the server then may not
have the next page built in advance; the table counts the pages that were).

Usage: ``python benchmarks/browser.py [--repeats N] [--url URL] [--driver cdp|playwright]``
(``--url`` measures an already running server instead of starting one).
The machine's load average is printed with the table: on a shared machine,
read medians, not maxima.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import urllib.parse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from app_helpers import CHROMIUM_ARGS, chromium_path, explorer_server  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _cdp import CdpDriver, PlaywrightDriver  # noqa: E402

#: The browsers the actions can be timed in: Chromium through the DevTools protocol's Runtime alone (as a
#: user's browser runs), or through Playwright, whose Network instrumentation copies every WebSocket frame.
DRIVERS = {"cdp": CdpDriver, "playwright": PlaywrightDriver}

#: Goals (median ms) per action.
GOALS = {"noise": 150, "exposure": 150, "render method": 150, "demosaic method": 150, "distance": 300,
         "scene change": None, "camera switch": 500, "camera: phone-1.4um": 500, "chart pick": 500,
         "chart pick: phone-1.4um": None,
         "pin": 1000, "pin, its quality measures in": None, "sweep 4 x 6": 10000, "link, 4 pinned": 3000,
         "first render": 1500, "first, back to back": None, "tab switch": None,
         "tab, after a camera switch": None}

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
function camsimWidget(css, kind) {  // the input or select of the widget with CSS class css
  const host = deep('.' + css);
  return host && deep(kind === 'select' ? 'select' : 'input', host.shadowRoot || host);
}
function camsimSet(el, value) {  // as a user's choice or Enter does it: the value, then its change event
  el.value = String(value);
  el.dispatchEvent(new Event('change', {bubbles: true}));
}
function camsimTab(title) {  // the tab whose title holds the text, or null
  const all = [];
  const walk = root => { for (const el of root.querySelectorAll('*')) {
    if (el.classList.contains('bk-tab')) all.push(el); if (el.shadowRoot) walk(el.shadowRoot); } };
  walk(document);
  return all.find(el => el.textContent.includes(title)) || null;
}
function camsimStats() {
  const host = camsimHost('camsim-stats');
  if (!host) return '';
  return (host.shadowRoot || host).textContent;
}
"""

# The whole action in one call into the page: note the stats line, watch the status and stats panes for
# changes (MutationObserver), make the change (the element's value set and its ``change`` event dispatched, as
# a user's Enter or choice makes it; the clock starts there), and resolve on the first change after which the
# status reports ``params[key] == value`` (not computing) and the stats line differs, plus one animation frame
# so the canvases have drawn the data that arrived in the same message. Nothing polls: a probe that checks
# every frame keeps the browser producing frames (its compositor and the test driver working ~60 times a
# second), on the same two cores as the server and the page.
_ACT = "([css, kind, value, key]) => {" + _DEEP + """
  const el = camsimWidget(css, kind);
  if (!el) return {error: `no widget .${css} in the page`};
  const before = camsimStats();
  const hosts = ['camsim-status', 'camsim-stats'].map(camsimHost);
  return new Promise(resolve => {
    let t0 = null, done = false;
    const check = () => {
      if (done || t0 === null) return;
      const s = camsimStatus();
      // a picked chart is shown as the chart with the options it was fitted with ("slanted-edge:distance=3,...")
      const shown = s && s.params ? s.params[key] : undefined;
      const same = shown === value || (typeof shown === 'string' && shown.split(':')[0] === value);
      if (!s || !same || s.computing) return;
      if (camsimStats() === before) return;
      done = true;
      observer.disconnect();
      requestAnimationFrame(() => resolve({ms: performance.now() - t0, engine: s.engine_ms}));
    };
    const observer = new MutationObserver(check);
    for (const h of hosts) observer.observe(h.shadowRoot || h, {childList: true, characterData: true, subtree: true});
    t0 = performance.now();
    camsimSet(el, value);
    setTimeout(() => {  // a result that never comes: say what the page shows instead of waiting forever
      if (done) return;
      done = true;
      observer.disconnect();
      const s = camsimStatus();
      resolve({error: `no result with ${key} = ${value} in ${ACT_TIMEOUT_MS} ms; the page shows ` +
                      JSON.stringify(s && s.params && s.params[key]) + (s && s.computing ? ' (computing)' : '')});
    }, ACT_TIMEOUT_MS);
  });
}""".replace("ACT_TIMEOUT_MS", "120000")

# First render: from navigation start (the page's clock) to the first frame after the status reports a
# result (not computing), checked every 5 ms by a timer in the page from its first script on (a timer makes
# no frames; the panes are in shadow roots, which a MutationObserver on the document does not see).
_FIRST_INIT = "(() => {" + _DEEP + """
  window.camsimFirst = new Promise(resolve => {
    const timer = setInterval(() => {
      const s = camsimStatus();
      if (!s || s.mean_de === null || s.mean_de === undefined || s.computing) return;
      clearInterval(timer);
      requestAnimationFrame(() => resolve({t: performance.now(), engine: s.engine_ms}));
    }, 5);
  });
})();"""


#: (label, status key, widget class, kind, the two values toggled)
ACTIONS = [
    ("noise", "noise_sigma", "w-noise", "number", (2.0, 0.0)),
    ("exposure", "exposure", "w-exposure", "number", (0.12, 0.1)),
    ("render method", "render_method", "w-render", "select", ("illuminant", "baseline")),
    ("demosaic method", "demosaic_method", "w-demosaic", "select", ("freeman", "bilinear")),
    ("distance", "distance", "w-distance", "number", (3.0, 3.32)),
    ("scene change", "scene", "w-scene", "select", ("bfgb128", "cacaphony290")),
    ("camera switch", "camera", "w-camera", "select", ("human-cones", "kodak-dcs200-ir")),
    ("camera: phone-1.4um", "camera", "w-camera", "select", ("phone-1.4um", "kodak-dcs200-ir")),
    ("chart pick", "scene", "w-scene", "select", ("slanted-edge", "cacaphony290")),
    ("chart pick: phone-1.4um", "scene", "w-scene", "select", ("slanted-edge", "cacaphony290"),
     ("camera", "w-camera", "select", "phone-1.4um")),
]
#: What each row leaves set when it ends: its second value (the default), set again untimed; a row with a
#: sixth element (key, widget class, kind, value) sets that first, untimed, and puts the default back after.
DEFAULTS = {"camera": "kodak-dcs200-ir"}

# The Compare designs tab: click a button (found through shadow roots) and time, on the page's clock, until the
# comparison's status (its JSON pane) holds what is wanted: ``pinned`` designs pinned and computed, or a sweep
# of ``points`` points. A 10 ms timer checks (a timer makes no frames), then one animation frame.
_COMPARE_STATUS = """
function compareStatus() {
  const host = camsimHost('camsim-compare-status');
  const pre = host && (host.shadowRoot ? deep('pre', host.shadowRoot) : host.querySelector('pre'));
  if (!pre) return null;
  try { return JSON.parse(pre.textContent); } catch (e) { return null; }
}
function compareHas(s, want) {
  if (!s || s.busy) return false;
  if (want.pinned !== undefined && (s.pinned.length !== want.pinned || s.designs.length < want.pinned)) return false;
  if (want.points !== undefined && !(s.sweep && s.sweep.points.length === want.points)) return false;
  // this sweep's values, not the last sweep's points still shown when the button was clicked
  if (want.values !== undefined && !(s.sweep && JSON.stringify(s.sweep.values) === JSON.stringify(want.values))) return false;
  // the designs drawn, not only listed: a slot of the page per design, shown (a link once listed its designs
  // while their slots stayed hidden); looked for once the status says so
  if (want.pinned !== undefined && shownSlots() < s.designs.length) return false;
  return true;
}
function shownSlots(root = document) {
  let n = 0;
  for (const el of root.querySelectorAll('*')) {
    if (el.classList.contains('camsim-compare-slot') && el.getClientRects().length > 0) n++;
    if (el.shadowRoot) n += shownSlots(el.shadowRoot);
  }
  return n;
}
"""
_COMPARE_ACT = "([button, want]) => {" + _DEEP + _COMPARE_STATUS + """
  return new Promise(resolve => {
    const host = deep('.' + button);
    const t0 = performance.now();
    let shown = null;
    (host.shadowRoot ? host.shadowRoot.querySelector('button') : host.querySelector('button')).click();
    const timer = setInterval(() => {
      if (!compareHas(compareStatus(), want)) {
        if (performance.now() - t0 > 180000) { clearInterval(timer); resolve(JSON.stringify(compareStatus())); }
        return;
      }
      if (shown === null) shown = performance.now() - t0;
      if (want.measured && (compareStatus().measuring || []).length) return;  // and the table's quality measures in
      clearInterval(timer);
      requestAnimationFrame(() => resolve(want.measured ? [shown, performance.now() - t0] : performance.now() - t0));
    }, 10);
  });
}"""
# A link that restores pinned designs: from navigation start until the comparison shows them all.
_LINK_INIT = "(() => {" + _DEEP + _COMPARE_STATUS + """
  window.camsimLinked = (want) => new Promise(resolve => {
    const timer = setInterval(() => {
      if (!compareHas(compareStatus(), want)) {
        if (performance.now() > 180000) { clearInterval(timer); resolve(JSON.stringify(compareStatus())); }
        return;
      }
      clearInterval(timer);
      requestAnimationFrame(() => resolve(performance.now()));
    }, 10);
  });
})();"""
# A tab switch: click the tab and time, on the page's clock, until the tab's own pane (class ``marker``) is shown
# (laid out and visible) holding the text ``want``, then the browser's next idle period (the tab's plots built
# and drawn) and one animation frame. A 20 ms timer looks (a timer makes no frames).
_TAB_ACT = "([title, marker, want]) => {" + _DEEP + """
  const tab = camsimTab(title);
  if (!tab) return {error: `no tab ${title} in the page`};
  const shown = el => el && el.getClientRects().length > 0 &&
    el.checkVisibility({visibilityProperty: true, opacityProperty: true, checkVisibilityCSS: true, checkOpacity: true});
  return new Promise(resolve => {
    const t0 = performance.now();
    tab.click();
    const timer = setInterval(() => {
      const el = deep('.' + marker);
      if (!(shown(el) && (el.shadowRoot || el).textContent.includes(want))) {
        if (performance.now() - t0 > 120000) { clearInterval(timer); resolve({error: `${title}: ${marker} not shown`}); }
        return;
      }
      clearInterval(timer);
      requestIdleCallback(() => requestAnimationFrame(() => resolve({ms: performance.now() - t0})), {timeout: 10000});
    }, 20);
  });
}"""
#: The tabs a "tab switch" row opens in turn, each with its own pane: (title, CSS class of the pane).
TAB_PANES = (("Scene", "camsim-scene-meta"), ("Results", "camsim-stats"), ("Camera", "camsim-camera-info"),
             ("Results", "camsim-stats"), ("Optics & sensor", "camsim-physical-table"), ("Results", "camsim-stats"),
             ("Image quality", "camsim-quality"), ("Results", "camsim-stats"))


def time_tab(page, title, marker, want=""):
    """ms from the click on the tab ``title`` to its pane ``marker`` shown holding ``want`` and drawn."""
    done = page.evaluate(_TAB_ACT, [title, marker, want])
    if "error" in done:
        raise RuntimeError(done["error"])
    return done["ms"]


def tab_rows(page, repeats):
    """Tab switches with nothing changed since the tab was last shown, and the Camera tab opened after a camera
    switch made on the Results tab (it shows the new camera): (label, ms list) rows. Every tab is built once,
    untimed, first (its first opening builds it)."""
    for title, marker in TAB_PANES:
        time_tab(page, title, marker)
    switches = [time_tab(page, title, marker) for _ in range(repeats) for title, marker in TAB_PANES]
    after = []
    for i in range(repeats):
        camera = ("human-cones", "kodak-dcs200-ir")[i % 2]
        time_action(page, "camera", "w-camera", "select", camera)
        after.append(time_tab(page, "Camera", "camsim-camera-info", camera))
        time_tab(page, "Results", "camsim-stats")
    if repeats % 2:
        time_action(page, "camera", "w-camera", "select", DEFAULTS["camera"])
    return [("tab switch", switches), ("tab, after a camera switch", after)]


#: The cameras pinned in turn (each the live design when pinned), then swept together.
PIN_CAMERAS = ("human-cones", "cie1931", "stockman-sharpe", "kodak-dcs200")
SWEEP_VALUES = ("0, 1, 2, 3, 4, 5", "0.5, 1.5, 2.5, 3.5, 4.5, 5.5")


def _wait(page, test, arg=None, what="condition"):
    """Wait in the page (a 20 ms timer) until the JavaScript body ``test`` (given ``arg``, with the page
    helpers of ``_DEEP`` at hand) returns true."""
    source = "(arg) => new Promise(resolve => {" + _DEEP + _COMPARE_STATUS + """
      const test = () => { TEST };
      const t0 = performance.now();
      const timer = setInterval(() => {
        let ok = false;
        try { ok = test(); } catch (e) {}
        if (ok || performance.now() - t0 > 180000) { clearInterval(timer); resolve(!!ok); }
      }, 20);
    })""".replace("TEST", test)
    if not page.evaluate(source, arg):
        raise RuntimeError(f"{what}: not within 180 s")


def _wait_status(page, key, value):
    _wait(page, "const s = camsimStatus(); return !!(s && s.params && s.params[arg[0]] === arg[1] && !s.computing);",
          [key, value], f"status {key} = {value}")


def _open_tab(page, title):
    """Click the tab ``title`` (found through shadow roots, once the page has it), as a user does."""
    _wait(page, "const t = camsimTab(arg); if (t) t.click(); return !!t;", title, f"the tab {title!r}")


def _set(page, css, kind, value):
    """Set a widget's value as a user does (choice, or text and Enter), untimed, once the page has it."""
    _wait(page, "const el = camsimWidget(arg[0], arg[1]); if (el) camsimSet(el, arg[2]); return !!el;",
          [css, kind, value], f"the widget .{css}")


def _await_global(page, name):
    """The value of the promise ``window[name]`` an init script makes, once the page's document has it."""
    deadline = time.monotonic() + 180
    while not page.evaluate("(name) => !!window[name]", name):
        if time.monotonic() > deadline:
            raise RuntimeError(f"the page never ran its init script ({name}): not loaded within 180 s")
        time.sleep(0.02)
    return page.evaluate("(name) => window[name]", name)


def _ms(value, what):
    """A time the page measured, or the error naming what it showed instead (a string)."""
    if isinstance(value, str):
        raise RuntimeError(f"{what}: not done within 180 s; the comparison shows {value[:400]}")
    return value


def compare_rows(driver, page, repeats):
    """Pin, a 4 x 6 sweep and a link restoring the pinned designs: (label, ms list) rows."""
    _open_tab(page, "Compare designs")
    pins, pins_measured = [], []
    for i, camera in enumerate(PIN_CAMERAS):
        _set(page, "w-camera", "select", camera)
        _wait_status(page, "camera", camera)
        _set(page, "w-pin-name", "text", f"d{i + 1} {camera}")
        shown, measured = _ms(page.evaluate(_COMPARE_ACT, ["w-pin", {"pinned": i + 1, "measured": True}]),
                              f"pin {camera}")
        pins.append(shown)
        pins_measured.append(measured)
    sweeps = []
    for values in SWEEP_VALUES[:max(1, min(2, repeats))]:
        _set(page, "w-sweep-values", "text", values)
        want = {"points": 4 * 6, "values": [float(v) for v in values.split(",")]}
        sweeps.append(_ms(page.evaluate(_COMPARE_ACT, ["w-sweep-run", want]), "sweep"))
    _wait(page, "return window.location.search.includes('pinned=');", what="the pinned designs in the address")
    # the link as a user shares it after pinning, without the sweep (the row times the designs' restoration)
    parts = urllib.parse.urlsplit(page.evaluate("() => window.location.href"))
    query = [(k, v) for k, v in urllib.parse.parse_qsl(parts.query) if k != "sweep"]
    link = urllib.parse.urlunsplit(parts._replace(query=urllib.parse.urlencode(query)))
    links = []
    for _ in range(max(1, min(3, repeats))):
        other = driver.new_page(1366, 768, fresh_context=True)
        try:
            other.add_init_script(_LINK_INIT)
            other.goto(link)
            _await_global(other, "camsimLinked")
            _open_tab(other, "Compare designs")
            links.append(_ms(other.evaluate("(want) => window.camsimLinked(want)", {"pinned": len(PIN_CAMERAS)}),
                             "link"))
        finally:
            other.close()
    return [("pin", pins), ("pin, its quality measures in", pins_measured), ("sweep 4 x 6", sweeps),
            ("link, 4 pinned", links)]


def time_action(page, key, css, kind, value):
    """ms from the widget change to the frame showing the result, and the engine ms reported."""
    _wait(page, "return !!camsimWidget(arg[0], arg[1]);", [css, kind], f"the widget .{css}")  # laid out yet
    done = page.evaluate(_ACT, [css, kind, value, key])
    if "error" in done:
        raise RuntimeError(done["error"])
    return done["ms"], done["engine"]


def time_first_render(driver, url):
    """ms from navigation start to the first result shown, the engine ms, and how the server made the page's
    session (its ``Server-Timing`` header, read from the page's navigation entry: a spare built in advance,
    or built for this request)."""
    page = driver.new_page(1366, 768, fresh_context=True)  # a browser context of its own: nothing cached
    try:
        page.add_init_script(_FIRST_INIT)
        page.goto(url)
        done = _await_global(page, "camsimFirst")
        timing = page.evaluate("() => performance.getEntriesByType('navigation')[0].serverTiming"
                               ".map(t => t.description)")
        how = "spare" if "spare" in timing else "built"
        # performance.now() counts from navigation start: the page's own clock
        return done["t"], done["engine"], how
    finally:
        page.close()


#: Seconds between first renders in the "first render" row: a visitor arriving at a server that has been
#: quiet for a while (it builds the next page once no page has sent a message for two seconds). "back to
#: back" opens pages one after another, as a class opening the explorer at once.
FIRST_PAUSE_S = 5.0


def run(url, repeats, driver="cdp"):
    rows = []
    with DRIVERS[driver](chromium_path(), CHROMIUM_ARGS) as browser:
        # first render: a fresh page (and browser context, so nothing cached) each time
        firsts = []
        for _ in range(repeats):
            time.sleep(FIRST_PAUSE_S)
            firsts.append(time_first_render(browser, url))
        back_to_back = [time_first_render(browser, url) for _ in range(repeats)]
        page = browser.new_page(1366, 768)
        page.add_init_script(_FIRST_INIT)
        page.goto(url)
        _await_global(page, "camsimFirst")
        for label, key, css, kind, values, *setup in ACTIONS:
            for s_key, s_css, s_kind, s_value in setup:
                time_action(page, s_key, s_css, s_kind, s_value)
            times, engines = [], []
            # one warm-up round trip, then `repeats` timed changes alternating the two values
            for v in values:
                time_action(page, key, css, kind, v)
            for i in range(repeats):
                ms, engine = time_action(page, key, css, kind, values[i % 2])
                times.append(ms)
                engines.append(engine or 0.0)
            rows.append((label, times, engines))
            # every row starts from the defaults: the camera rows once left phone-1.4um for the chart pick
            if (repeats - 1) % 2 == 0:
                time_action(page, key, css, kind, values[1])
            for s_key, s_css, s_kind, _ in setup:
                time_action(page, s_key, s_css, s_kind, DEFAULTS[s_key])
        for label, times in tab_rows(page, repeats):
            rows.append((label, times, [0.0]))
        # the Compare rows pin, sweep and link on the slanted edge fitted to each camera (picked here, untimed)
        time_action(page, "scene", "w-scene", "select", "slanted-edge")
        for label, times in compare_rows(browser, page, repeats):
            rows.append((label, times, [0.0]))
        page.close()
    for label, runs in (("first render", firsts), ("first, back to back", back_to_back)):
        spares = sum(f[2] == "spare" for f in runs)
        rows.append((label, [f[0] for f in runs], [f[1] or 0.0 for f in runs], f"{spares}/{len(runs)}"))
    return rows


def report(rows, repeats, driver="cdp"):
    load = os.getloadavg()
    how = {"cdp": "driven through the DevTools protocol's Runtime alone",
           "playwright": "driven by Playwright (its Network instrumentation on)"}[driver]
    print(f"explorer in Chromium at 1366 x 768 ({how}), default scene; {repeats} repetitions per action; "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores")
    width = max(len("action"), *(len(row[0]) for row in rows))
    print(f"{'action':<{width}} {'median ms':>9} {'max ms':>8} {'engine ms':>9} {'goal ms':>8} {'median/goal':>11} "
          f"{'spare pages':>11}")
    print("-" * (width + 62))
    for label, times, engines, *spares in rows:
        med, mx = statistics.median(times), max(times)
        goal = GOALS.get(label)
        ratio = f"{med / goal:.2f}" if goal else "-"
        print(f"{label:<{width}} {med:9.0f} {mx:8.0f} {statistics.median(engines):9.1f} {goal or '-':>8} {ratio:>11} "
              f"{spares[0] if spares else '-':>11}")
    print(f"first render: pages opened {FIRST_PAUSE_S:.0f} s apart; back to back: one after another. "
          "spare pages: how many were served from a page the server built in advance (Server-Timing header).")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5, help="repetitions per action (>= 5)")
    ap.add_argument("--url", default=None, help="measure a running explorer instead of starting one")
    ap.add_argument("--driver", choices=sorted(DRIVERS), default="cdp",
                    help="cdp: Chromium as a user runs it (default); playwright: with Playwright's instrumentation")
    args = ap.parse_args()
    if args.url:
        rows = run(args.url, args.repeats, args.driver)
    else:
        with explorer_server() as url:
            rows = run(url, args.repeats, args.driver)
    report(rows, args.repeats, args.driver)
    return 0


if __name__ == "__main__":
    sys.exit(main())
