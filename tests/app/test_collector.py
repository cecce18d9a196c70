"""``camsim serve``'s full garbage collections at quiet moments (``camsim_explorer.collector``)."""

import gc

import pytest

from camsim_explorer.collector import OUT_OF_REACH, QuietCollector


class Clock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now


def _full_collections():
    return gc.get_stats()[2]["collections"]


def _make_long_lived(n):
    """``n`` small containers that survive young collections (so they reach generation 2)."""
    return [[i] for i in range(n)]


@pytest.fixture
def collector():
    clock = Clock()
    page = {"idle": 0.0, "busy": False}
    c = QuietCollector(idle_for=lambda: page["idle"], busy=lambda: page["busy"], quiet_s=2.0, every_s=20.0,
                       at_most_s=120.0, clock=clock)
    c.start()
    try:
        yield c, clock, page
    finally:
        c.stop()


def test_python_makes_full_collections_of_its_own_without_the_collector():
    """The control for the next test: a million objects that live make Python run full collections."""
    before = _full_collections()
    kept = _make_long_lived(1_000_000)
    assert _full_collections() > before
    del kept


def test_with_the_collector_python_makes_no_full_collection_of_its_own(collector):
    before = _full_collections()
    kept = _make_long_lived(1_000_000)
    assert _full_collections() == before
    assert gc.get_threshold()[2] == OUT_OF_REACH
    del kept


def test_a_full_collection_waits_for_quiet_pages_or_the_longest_interval(collector):
    c, clock, page = collector
    gc.collect(1)  # something reached generation 2
    assert gc.get_count()[2] > 0
    clock.now += 30  # past every_s, but a page sent a message 0.5 s ago
    page["idle"] = 0.5
    assert not c.due()
    page["idle"], page["busy"] = 5.0, True  # quiet, but a session computes
    assert not c.due()
    page["busy"] = False
    assert c.due()
    page["idle"] = 0.1
    clock.now += 100  # 130 s since the last full collection: quiet or not
    assert c.due()
    before = _full_collections()
    assert c.check() is True
    assert _full_collections() == before + 1
    assert c.last_full == clock.now  # noted from the collection itself
    assert not c.due()  # nothing reached generation 2 since
    clock.now += 5
    gc.collect(1)
    page["idle"] = 60.0
    assert not c.due()  # quiet, but only 5 s after the last


def test_stop_gives_python_its_thresholds_back():
    before = gc.get_threshold()
    c = QuietCollector(idle_for=lambda: 0.0, busy=lambda: False)
    c.start()
    c.stop()
    assert gc.get_threshold() == before
    assert c._noted not in gc.callbacks


def test_camsim_serve_turns_pythons_full_collections_off_and_looks_every_second(monkeypatch):
    import asyncio

    from tornado.ioloop import IOLoop

    from camsim_explorer import serve
    from camsim_explorer.compat import spare_session

    monkeypatch.setattr(spare_session, "note_messages", lambda: None)  # not Bokeh's handler, in the test process
    looks = []
    monkeypatch.setattr(QuietCollector, "check", lambda self: looks.append(self))
    before = gc.get_threshold()
    loop = IOLoop(make_current=False)
    made = []

    async def serving():
        made.append(serve._full_collections_when_quiet(IOLoop.current()))
        await asyncio.sleep(2.3)

    try:
        loop.run_sync(serving)
        assert gc.get_threshold()[2] == OUT_OF_REACH
        assert len(looks) >= 2 and set(looks) == set(made)
    finally:
        for c in made:
            c.stop()
        loop.close()
    assert gc.get_threshold() == before
