"""A page built for its request sends its head first (``camsim_explorer.compat.early_head``): when, and what the
rest of the answer is when the page does not begin as sent or its session cannot be made. The browser's side is
``tests/browser/test_page_serving_browser.py``."""

import asyncio
from types import SimpleNamespace

import pytest

from camsim_explorer.compat import early_head

PAGE = ('<!DOCTYPE html>\n<html><head><title>camsim</title><script src="static/js/bokeh.min.js"></script>\n'
        '<link rel="stylesheet" href="a.css"></head><body><div id="x"></div></body></html>')


class Handler:
    """The parts of Tornado's request handler the hook uses, recording what is written."""

    def __init__(self, path="/", method="GET"):
        self.request = SimpleNamespace(path=path, method=method)
        self.headers, self.out, self.flushes, self._finished = {}, [], 0, False

    def set_header(self, name, value):
        self.headers[name] = value

    def flush(self):
        self.flushes += 1

    def finish(self, chunk=None):
        self.out.append(chunk)
        self._finished = True


def _write(handler, chunk):
    handler.out.append(chunk)


@pytest.fixture
def fresh(monkeypatch):
    monkeypatch.setattr(early_head, "_heads", {})
    monkeypatch.setattr(early_head, "_steady", {})


def _session(handler, get_session):
    return asyncio.run(early_head.session_after_head(handler, get_session, _write))


async def _made(handler):
    return "session"


def test_the_head_goes_first_once_two_pages_of_the_path_began_alike(fresh):
    head = early_head.head_of(PAGE)
    assert head.endswith("bokeh.min.js\"></script>\n") and "stylesheet" not in head
    for i in range(3):
        handler = Handler()
        assert _session(handler, _made) == "session"
        # nothing before the second page has begun as the first; from the third on, the head
        assert handler.out == ([] if i < 2 else [head]) and handler.flushes == (i >= 2), i
        early_head._note("/", PAGE)
    other = Handler("/other")
    _session(other, _made)
    assert other.out == []  # another path has its own pages
    post = Handler(method="POST")
    _session(post, _made)
    assert post.out == []
    early_head._note("/", PAGE.replace("bokeh.min.js", "bokeh.min.js?v=2"))  # a page that begins otherwise
    again = Handler()
    _session(again, _made)
    assert again.out == []  # not steady until two pages begin alike again


def test_a_page_that_does_not_begin_as_sent_is_asked_for_again(fresh):
    head = early_head.head_of(PAGE)
    assert early_head.rest_of(PAGE, head) == PAGE[len(head):]
    changed = PAGE.replace("<title>camsim</title>", "<title>other</title>")
    assert early_head.rest_of(changed, head) is early_head.REFRESH
    assert 'http-equiv="refresh"' in early_head.REFRESH and early_head.REFRESH.rstrip().endswith("</html>")
    assert early_head.head_of(PAGE.replace("<link", "</head><link")) is None  # a stylesheet in the body: nothing


def test_a_session_that_cannot_be_made_after_the_head_went_ends_with_a_line(fresh):
    early_head._note("/", PAGE)
    early_head._note("/", PAGE)
    handler = Handler()

    async def failing(_):
        raise RuntimeError("no session")

    with pytest.raises(RuntimeError, match="no session"):
        _session(handler, failing)
    assert handler.out == [early_head.head_of(PAGE), early_head.FAILED] and handler._finished
    assert handler.headers["Content-Type"] == "text/html"
    assert "could not be built" in early_head.FAILED and early_head.FAILED.rstrip().endswith("</html>")
