"""A non-editable install works from any directory (issue 40).

The wheel is built from a copy of the sources (``pip wheel --no-deps
--no-build-isolation``: no network, and no ``build/`` left in the
checkout), checked for what it holds, and installed (``--no-deps``) in a
fresh virtual environment. That environment sees the project's
dependencies through a ``.pth`` file naming this environment's
site-packages, whose own ``.pth`` files (the editable install's finder
among them) are not run, so it cannot import the checkout. From a
temporary directory, with ``python -I``, the installed package loads a
shipped scene and camera, simulates, demosaics and renders (the same
numbers as the checkout), and the installed ``camsim serve`` answers on a
free loopback port with the explorer's page.
"""

import json
import os
import re
import shutil
import site
import socket
import subprocess
import sys
import time
import urllib.request
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
#: What the build reads: the project file, the readme it names, the packages' folders.
SOURCES = ("pyproject.toml", "README.md", "camsim_core", "app", "assets")
SKIP = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
#: Seconds the installed server may take to answer (numba compiles the engine afresh in a new environment).
SERVER_TIMEOUT = 240

#: Run by the installed Python from a temporary directory: where the packages come from, and a simulation.
ENGINE_RUN = r"""
import importlib.util, json, sys
import numpy as np
import camsim_core as cs
import camsim_explorer
scene = cs.load_scene("cacaphony290")
camera = cs.load_camera("kodak-dcs200")
camera = camera.replace(exposure=cs.auto_exposure(scene, camera))
raw = cs.simulate(scene, camera)
rendered = cs.render(cs.demosaic(raw), cs.load_monitor("simtoolbox-test"))
np.savez(sys.argv[1], raw=np.asarray(raw.data), rendered=np.asarray(rendered.data))
print(json.dumps({"camsim_core": cs.__file__, "camsim_explorer": camsim_explorer.__file__, "path": sys.path,
                  "modules": sorted(m for m in sys.modules if m.startswith("__editable__") or m.partition(".")[0] == "app"),
                  "app_importable": importlib.util.find_spec("app") is not None}))
"""


def _copy_sources(dest):
    for name in SOURCES:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=SKIP)
        else:
            shutil.copy2(src, dest / name)
    for extra in ("setup.py", "setup.cfg", "MANIFEST.in"):  # none today; a build reading one gets it
        if (ROOT / extra).exists():
            shutil.copy2(ROOT / extra, dest / extra)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The project's wheel, built from a copy of the working tree."""
    work = tmp_path_factory.mktemp("wheel")
    (work / "src").mkdir()
    _copy_sources(work / "src")
    out = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "--no-build-isolation",
                          "--no-index", "--wheel-dir", str(work / "dist"), str(work / "src")],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-3000:]
    (built,) = (work / "dist").glob("camsim_spectral-*.whl")
    return built


