"""An ExplorerState computing as in a served page, with the test's thread as the event loop.

``served(state)`` gives the state a :class:`~camsim_explorer.state.Runner`
whose outcomes wait in a queue; ``settle(state, outcomes)`` applies them on
the calling thread, as the page's next-tick callback does, until nothing is
computing. What ran on "the loop" is then what ran on the test's thread.
"""

import queue

from camsim_explorer.state import Runner


def served(state):
    """Give ``state`` a runner whose outcomes wait for the test's thread (the event loop); returns the queue."""
    outcomes = queue.Queue()
    state.set_runner(Runner(state._compute, lambda job, outcome: outcomes.put((job, outcome))))
    return outcomes


def settle(state, outcomes, timeout=120):
    """Apply outcomes on this thread until nothing is computing."""
    while True:
        job, outcome = outcomes.get(timeout=timeout)
        state._apply(job, outcome)
        if not state.computing and not state.runner.busy and outcomes.empty():
            return


def threads_calling(monkeypatch, module, name):
    """Record which threads call ``module.name`` from now on (the test's): returns the list of thread ids."""
    import threading

    seen, original = [], getattr(module, name)

    def recording(*a, **k):
        seen.append(threading.get_ident())
        return original(*a, **k)

    monkeypatch.setattr(module, name, recording)
    return seen
