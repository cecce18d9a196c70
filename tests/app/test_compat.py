"""The explorer's uses of Panel/Bokeh internals are all in ``camsim_explorer.compat``, and all still apply.

Two kinds of check:

* **Loud on upgrade.** Every hook of the compat package needs an internal of
  Panel, Bokeh or Tornado; ``compat.status()`` says whether each is there. On a
  Panel or Bokeh where one is missing, or that is not a release the hooks were
  tested with, these tests fail (at run time the explorer then logs a warning
  and keeps Panel's own behaviour).
* **Nowhere else.** Every other module of the explorer is read (its syntax
  tree, not its text): no attribute, import or ``getattr`` of a name starting
  with ``_`` that Panel, Bokeh or Tornado define, on anything but the
  explorer's own objects.
"""

from __future__ import annotations

import ast
import logging
import re
from functools import lru_cache
from pathlib import Path

import pytest

import camsim_explorer
from camsim_explorer import compat

APP = Path(camsim_explorer.__file__).parent
COMPAT = APP / "compat"


def test_every_hook_applies_to_the_installed_panel_and_bokeh():
    result = compat.apply()
    missing = [name for name, ok in result.items() if not ok]
    assert not missing, f"compat hooks that no longer apply: {missing} (see camsim_explorer/compat)"
    assert set(result) >= {"pages_without_mathjax", "link_values_kept_as_text", "forget_js_links",
                           "flush_stranded_writes", "undelay", "favicon_type", "address_writer", "tornado_app",
                           "skip_busy_tracking", "design_only_for_stylesheets", "build_off_loop",
                           "served_without_cdn", "skip_discarded_defaults", "plain_defaults_once",
                           "connected_at_pull", "early_head"}


def test_panel_and_bokeh_are_releases_the_hooks_were_tested_with():
    for name, (version, known) in compat.versions_tested().items():
        assert known, f"{name} {version} is not in compat.TESTED {compat.TESTED[name]}: re-measure the hooks, then add it"


def test_a_missing_internal_is_a_warning_naming_what_is_lost(monkeypatch, caplog):
    import panel.io.document as pdoc

    monkeypatch.delattr(pdoc, "_WRITE_MSGS")
    monkeypatch.setattr(compat, "_done", {})
    with caplog.at_level(logging.WARNING, logger="camsim.explorer"):
        result = compat.apply()
    assert result["flush_stranded_writes"] is False
    assert any("flush_stranded_writes" in r.getMessage() and "may not reach the page" in r.getMessage()
               for r in caplog.records)
    assert compat.hooks.flush_stranded_writes(object()) is False  # falls back: nothing sent, no error
    monkeypatch.setattr(compat, "_done", {})


def test_nothing_is_patched_on_import():
    import subprocess
    import sys

    code = ("import panel.io.resources as r, panel.io.location as l; from panel.io.state import _state; "
            "from panel.reactive import Reactive; from bokeh.core.has_props import HasProps as H; "
            "from bokeh.core.property.descriptors import PropertyDescriptor as D; "
            "from bokeh.server.session import ServerSession as S; "
            "before = (r._panel_use_mathjax, l.parse_query, _state._add_busy_event, Reactive._update_properties, "
            "H.query_properties_with_values, D._get_default, S.pull); "
            "import camsim_explorer.main, camsim_explorer.state, camsim_explorer.views, camsim_explorer.serve; "
            "after = (r._panel_use_mathjax, l.parse_query, _state._add_busy_event, Reactive._update_properties, "
            "H.query_properties_with_values, D._get_default, S.pull); "
            "assert before == after, 'patched on import'; "
            "import camsim_explorer.compat as c; c.apply(); "
            "assert (r._panel_use_mathjax, l.parse_query, _state._add_busy_event) != before[:3], 'apply() patched nothing'; "
            "assert H.query_properties_with_values is not before[4], 'apply() left Bokeh serialization alone'; "
            "assert D._get_default is not before[5], 'apply() left Bokeh defaults alone'; "
            "assert S.pull != before[6], 'apply() left the pull alone'")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]