def test_the_wheel_holds_the_engine_the_explorer_and_every_shipped_file(wheel):
    with zipfile.ZipFile(wheel) as z:
        infos = {i.filename: i for i in z.infolist()}
        entry_points = next(z.read(n).decode() for n in infos if n.endswith(".dist-info/entry_points.txt"))
    tops = {n.split("/")[0] for n in infos if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"camsim_core", "camsim_explorer"}  # no top-level `app` or `assets`
    missing = []
    for init in (ROOT / "camsim_core").rglob("__init__.py"):  # every package of the engine
        name = init.relative_to(ROOT).as_posix()
        missing += [] if name in infos else [name]
    for module in (ROOT / "app").rglob("*.py"):  # the explorer and its subpackages, under its own name
        name = module.relative_to(ROOT / "app").as_posix()
        missing += [] if f"camsim_explorer/{name}" in infos else [f"app/{name}"]
    shipped = [p for p in (ROOT / "assets").rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    for path in shipped:  # every shipped file, byte for byte (the zip's CRC-32 of it)
        name = "camsim_core/assets/" + path.relative_to(ROOT / "assets").as_posix()
        if name not in infos or infos[name].CRC != zlib.crc32(path.read_bytes()):
            missing.append(name)
    assert missing == [] and len(shipped) > 100
    assert re.search(r"^camsim\s*=\s*camsim_core\.cli:main\s*$", entry_points, re.M), entry_points


def _fresh_environment(folder, wheel):
    """A new virtual environment with only ``wheel`` installed; the dependencies are this environment's."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(folder)], check=True, timeout=120)
    python = folder / "bin" / "python"
    # without the caller's PYTHONPATH: an empty entry in it is the working directory, the checkout, where pip found
    # camsim already installed (its egg-info) and installed nothing
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet", "--no-deps",
                          "--no-index", str(wheel)], capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-3000:]
    purelib = subprocess.run([str(python), "-I", "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                             capture_output=True, text=True, check=True).stdout.strip()
    ours = [p for p in site.getsitepackages() if Path(p).is_dir()]
    # a path line adds the folder to sys.path; the .pth files inside it (the editable finder's) are not run
    (Path(purelib) / "camsim-test-dependencies.pth").write_text("\n".join(ours) + "\n")
    return python, Path(purelib)


def _clean_env(folder, home):
    keep = {k: os.environ[k] for k in ("LANG", "LC_ALL", "TMPDIR", "NUMBA_CACHE_DIR") if k in os.environ}
    return dict(keep, PATH=f"{folder / 'bin'}{os.pathsep}/usr/bin{os.pathsep}/bin", HOME=str(home),
                PYTHONNOUSERSITE="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", BOKEH_LOG_LEVEL="warn")


def _expected(scene_name="cacaphony290", camera_name="kodak-dcs200"):
    """The same simulation by the checkout's camsim (this process)."""
    import camsim_core as cs

    scene, camera = cs.load_scene(scene_name), cs.load_camera(camera_name)
    camera = camera.replace(exposure=cs.auto_exposure(scene, camera))
    raw = cs.simulate(scene, camera)
    return raw, cs.render(cs.demosaic(raw), cs.load_monitor("simtoolbox-test"))


def test_the_installed_wheel_simulates_and_serves_from_any_directory(wheel, tmp_path):
    venv, elsewhere = tmp_path / "venv", tmp_path / "elsewhere"
    elsewhere.mkdir()
    python, purelib = _fresh_environment(venv, wheel)
    env = _clean_env(venv, elsewhere)
    camsim = venv / "bin" / "camsim"
    assert camsim.exists()  # the console script
    log = open(tmp_path / "server.log", "w+")
    server = subprocess.Popen([str(camsim), "serve", "--port", "0", "--address", "127.0.0.1", "--no-upload",
                               "--no-spare-page"], cwd=elsewhere, env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        port = _port_when_listening(server, tmp_path / "server.log")
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=120) as response:
            status, headers, page = response.status, response.headers, response.read().decode()
        assert status == 200
        assert "<title>camsim explorer" in page
        assert "Content-Security-Policy" in headers  # the explorer's serve module answered

        # after the server's warm-up, which compiled the engine's kernels into the installed package (not twice)
        run = subprocess.run([str(python), "-I", "-c", ENGINE_RUN, str(tmp_path / "installed.npz")], cwd=elsewhere,
                             env=env, capture_output=True, text=True, timeout=SERVER_TIMEOUT)
        assert run.returncode == 0, run.stderr[-3000:]
        seen = json.loads(run.stdout.strip().splitlines()[-1])
        for package in ("camsim_core", "camsim_explorer"):
            assert Path(seen[package]).is_relative_to(purelib), seen[package]
        assert seen["modules"] == [] and not seen["app_importable"]  # no editable finder; the checkout's app/ unseen
        assert not any(Path(p).resolve() == ROOT or Path(p).resolve().is_relative_to(ROOT / "camsim_core")
                       for p in seen["path"] if p), seen["path"]
        installed = np.load(tmp_path / "installed.npz")
        raw, rendered = _expected()
        assert np.median(installed["raw"]) > 0 and np.percentile(installed["raw"], 99) < 255  # exposed, not saturated
        np.testing.assert_array_equal(installed["raw"], np.asarray(raw.data))
        np.testing.assert_array_equal(installed["rendered"], np.asarray(rendered.data))
    finally:
        server.terminate()
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        log.close()


def _port_when_listening(server, log_path):
    """The port ``camsim serve --port 0`` printed, once it accepts connections."""
    deadline = time.monotonic() + SERVER_TIMEOUT
    port = None
    while True:
        assert server.poll() is None, f"camsim serve exited ({server.returncode}): {log_path.read_text()[-3000:]}"
        assert time.monotonic() < deadline, f"camsim serve did not answer: {log_path.read_text()[-3000:]}"
        if port is None:
            found = re.search(r"http://localhost:(\d+)/", log_path.read_text(errors="replace"))
            port = int(found.group(1)) if found else None
        if port is not None:
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=2):
                    return port
            except OSError:
                pass
        time.sleep(0.1)
