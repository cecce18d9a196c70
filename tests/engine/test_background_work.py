"""Background work (sweeps) takes one core at most, at lower priority, whatever session runs it."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest

from camsim_core import _parallel
from camsim_core._parallel import BACKGROUND_NICE, background, run_blocks


def _in_thread(fn):
    out = {}

    def run():
        out["value"] = fn()

    t = threading.Thread(target=run)
    t.start()
    t.join(30)
    return out["value"]


def test_background_blocks_run_in_the_calling_thread_at_lower_priority():
    def work():
        seen = []
        before = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
        with background():
            run_blocks(lambda a, b: seen.append(threading.get_ident()), [0, 10, 20, 30], values=10**9)
            nice = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
        return seen, threading.get_ident(), before, nice

    seen, me, before, nice = _in_thread(work)
    assert seen == [me] * 3  # no block went to the shared pool
    # set to BACKGROUND_NICE (absolute); a thread already nicer than that may stay so (lowering needs privilege)
    assert nice == BACKGROUND_NICE or nice == before > BACKGROUND_NICE


def test_outside_background_large_work_uses_the_pool():
    if _parallel.CORES < 2:
        pytest.skip("one core: the pool is never used")
    seen = []
    run_blocks(lambda a, b: seen.append(threading.get_ident()), [0, 10, 20], values=10**9)
    assert threading.get_ident() not in seen


def test_two_background_jobs_never_overlap():
    from overlap import Overlap

    active = Overlap()

    def job():
        for _ in range(5):
            with background(), active:
                time.sleep(0.005)

    threads = [threading.Thread(target=job) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert active.most == 1


def test_a_sweep_computes_its_points_as_background_work(monkeypatch):
    import camsim_core.review.sweep as sweep

    seen = []

    def fake(params, name, **kw):
        seen.append((_parallel._local.depth, os.getpriority(os.PRIO_PROCESS, threading.get_native_id())))
        raise sweep.CamsimError("stop here")

    monkeypatch.setattr(sweep, "evaluate_design", fake)
    base = os.getpriority(os.PRIO_PROCESS, 0)
    points = sweep.run_sweep([("a", {"camera": "kodak-dcs200"})], "noise_sigma", [0.0, 2.0])
    assert len(points) == 2 and all(p.error == "stop here" for p in points)
    assert seen and all(depth == 1 and nice >= BACKGROUND_NICE for depth, nice in seen)
    assert os.getpriority(os.PRIO_PROCESS, 0) == base  # the caller's own thread keeps its priority


def test_quality_measures_left_for_later_are_the_same_numbers_measured_as_background_work(monkeypatch):
    """A pinned design's image-quality measures, left for later and measured as background work (one core, lower
    priority), are the numbers measured with the design; a quality that is neither is refused by name."""
    import camsim_core.review.design as design

    params = {"scene": "macbeth", "camera": "kodak-dcs200"}
    now = design.evaluate_design(params, quality=True).quality
    later = design.evaluate_design(params, quality="later")
    assert later.quality == {} and later.quality_pending
    seen = []
    real = design.quality_measures
    monkeypatch.setattr(design, "quality_measures", lambda *a: seen.append(
        (_parallel._local.depth, os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))) or real(*a))
    measured = _in_thread(lambda: later.measure_quality(background=True))
    assert measured == now and set(now) == {"psnr_db", "ssim", "macbeth_de2000"}
    assert not later.quality_pending and later.quality_inputs is None  # the pipeline result is released
    assert len(seen) == 1 and seen[0][0] == 1 and seen[0][1] >= BACKGROUND_NICE
    assert later.measure_quality() is later.quality and len(seen) == 1  # measured once
    with pytest.raises(design.ParameterError, match="quality"):
        design.evaluate_design(params, quality="soon")