@lru_cache(maxsize=1)
def _library_private_names():
    """Names starting with one underscore (not dunders) that Panel, Bokeh or Tornado define or assign."""
    import bokeh
    import panel
    import tornado

    names = set()
    pattern = re.compile(r"(?:def|class)\s+(_[A-Za-z]\w*)|\.(_[A-Za-z]\w*)\s*=[^=]|^\s*(_[A-Za-z]\w*)\s*[:=][^=]", re.M)
    for package in (panel, bokeh, tornado):
        for path in Path(package.__file__).parent.rglob("*.py"):
            for m in pattern.finditer(path.read_text(encoding="utf-8", errors="replace")):
                names.add(next(g for g in m.groups() if g))
    return {n for n in names if not n.startswith("__")}


#: Underscored names that Panel documents as the API of its ESM components (``_esm``, ``_importmap``,
#: ``_stylesheets``: reference/custom_components/JSComponent; ``_handle_msg``: how_to/custom_components/esm/callbacks;
#: ``_rename``: the same pages, to keep a parameter off the browser): public by Panel's own docs.
DOCUMENTED = {"_esm", "_importmap", "_stylesheets", "_handle_msg", "_rename"}


def _library_aliases(tree):
    """Names a module binds to Panel, Bokeh, HoloViews or Tornado modules and classes (``pn``, ``JSComponent``)."""
    roots = ("panel", "bokeh", "holoviews", "tornado")
    aliases = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            aliases |= {(a.asname or a.name).split(".")[0] for a in node.names if a.name.split(".")[0] in roots}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in roots:
            aliases |= {a.asname or a.name for a in node.names}
    return aliases


def _root(node):
    while isinstance(node, (ast.Attribute, ast.Call, ast.Subscript)):
        node = node.value if not isinstance(node, ast.Call) else node.func
    return node.id if isinstance(node, ast.Name) else None


def _library_classes(tree):
    """Class definitions of a module that subclass a Panel, Bokeh, HoloViews or Tornado class."""
    aliases = _library_aliases(tree)
    return [n for n in ast.walk(tree) if isinstance(n, ast.ClassDef) and any(_root(b) in aliases for b in n.bases)]


def _own_private_names():
    """Private names the explorer and the engine define themselves on their own objects and modules:
    attributes set on ``self``/``cls``, members of classes that subclass nothing of Panel's or Bokeh's,
    module-level names (so ``state._uploads`` on the explorer's own state is not Panel's)."""
    own = set()
    roots = [APP, Path(__import__("camsim_core").__file__).parent]
    for root in roots:
        for path in root.rglob("*.py"):
            if COMPAT in path.parents:
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"))
            library = {id(c) for c in _library_classes(tree)}
            for node in ast.walk(tree):
                if isinstance(node, ast.ClassDef) and id(node) not in library:
                    for item in node.body:
                        names = [item.name] if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) else \
                            [t.id for t in getattr(item, "targets", [getattr(item, "target", None)]) if isinstance(t, ast.Name)]
                        own |= {n for n in names if n.startswith("_")}
                elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and node.attr.startswith("_"):
                    if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                        own.add(node.attr)
            for item in tree.body:  # module level
                if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and item.name.startswith("_"):
                    own.add(item.name)
                for t in getattr(item, "targets", [getattr(item, "target", None)]):
                    if isinstance(t, ast.Name) and t.id.startswith("_"):
                        own.add(t.id)
    return own


