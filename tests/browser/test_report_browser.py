"""The ``camsim report`` HTML in a real Chromium with no network: every image decodes, the tables hold
the engine's numbers for each design run alone."""

import json

import pytest

from app_helpers import ARTIFACTS, CHROMIUM_ARGS, chromium_path
from camsim_core.cli import main
from camsim_core.review import evaluate_design

pytestmark = pytest.mark.browser

DESIGNS = {"dcs200": {"camera": "kodak-dcs200-ir"}, "cones": {"camera": "human-cones"}}
SWEEP = [0.0, 4.0]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    files = []
    for name, params in DESIGNS.items():
        path = folder / f"{name}.json"
        path.write_text(json.dumps(params))
        files.append(str(path))
    out = folder / "report.html"
    assert main(["report", *files, "--out", str(out), "--sweep", "noise_sigma=" + ",".join(map(str, SWEEP))]) == 0
    return out


@pytest.fixture(scope="module")
def page(report):
    from playwright.sync_api import sync_playwright

    try:
        path = chromium_path()
    except RuntimeError as exc:
        pytest.fail(str(exc))
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        context = browser.new_context(offline=True)
        attempted = []

        def block(route):
            url = route.request.url
            if url.startswith(("data:", "file:")):
                route.continue_()
            else:
                attempted.append(url)
                route.abort()

        context.route("**/*", block)
        pg = context.new_page()
        pg.on("request", lambda r: None if r.url.startswith(("data:", "file:")) else attempted.append(r.url))
        errors = []  # a resource refused by the report's Content-Security-Policy shows up here
        pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        pg.goto(report.as_uri())
        pg.wait_for_load_state("load")
        pg.attempted, pg.errors = attempted, errors
        ARTIFACTS.mkdir(exist_ok=True)
        pg.screenshot(path=str(ARTIFACTS / "report.png"), full_page=True)
        yield pg
        browser.close()


def test_report_needs_no_network(page):
    assert page.attempted == [] and page.errors == []
    srcs = page.eval_on_selector_all("img", "els => els.map(e => e.getAttribute('src').slice(0, 22))")
    assert srcs and set(srcs) == {"data:image/png;base64,"}


def test_every_image_decodes(page):
    sizes = page.eval_on_selector_all("img", "els => els.map(e => [e.complete, e.naturalWidth, e.naturalHeight])")
    # ideal + colour bar + (rendered, CIELAB map, S-CIELAB map) x 2 + histogram + A/B (2) + sweep plot
    assert len(sizes) == 12
    assert all(done and w > 0 and h > 0 for done, w, h in sizes), sizes
    rendered = page.eval_on_selector_all("img[alt$=': rendered']", "els => els.map(e => [e.naturalWidth, e.naturalHeight])")
    assert rendered == [[372, 233], [372, 233]]  # cacaphony290 through the DCS-200 geometry at 3.32 m


def _rows(page, table):
    return page.eval_on_selector_all(
        f"#{table} tbody tr",
        "rows => rows.map(r => [...r.children].map(c => [c.innerText, c.dataset.value || null]))")


def test_tables_hold_the_engines_numbers_for_each_design_alone(page):
    rows = {r[0][0]: r[1:] for r in _rows(page, "measures")}
    assert set(rows) == set(DESIGNS)
    means = []
    for name, params in DESIGNS.items():
        alone = evaluate_design(params, name)
        m = alone.measures
        expected = [m["cielab"]["mean"], m["cielab"]["median"], m["cielab"]["p95"],
                    m["scielab"]["mean"], m["scielab"]["median"], m["scielab"]["p95"]]
        shown = rows[name]
        assert [t for t, _ in shown[:6]] == [f"{v:.2f}" for v in expected]
        assert [float(v) for _, v in shown[:6]] == expected
        # then the image-quality measures the scene allows (the default photo: PSNR and SSIM)
        assert set(alone.quality) == {"psnr_db", "ssim"}
        assert [float(v) for _, v in shown[6:]] == [alone.quality["psnr_db"], alone.quality["ssim"]]
        means.append(m["cielab"]["mean"])
    assert means[0] != means[1]
    differ = {r[0][0]: [t for t, _ in r[1:]] for r in _rows(page, "differ")}
    assert differ == {"camera": ["kodak-dcs200-ir", "human-cones"]}


def test_sweep_table_points_equal_each_configuration_alone(page):
    rows = _rows(page, "sweep")
    assert len(rows) == len(DESIGNS) * len(SWEEP)
    for row in rows:
        name, value = row[0][0], float(row[1][0])
        alone = evaluate_design({**DESIGNS[name], "noise_sigma": value}, name)
        assert float(row[2][1]) == alone.measures["cielab"]["mean"]
        assert float(row[3][1]) == alone.measures["cielab"]["median"]


def test_report_names_the_version_and_the_scene(page):
    import camsim_core

    meta = page.inner_text("p.meta")
    assert f"camsim {camsim_core.__version__}" in meta and "cacaphony290" in meta
    data = json.loads(page.inner_text("#camsim-report-data") or page.eval_on_selector(
        "#camsim-report-data", "e => e.textContent"))
    assert [d["name"] for d in data["designs"]] == list(DESIGNS)
