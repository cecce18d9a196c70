"""Fixtures shared across the suite: tests/engine (camsim_core alone), tests/app (the explorer's state and
server, no browser) and tests/browser (Debian's Chromium through Playwright).

This folder has no ``__init__.py``, so pytest puts it on ``sys.path`` when it loads this file: the helpers
beside it (``app_helpers``, ``ws_session``, ``upload_helpers``, ...) import by name from every area. Areas keep
their own fixtures in their test files.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import camsim_core as cs


#: Test files by the time they took (worker seconds, runs of the whole suite on three workers, 2026-11-27 and
#: 2026-11-29), longest first, the browser's files before the others: ``make test`` hands whole files to its
#: workers in collection order (``--dist loadfile --no-loadscope-reorder``). Starting the longest first leaves the
#: short ones to fill in at the end, where xdist's own order (files with the most tests first) left two or three
#: browser files of a minute or more to run last, on one worker, while the others sat idle; the browser's files
#: in a row let a worker keep its browser open from one to the next (``_WorkerBrowser``). A file missing from the
#: list (new, or renamed) runs after these, browser files before the others; a stale list costs time, never a test.
LONGEST_FIRST = (
    "browser/test_input_fuzz_browser.py", "browser/test_page_serving_browser.py", "browser/test_app_browser.py",
    "browser/test_newcomer_browser.py", "browser/test_tab_walk_browser.py", "browser/test_xss_browser.py",
    "browser/test_upload_browser.py", "browser/test_app_compare_browser.py", "browser/test_server_hostile_browser.py",
    "browser/test_app_monkey.py", "browser/test_measures_browser.py", "browser/test_reader_errors_browser.py",
    "app/test_build_off_loop.py", "app/test_wheel_install.py",
    "engine/test_scale.py", "engine/test_optics_fused.py", "engine/test_reader_fuzz_images.py",
    "app/test_app_compare.py", "app/test_app_state.py",
    "engine/test_scielab.py", "app/test_upload_isolation.py",
    "app/test_notebook.py",
)
_RANK = {name: i for i, name in enumerate(LONGEST_FIRST)}
_AREAS = ("browser", "app", "engine")
_TESTS = Path(__file__).resolve().parent


def _file_rank(item):
    """(0, place in LONGEST_FIRST) for a listed file; (1, its area's place) for the others (doctests last)."""
    try:
        rel = item.path.resolve().relative_to(_TESTS).as_posix()
    except ValueError:  # a doctest of a module outside tests/
        return (2, 0)
    if rel in _RANK:
        return (0, _RANK[rel])
    area = rel.split("/", 1)[0]
    return (1, _AREAS.index(area) if area in _AREAS else len(_AREAS))


def pytest_collection_modifyitems(config, items):
    """Longest test files first (:data:`LONGEST_FIRST`); a stable sort, so tests keep their order in a file.
    Notes the files whose tests use the worker's browser (:class:`_WorkerBrowser`)."""
    items.sort(key=_file_rank)
    _BROWSER_FILES.update(item.path for item in items if _uses_shared_browser(item))


@pytest.fixture(scope="session")
def cacaphony():
    return cs.load_scene("cacaphony290")


@pytest.fixture(scope="session")
def cacaphony64(cacaphony):
    """The default scene in float64: for checks of the engine's arithmetic to float64 precision (shipped
    scenes load as float32, which holds their 16-bit samples)."""
    return dataclasses.replace(cacaphony, data=cacaphony.data.astype(np.float64))


@pytest.fixture(scope="session")
def dcs200_ir():
    return cs.load_camera("kodak-dcs200-ir")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def chromium_profile(tmp_path_factory):
    """The folder of the test browser's profile, one per worker, used by each test module's browser in turn."""
    return tmp_path_factory.mktemp("chromium-profile")


class _WorkerBrowser:
    """Debian's Chromium driven by Playwright, kept open by a worker from one browser test file to the next.

    Launching it (its browser, GPU, zygote and utility processes, Playwright's driver) and closing it cost about
    1.5-2 s of CPU, once per test file before. It is closed before the tests of a file that does not use it (the
    engine's and the explorer's tests, files with a browser of their own) and at the end of the run: Playwright's sync
    API holds an asyncio loop in the thread while it runs, and those tests use asyncio or start Playwright
    themselves."""

    def __init__(self):
        self._playwright = self.context = None

    def open(self, profile):
        if self.context is None:
            from app_helpers import CHROMIUM_ARGS, VIEWPORT, chromium_path
            from playwright.sync_api import sync_playwright

            path = chromium_path()  # RuntimeError: no Chromium (the fixture fails the test with it)
            self._playwright = sync_playwright().start()
            try:
                self.context = self._playwright.chromium.launch_persistent_context(
                    profile, executable_path=path, args=CHROMIUM_ARGS, viewport=VIEWPORT)
            except BaseException:
                self.close()
                raise
        return self.context

    def close(self):
        context, playwright, self.context, self._playwright = self.context, self._playwright, None, None
        try:
            if context is not None:
                context.close()
        finally:
            if playwright is not None:
                playwright.stop()


_WORKER_BROWSER = _WorkerBrowser()
#: The test files with a test that uses it (the others close it: ``pytest_runtest_setup``).
_BROWSER_FILES = set()


def _uses_shared_browser(item):
    """Whether ``item`` uses this conftest's ``browser`` fixture (itself, or through ``page`` or ``shared_page``),
    not a test file's own: a fixture's ``baseid`` is its test file's node id (``....py``) or its conftest's folder,
    whatever folder pytest runs from."""
    defs = getattr(getattr(item, "_fixtureinfo", None), "name2fixturedefs", {}).get("browser")
    return bool(defs) and not defs[-1].baseid.endswith(".py")


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    """Close the worker's browser before the tests of a file that does not use it (:class:`_WorkerBrowser`).
    Within a file that does, it stays open (the file's ``browser`` is its context until the file ends)."""
    if _WORKER_BROWSER.context is not None and item.path not in _BROWSER_FILES:
        _WORKER_BROWSER.close()


def pytest_sessionfinish(session):
    _WORKER_BROWSER.close()


@pytest.fixture(scope="module")
def browser(chromium_profile):
    """Debian's Chromium driven by Playwright (:class:`_WorkerBrowser`, open from one browser test file to the
    next), as its one browser context: the worker's profile (``chromium_profile``), kept on disk as a student's
    browser keeps its own. Files that need other launch options define their own ``browser``. The pages a file
    leaves open are closed after it.

    A profile on disk keeps what the browser compiled of Bokeh's and Panel's scripts (V8's code cache, which a
    private context such as Playwright's ``new_context`` does not keep): a page load then took 1.2-1.4 s of the
    renderer's CPU and 0.4 s of the browser process's, against 2.1-2.6 s and 0.5-0.7 s in a private context
    (seven loads each, 2026-11-28)."""
    try:
        context = _WORKER_BROWSER.open(chromium_profile)
    except RuntimeError as exc:
        pytest.fail(str(exc))
    before = set(context.pages)
    yield context
    for pg in context.pages:
        if pg not in before:
            pg.close()


@pytest.fixture(scope="session")
def server():
    """``camsim serve`` on 127.0.0.1 with its default flags, shared by the test files of a worker.

    Each page is a session of its own, so tests on one server do not see each
    other's designs; a server costs about 9 s of CPU to start (imports, the
    first page built in advance), paid once per worker instead of once per
    file. Files that need other flags, or a server no other test has used
    (counts of pages built, a log with nothing else in it), use
    ``own_server`` or start their own with ``app_helpers.explorer_server``.
    """
    from app_helpers import ARTIFACTS, explorer_server

    ARTIFACTS.mkdir(exist_ok=True)
    with explorer_server() as url:
        yield url


@pytest.fixture(scope="module")
def own_server():
    """``camsim serve`` with its default flags for this test file alone."""
    from app_helpers import ARTIFACTS, explorer_server

    ARTIFACTS.mkdir(exist_ok=True)
    with explorer_server() as url:
        yield url


@pytest.fixture
def page(browser, server):
    """A fresh page of the explorer (``app_helpers.Page``) on this module's server, closed after the test."""
    from app_helpers import Page, server_gone

    gone = server_gone(server)
    if gone:
        pytest.fail(gone)
    pg = Page(browser, server)
    yield pg
    pg.close()


@pytest.fixture(scope="module")
def _module_page(browser):
    """The page :func:`shared_page` hands to the tests of a module (held here, closed after the last)."""
    held = {}
    yield held
    if held.get("page") is not None:
        held["page"].close()


@pytest.fixture
def shared_page(_module_page, browser, server):
    """A page of the explorer that the tests of a module take in turn, each from the page's Start over.

    Opening a page costs about 4.5 s of CPU (Chromium, the server, Playwright's driver); Start over (the
    button a student presses) costs one computation. Each test gets a page as new: the parameters, the images
    computed (their hashes), the tab shown and the message are those of the page when it first showed its
    result, checked (``Page.start_over``); a page left otherwise (presentation mode, pinned designs, closed, not
    back within 30 s) is closed and a new one opened. A test that needs a page no other test has touched
    (what the server sends with the page, its first messages) uses ``page``.
    """
    from app_helpers import Page, server_gone

    gone = server_gone(server)
    if gone:
        pytest.fail(gone)
    pg = _module_page.get("page")
    if pg is not None and not pg.start_over(_module_page["fresh"]):
        pg.close()
        pg = None
    if pg is None:
        pg = _module_page["page"] = Page(browser, server)
        _module_page["fresh"] = pg.status()
    pg.fresh = _module_page["fresh"]  # the page's status when it was new (what Start over gives back)
    yield pg