def _uses(path, library, own):
    """(line, what) for each touch of a library's private name in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for cls in _library_classes(tree):  # overriding a private member of a Panel or Bokeh class
        for item in cls.body:
            names = [item.name] if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) else \
                [t.id for t in getattr(item, "targets", [getattr(item, "target", None)]) if isinstance(t, ast.Name)]
            found += [(item.lineno, f"{cls.name}.{n} overrides a private member") for n in names
                      if n in library and n not in DOCUMENTED]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in ("panel", "bokeh", "tornado", "param", "holoviews"):
            found += [(node.lineno, f"from {node.module} import {a.name}") for a in node.names
                      if a.name.startswith("_") and not a.name.startswith("__")]
        elif isinstance(node, ast.Attribute) and node.attr in library and node.attr not in own and node.attr not in DOCUMENTED:
            base = node.value
            if isinstance(base, ast.Name) and base.id in ("self", "cls"):
                continue
            found.append((node.lineno, f".{node.attr}"))
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr", "setattr")
              and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant) and isinstance(node.args[1].value, str)
              and node.args[1].value in library and node.args[1].value not in own):
            found.append((node.lineno, f"{node.func.id}(..., {node.args[1].value!r})"))
    return found


def test_no_module_outside_compat_touches_a_private_panel_bokeh_or_tornado_name():
    library, own = _library_private_names(), _own_private_names()
    assert {"_WRITE_MSGS", "_update_query", "_debounce", "_tornado", "_synced", "_handle_pull"} <= library  # the scan sees them
    offenders = []
    for path in sorted(APP.rglob("*.py")):
        if COMPAT in path.parents:
            continue
        offenders += [f"{path.relative_to(APP.parent)}:{line}: {what}" for line, what in _uses(path, library, own)]
    assert not offenders, "private Panel/Bokeh/Tornado names outside camsim_explorer/compat:\n" + "\n".join(offenders)


def test_the_scan_finds_a_private_use(tmp_path):
    # the check itself can fail: a module that reaches into Panel is reported
    bad = tmp_path / "bad.py"
    bad.write_text("import panel as pn\nfrom panel.io.state import _state\n"
                   "def f(w, loc):\n    w._debounce = 0\n    return getattr(loc, '_synced', None)\n"
                   "class P(pn.pane.Str):\n    def _transform_object(self, obj):\n        return {}\n"
                   "class J(pn.custom.JSComponent):\n    _esm = ''\n")
    uses = _uses(bad, _library_private_names(), _own_private_names())
    assert sorted(u[1] for u in uses) == sorted(["from panel.io.state import _state", "._debounce", "getattr(..., '_synced')",
                                                 "P._transform_object overrides a private member"])


@pytest.mark.parametrize("name", ["camsim_explorer.compat.tuning", "camsim_explorer.compat.plain_text",
                                  "camsim_explorer.compat.bokeh_defaults", "camsim_explorer.compat.number_box",
                                  "camsim_explorer.compat.early_head"])
def test_compat_examples_run(name):
    import doctest
    import importlib

    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_a_number_box_takes_any_whole_number_the_browser_sends():
    """JavaScript writes 1e20 as "100000000000000000000", an int beyond 64 bits that Panel's own box handed to
    ``np.isnan`` (TypeError, a traceback in the server's log). Sent through Panel's event processing, as the
    browser's message is; fails when Panel stops calling the override."""
    import panel as pn

    from camsim_explorer.compat.number_box import FloatInput

    with pytest.raises(TypeError):  # the hazard, in Panel's own box
        pn.widgets.FloatInput(value=1.0)._process_events({"value": 10 ** 20})
    box = FloatInput(value=1.0)
    for sent, read in ((10 ** 20, 1e20), (-(10 ** 400), float("-inf")), (7, 7.0), (2.5, 2.5)):
        box._process_events({"value": sent})
        assert box.value == read and type(box.value) is float, (sent, box.value)


def test_the_server_serves_its_resources_itself_whatever_the_environment(monkeypatch):
    # a cdn resource mode in the environment (or left by a notebook rendering) sent pages to cdn.holoviz.org
    from bokeh.settings import settings
    from panel.io.resources import set_resource_mode, use_cdn

    from camsim_explorer.serve import serve_resources_locally

    monkeypatch.setenv("BOKEH_RESOURCES", "cdn")
    assert use_cdn()  # the hazard: Panel would take its CSS from the CDN
    try:
        serve_resources_locally()
        assert not use_cdn()
        with set_resource_mode("cdn"):  # Panel's temporary change (a notebook rendering) ...
            pass
        assert not use_cdn()  # ... restores the server's mode, not the environment's
    finally:
        settings.resources.unset_value()


@pytest.fixture
def without_cdn():
    """``hooks.served_without_cdn`` applied for one test, and Panel given back as it was (a notebook may use
    the CDN)."""
    import panel.io.resources as resources
    import panel.reactive as reactive
    import panel.template.base as template

    from camsim_explorer.compat import hooks

    use_cdn, patch = resources.use_cdn, resources.patch_stylesheet
    yield hooks.served_without_cdn
    resources.use_cdn = template.use_cdn = getattr(use_cdn, "original", use_cdn)
    resources.patch_stylesheet = reactive.patch_stylesheet = getattr(patch, "original", patch)


def test_a_served_page_never_asks_the_cdn_even_inside_a_cdn_rendering(without_cdn):
    import panel.io.resources as resources
    import panel.template.base as template

    assert without_cdn()
    with resources.set_resource_mode("cdn"):  # what a notebook rendering does, process-wide
        assert not resources.use_cdn() and not template.use_cdn()
        assert not resources.get_dist_path().startswith("http")


def test_a_component_made_for_a_page_not_yet_written_takes_its_stylesheets_from_this_server(without_cdn):
    """A page's document has no ``dist_url`` until Panel writes the page (it is built before, in camsim's
    builder thread), and Panel pointed the stylesheets of a component made then at cdn.holoviz.org: a sweep's
    plot loaded 219 stylesheets the page's policy refused (CI)."""
    import panel as pn
    import panel.io.resources as resources
    from bokeh.document import Document
    from bokeh.models import ImportedStyleSheet

    def urls(doc):
        model = pn.widgets.Button(label="Run").get_root(doc)
        return [s.url for s in model.select({"type": ImportedStyleSheet})]

    assert any(u.startswith(resources.CDN_DIST) for u in urls(Document()))  # Panel's own answer: the CDN
    assert without_cdn()
    made = urls(Document())
    assert made and not any(u.startswith("http") for u in made), made
    assert any(resources.LOCAL_DIST in u for u in made), made


def test_the_explorer_uses_no_widget_name_panel_2_removes():
    """Panel 1.9 labels widgets with ``label`` and colours buttons with ``color``; ``name`` and ``button_type``
    warn and go in Panel 2.0. The whole page, every tab built, uses neither (a warning here is an error)."""
    import warnings

    from camsim_explorer import main
    from camsim_explorer.shown import now
    from camsim_explorer.state import ExplorerState
    from camsim_explorer.views import ResultsView

    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=r".*(Widget\.name|button_type) is deprecated")
        main.create_app()
        state = ExplorerState()
        views = {"results": ResultsView(state)}
        for _, build in main.TABS:
            build(state, views, now)


def test_a_session_is_connected_for_panel_once_its_document_is_pulled():
    import asyncio
    from types import SimpleNamespace

    from bokeh.document import Document
    from bokeh.server.session import ServerSession
    from panel.io.state import state

    compat.apply()
    doc, empty = Document(), Document()

    async def handle_pull(message, connection):  # as Bokeh's: the reply made from the document, or None
        return "reply" if connection.session.document is doc else None

    def pull(document):
        connection = SimpleNamespace(session=SimpleNamespace(document=document, _handle_pull=handle_pull))
        return asyncio.run(ServerSession.pull("message", connection))

    assert not state._connected.get(doc)
    assert pull(doc) == "reply"
    assert state._connected.get(doc) is True  # changes made from now on go to the page as patches
    assert pull(empty) is None and not state._connected.get(empty)  # no reply (a destroyed session): not connected
