"""The explorer's escaping helpers (app.safe_text) and its Content-Security-Policy transform (app.csp),
without a browser: what Panel's own Markdown renderer makes of escaped text, and what the policy allows."""

from __future__ import annotations

import html
import re

import panel as pn
import pytest
from tornado.httputil import HTTPHeaders

from camsim_explorer.csp import HEADER, ContentSecurityPolicy, add_nonce, policy
from camsim_explorer.safe_text import PlainText, html_text, md_text

HOSTILE = [
    "<img src=x onerror=window.__pwned=1>",
    "<svg onload=window.__pwned=2>",
    '"><script>window.__pwned=3</script>',
    "[x](javascript:window.__pwned=4)",
    "<javascript:alert(1)>",
    "![x](javascript:alert(1))",
    "`code` **bold** _it_ ~~gone~~ $x^2$ :smile: www.example.com http://example.com a|b",
    "# heading\n- list\n1. item\n> quote\n\n    indented",
    "&lt;already escaped&gt; &amp; 'single' \"double\"",
    "back\\slash \\<b>x</b> [link][ref]\n\n[ref]: javascript:alert(1)",
    "<details open ontoggle=alert(1)>",
    "",
]


def _markdown(text):
    """HTML that Panel's Markdown pane (its markdown-it renderer, as the explorer's panes use it) makes of ``text``."""
    return pn.pane.Markdown._get_parser("markdown-it", ()).render(text)


def _visible(markup):
    """The text a browser shows for ``markup`` (tags dropped, entities decoded)."""
    return html.unescape(re.sub(r"<[^>]*>", "", markup))


@pytest.mark.parametrize("text", HOSTILE)
def test_md_text_renders_as_the_literal_text(text):
    out = _markdown(md_text(text))
    assert re.findall(r"<(\w+)", out) in ([], ["p"])  # one paragraph of text (or nothing), no other element
    assert "href" not in out and "src" not in out.replace("src=x", "")
    assert _visible(out).strip() == re.sub(r"\n+", " ", text).strip()  # line breaks become a space


@pytest.mark.parametrize("text", HOSTILE)
def test_md_text_inside_markdown_and_a_table_cell_stays_text(text):
    """As the explorer uses it: in bold messages, and in the cells of the scene's metadata table."""
    out = _markdown(f"**Refused:** {md_text(text)} (kept)")
    assert re.findall(r"<(\w+)", out) == ["p", "strong"]
    table = _markdown(f"| | |\n|---|---|\n| name | {md_text(text)} |\n| kind | scene |")
    assert set(re.findall(r"<(\w+)", table)) <= {"table", "thead", "tbody", "tr", "th", "td"}
    assert table.count("<tr>") == 3 and table.count("<td>") == 4  # the text stays in its cell


def test_md_text_keeps_a_message_on_one_line():
    assert "\n" not in md_text("a\nb\r\nc\u2028d") and _visible(_markdown(md_text("a\nb"))).strip() == "a b"


@pytest.mark.parametrize("text", HOSTILE)
def test_html_text_is_text_in_elements_and_attributes(text):
    out = html_text(text)
    assert "<" not in out and ">" not in out and '"' not in out and "'" not in out
    assert html.unescape(out) == text
    assert html_text(3.5) == "3.5" and html_text(None) == "None"


def test_plain_text_pane_shows_its_text_and_keeps_it():
    """Panel's Str pane puts its text into the page as HTML; PlainText escapes it (and ``object`` stays the text)."""
    text = '{"name": "<img src=x onerror=alert(1)>"}'
    pane = PlainText(text)
    assert pane.object == text
    sent = pane._transform_object(text)["object"]
    page = html.unescape(sent)  # what the browser decodes from the model, then puts into the page
    assert page.startswith("<pre>") and page.endswith("</pre>") and "<img" not in page
    assert _visible(page) == text
    assert "<img" in html.unescape(pn.pane.Str(text)._transform_object(text)["object"])  # what it guards against


def test_the_policy_allows_the_page_own_scripts_only():
    text = policy("abc123")
    directives = {d.split()[0]: d.split()[1:] for d in text.split("; ")}
    assert directives["script-src"][:2] == ["'self'", "'nonce-abc123'"]
    assert "'unsafe-inline'" not in directives["script-src"] and "'strict-dynamic'" not in directives["script-src"]
    assert directives["script-src-attr"] == ["'none'"]
    assert directives["object-src"] == ["'none'"] and directives["default-src"] == ["'self'"]
    assert not [s for v in directives.values() for s in v if s.startswith(("http", "*"))]  # nothing from elsewhere


def test_add_nonce_marks_inline_scripts_only():
    page = (b'<script type="esms-options">{"shimMode": true}</script>\n<script src="static/js/bokeh.min.js"></script>\n'
            b'<script type="text/javascript">\n  const s = "<script>";\n</script><script>x()</script>'
            b'<script nonce="other">y()</script><p>script</p>')
    out = add_nonce(page, "N1")
    assert out.count(b'nonce="N1"') == 3
    assert b'<script src="static/js/bokeh.min.js"></script>' in out and b'<script nonce="other">' in out
    assert b'const s = "<script>";' in out  # a "<script" inside a script's text is not a tag


def _request():
    from unittest import mock

    return mock.Mock()


def test_the_transform_sets_the_header_and_the_nonces_of_an_html_response():
    transform = ContentSecurityPolicy(_request())
    body = b"<html><script>go()</script></html>"
    headers = HTTPHeaders({"Content-Type": "text/html", "Content-Length": str(len(body))})
    status, headers, chunk = transform.transform_first_chunk(200, headers, body, True)
    nonce = re.search(r"'nonce-([^']+)'", headers[HEADER]).group(1)
    assert chunk == b'<html><script nonce="' + nonce.encode() + b'">go()</script></html>'
    assert headers["Content-Length"] == str(len(chunk))
    again = ContentSecurityPolicy(_request()).transform_first_chunk(
        200, HTTPHeaders({"Content-Type": "text/html"}), body, True)[1][HEADER]
    assert nonce not in again  # a nonce per response
    js = HTTPHeaders({"Content-Type": "application/javascript"})
    assert ContentSecurityPolicy(_request()).transform_first_chunk(200, js, b"<script>", True) == (200, js, b"<script>")
    assert HEADER not in js
