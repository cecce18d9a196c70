"""An ExplorerState computing as in a served page, with the test's thread as the event loop.

``served(state)`` gives the state a :class:`~camsim_explorer.state.Runner`
whose outcomes wait in a queue; ``settle(state, outcomes)`` applies them on
the calling thread, as the page's next-tick callback does, until nothing is
computing. What ran on "the loop" is then what ran on the test's thread.
"""

import queue
import time

from camsim_explorer.state import Runner


def served(state):
    """Give ``state`` a runner whose outcomes wait for the test's thread (the event loop); returns the queue."""
    outcomes = queue.Queue()
    state.set_runner(Runner(state._compute, lambda job, outcome: outcomes.put((job, outcome))))
    return outcomes


def settle(state, outcomes, timeout=120):
    """Apply outcomes on this thread until nothing is computing and the runner is idle.

    The runner hands over an outcome before it looks for a newer job and calls itself idle: right after
    the last outcome is applied it may still say busy, with nothing more to come (a wait for another
    outcome then hung for ``timeout`` s on a loaded machine). So the queue is looked at in short waits,
    until the state computes nothing and the runner is idle, with no outcome left."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            job, outcome = outcomes.get(timeout=0.02)
        except queue.Empty:
            if not state.computing and not state.runner.busy and outcomes.empty():
                return
            if time.monotonic() > deadline:
                raise AssertionError(f"the session still computes after {timeout} s (computing {state.computing}, "
                                     f"runner busy {state.runner.busy})") from None
            continue
        state._apply(job, outcome)


def threads_calling(monkeypatch, module, name):
    """Record which threads call ``module.name`` from now on (the test's): returns the list of thread ids."""
    import threading

    seen, original = [], getattr(module, name)

    def recording(*a, **k):
        seen.append(threading.get_ident())
        return original(*a, **k)

    monkeypatch.setattr(module, name, recording)
    return seen
