"""The README and docs/ say what is true: their Python examples run, their links resolve, and the
README stays the users' page (short, opening with the two make commands CI and users run).

Every ```python block of README.md and docs/**/*.md is run in a fresh temporary directory; where
the text after a block says "It prints `...`", the block's output must be exactly that. Every
relative link (and its #anchor, by GitHub's heading ids) must name an existing file and heading.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
PAGES = [README, ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").rglob("*.md"))]
MAX_README_LINES = 300


def fenced_blocks(text):
    """``(info, code, end)`` of every fenced block of ``text`` (fences paired in order); ``end`` is the
    offset just after the closing fence."""
    blocks, info, start, pos = [], None, 0, 0
    for line in text.splitlines(keepends=True):
        pos += len(line)
        if line.startswith("```"):
            if info is None:
                info, start = line[3:].strip(), pos
            else:
                blocks.append((info, text[start:pos - len(line)], pos))
                info = None
    assert info is None, "a fenced block is not closed"
    return blocks


def python_examples():
    cases = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for k, (info, code, end) in enumerate(b for b in fenced_blocks(text) if b[0] == "python"):
            claim = re.match(r"\s*It prints `([^`]*)`", text[end:])
            cases.append(pytest.param(code, claim.group(1) if claim else None,
                                      id=f"{page.relative_to(ROOT)}[{k}]"))
    return cases


@pytest.mark.parametrize("code, printed", python_examples())
def test_python_example_runs(code, printed, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # examples write files where they run
    exec(compile(code, "<docs example>", "exec"), {"__name__": "__main__"})
    out = capsys.readouterr().out
    if printed is not None:
        assert out.strip() == printed


def test_readme_is_short_and_opens_with_make_serve_and_make_test():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md has {len(lines)} lines, at most {MAX_README_LINES}"
    assert lines[:3] == ["# camsim", "", "```"], "the make commands come right after the title"
    assert lines[3].split("#")[0].strip() == "make serve"
    assert lines[4].split("#")[0].strip() == "make test"


def test_readme_test_command_is_what_ci_runs():
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^make test$", ci, re.M)
    assert re.search(r"^test:", makefile, re.M) and re.search(r"^serve:", makefile, re.M)


def test_the_longest_test_files_named_first_exist_and_make_test_keeps_their_order():
    """``tests/conftest.py`` orders the files by ``LONGEST_FIRST``; a renamed file would silently drop to the end,
    and xdist's own reordering (without ``--no-loadscope-reorder``) would undo the order."""
    import conftest

    missing = [name for name in conftest.LONGEST_FIRST if not (ROOT / "tests" / name).is_file()]
    assert missing == [], f"tests/conftest.py LONGEST_FIRST names files that do not exist: {missing}"
    assert len(set(conftest.LONGEST_FIRST)) == len(conftest.LONGEST_FIRST)
    recipe = re.search(r"^test:.*\n((?:\t.*\n)+)", (ROOT / "Makefile").read_text(encoding="utf-8"), re.M).group(1)
    assert "--dist loadfile" in recipe and "--no-loadscope-reorder" in recipe, recipe


def github_anchor(heading):
    """The id GitHub gives a Markdown heading: lower case, punctuation (but - and _) dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(page):
    text = page.read_text(encoding="utf-8")
    prose = text
    for _, code, end in fenced_blocks(text):
        prose = prose.replace(code, "")
    return {github_anchor(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.*?)\s*$", prose, re.M)}


def relative_links(page):
    text = page.read_text(encoding="utf-8")
    for _, code, _ in fenced_blocks(text):
        text = text.replace(code, "")
    text = re.sub(r"`[^`\n]*`", "", text)  # inline code
    for m in re.finditer(r"!?\[[^\]]*\]\(([^)\s]+)\)", text):
        target = m.group(1)
        if not re.match(r"[a-z][a-z0-9+.-]*:", target):  # not http:, mailto:, ...
            yield target


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_point_to_existing_files_and_headings(page):
    broken = []
    for target in relative_links(page):
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            broken.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target}: no heading #{anchor} in {dest.relative_to(ROOT)}")
    assert not broken, broken


def test_github_anchor_follows_githubs_rule():
    assert github_anchor("Figure 1.14: sensor choice") == "figure-114-sensor-choice"
    assert github_anchor("`camsim report`") == "camsim-report"
    assert github_anchor("Pages built off the event loop (`app/_build_off_loop.py`)") == \
        "pages-built-off-the-event-loop-app_build_off_looppy"
    assert github_anchor("The ideal image (section 4.3)") == "the-ideal-image-section-43"


def test_make_test_and_serve_write_camsims_bytecode_first():
    """Where PYTHONDONTWRITEBYTECODE is set (CI machines), every process of the suite compiled the explorer and
    its dependencies from source as it imported them (4.7 s to import it instead of 2.1 s): ``make`` lets Python
    write the bytecode of what it imports (the dependencies are installed without theirs), and its ``bytecode``
    step writes camsim's before the test workers start."""
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^unexport PYTHONDONTWRITEBYTECODE$", makefile, re.M)
    for target in ("test", "test-fast", "serve"):
        deps = re.search(rf"^{re.escape(target)}:(.*)$", makefile, re.M).group(1).split()
        assert "bytecode" in deps, (target, deps)
    recipe = re.search(r"^bytecode:.*\n((?:\t.*\n)+)", makefile, re.M).group(1)
    assert "compileall" in recipe and all(folder in recipe for folder in ("camsim_core", "app")), recipe
