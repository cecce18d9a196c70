"""The engine's layer stays below the explorer's (issue 40).

Every module of ``camsim_core`` is imported in a fresh interpreter, found by
walking the package with :mod:`pkgutil` and checked against the ``.py``
files on disk: none may load Panel, Bokeh, HoloViews or the explorer
(``camsim_explorer``, or the folder ``app`` imported under its folder
name). ``camsim serve`` is the explorer's: without it the command says how
to install it.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import camsim_core

ROOT = Path(__file__).resolve().parents[2]
ENGINE = Path(camsim_core.__file__).resolve().parent
#: Top-level modules the engine must never load.
GUI = ("panel", "bokeh", "holoviews", "camsim_explorer", "app")

#: Run in a fresh interpreter: import every engine module, build the command line's parser, note what got
#: loaded; then run ``camsim serve`` as if the explorer were not installed (the [app] extra left out).
WALK = r"""
import contextlib, importlib, io, json, pkgutil, sys
import camsim_core
names = ["camsim_core"]
for info in pkgutil.walk_packages(camsim_core.__path__, "camsim_core."):
    if info.name.rpartition(".")[2] == "__main__":  # running it is the command line itself
        continue
    importlib.import_module(info.name)
    names.append(info.name)
from camsim_core.cli import build_parser, main
build_parser()  # every command's parser, serve's included
loaded = sorted(m for m in sys.modules if m.partition(".")[0] in %r)

class NoExplorer:
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in ("camsim_explorer", "panel"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)

sys.meta_path.insert(0, NoExplorer())
err = io.StringIO()
with contextlib.redirect_stderr(err):
    status = main(["serve", "--port", "0"])
print(json.dumps({"imported": names, "gui": loaded, "serve": [status, err.getvalue()]}))
"""


@pytest.fixture(scope="module")
def fresh():
    """What the fresh interpreter of :data:`WALK` saw, run from the repository root (where a stray
    ``import app`` would succeed, and so be seen)."""
    out = subprocess.run([sys.executable, "-c", WALK % (GUI,)], cwd=ROOT, capture_output=True, text=True,
                         timeout=180)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _engine_modules_on_disk():
    """Dotted names of camsim_core's modules, from its files (not from pkgutil)."""
    names = set()
    for path in ENGINE.rglob("*.py"):
        rel = path.relative_to(ENGINE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__main__" or "__pycache__" in parts:
            continue
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if all((ENGINE.parent.joinpath(*parts[:i]) / "__init__.py").exists() for i in range(1, len(parts))):
            names.add(".".join(parts))
    return names


def test_every_engine_module_imports_without_the_explorer_or_a_gui_library(fresh):
    on_disk = _engine_modules_on_disk()
    assert len(on_disk) > 50 and on_disk <= set(fresh["imported"]), sorted(on_disk - set(fresh["imported"]))
    assert fresh["gui"] == []


def test_camsim_serve_without_the_explorer_says_how_to_install_it(fresh):
    status, stderr = fresh["serve"]
    assert status == 2
    assert stderr.strip().splitlines() == [
        'camsim serve: error: the explorer is not installed (camsim_explorer is missing): '
        'pip install "camsim-spectral[app]" installs it']


def test_nothing_imports_the_explorer_by_its_folder_name_or_edits_sys_path():
    """The explorer is ``camsim_explorer`` everywhere (a module imported under two names would exist twice,
    with two states); the engine finds nothing by changing ``sys.path``."""
    by_folder = re.compile(r"^\s*(from\s+app(\.|\s+import\b)|import\s+app(\.|\s*$|\s*,|\s+as\b))", re.M)
    offenders = []
    for folder in ("camsim_core", "app", "tests", "benchmarks", "examples"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            text = path.read_text(encoding="utf-8", errors="replace")
            if by_folder.search(text):
                offenders.append(f"{path.relative_to(ROOT)} imports app")
            if folder == "camsim_core" and re.search(r"sys\.path\.(insert|append)|sys\.path\s*\[", text):
                offenders.append(f"{path.relative_to(ROOT)} changes sys.path")
    assert offenders == []


def test_the_package_and_its_command_line_help_load_no_plotting_library():
    """``import camsim_core`` and ``camsim --help`` leave colour-science (which loads matplotlib: 1.1-1.6 s)
    and matplotlib out until something needs them: ``camsim --help`` took 2.7 s, now 1.1 s. Nor do they load
    ``scipy.signal`` (through scikit-image's registration, for the block comparison only): ``import
    camsim_core`` took 1.09 s with it, 0.46 s without, in every server, worker and command."""
    code = ("import contextlib, io, sys\nimport camsim_core\nfrom camsim_core.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n    main(['--help'])\n"
            "print(sorted({m.partition('.')[0] for m in sys.modules} & {'colour', 'matplotlib'}\n"
            "             | {m for m in sys.modules} & {'scipy.signal', 'skimage.feature', 'skimage.registration'}))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip() == "[]", out.stdout


def test_the_explorer_draws_with_bokeh_alone():
    """One plotting layer (issue 40): every module of the explorer imported in a fresh interpreter (built as a
    page would be) loads no HoloViews; the ``app`` extra does not ask for it."""
    import pkgutil

    import camsim_explorer

    names = [info.name for info in pkgutil.walk_packages(camsim_explorer.__path__, "camsim_explorer.")]
    assert {"camsim_explorer.quality", "camsim_explorer.physical", "camsim_explorer.experiments"} <= set(names)
    code = ("import importlib, sys\n"
            f"for name in {names!r}:\n    importlib.import_module(name)\n"
            "from camsim_explorer.main import create_app\n"
            "create_app()\n"
            "print(sorted(m for m in sys.modules if m.partition('.')[0] == 'holoviews'))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=180)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().splitlines()[-1] == "[]", out.stdout[-2000:]
    assert "holoviews" not in (ROOT / "pyproject.toml").read_text().lower()
