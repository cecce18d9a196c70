"""Running one task per configuration: in-process, on a local Dask cluster, or on an existing one.

``run_tasks(function, configurations, workers=..., scheduler=...)`` returns
``[function(c) for c in configurations]`` in the configurations' order
whatever the order in which tasks finish, so that (with each task seeded
from its own configuration, :func:`~camsim_core.experiments.grid.task_seed`)
a sweep gives the same numbers on 1, 2 or 100 workers.

* ``workers=None`` and no scheduler: a plain loop in this process (no Dask;
  what the explorer's Experiments tab uses).
* ``workers=N``: a :class:`distributed.LocalCluster` of N workers with one
  thread each, bound to 127.0.0.1 with the dashboard off, closed at the end.
* ``scheduler="tcp://host:8786"``: an existing cluster (its workers must be
  able to import ``camsim_core`` and read the scenes).

A tqdm progress bar counts finished tasks on the terminal (standard error;
it switches itself off when that is not a terminal, unless ``progress=True``).
"""

from __future__ import annotations

import contextlib

import logging
import os

from tqdm.auto import tqdm

from ..errors import ParameterError

__all__ = ["run_tasks", "dask_client", "local_cluster", "choose_workers", "MIN_CLUSTER_TASKS"]

#: Below this many tasks a local cluster does not pay: starting its worker
#: processes (~1.5 s, each importing numpy, scipy and colour) costs more than
#: it saves on 2 cores, so the sweep runs in this process.
MIN_CLUSTER_TASKS = 50


def choose_workers(n_tasks, requested=None, *, cpus=None):
    """Workers of the local cluster for ``n_tasks`` tasks, or None to run them in this process.

    ``requested``: None (choose: in this process below :data:`MIN_CLUSTER_TASKS`
    tasks, else one worker per CPU), 0 (in this process), or N (a cluster of
    N workers, never more than there are tasks).
    """
    if requested is not None and (isinstance(requested, bool) or not isinstance(requested, int) or requested < 0):
        raise ParameterError("workers", f"must be a whole number >= 0, or None to choose; got {requested!r}")
    if requested == 0 or n_tasks == 0:
        return None
    if requested is None:
        if n_tasks < MIN_CLUSTER_TASKS:
            return None
        requested = cpus or os.cpu_count() or 1
    return max(1, min(int(requested), int(n_tasks)))


def local_cluster(workers, *, processes=True):
    """A :class:`distributed.LocalCluster` of ``workers`` single-thread workers, no dashboard.

    Scheduler and workers listen on 127.0.0.1 only (TCP, also when
    ``processes=False`` makes the workers threads of this process).
    """
    from distributed import LocalCluster

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ParameterError("workers", f"must be a whole number >= 1 (or None to run in this process), got {workers!r}")
    # Every socket on the loopback interface: TCP between scheduler and workers (also for thread
    # workers, whose default in-process transport would not take a host); no dashboard (it would
    # import bokeh); the scheduler's small HTTP server (health, metrics) on a free loopback port.
    return LocalCluster(
        n_workers=workers,
        threads_per_worker=1,
        processes=processes,
        host="127.0.0.1",
        protocol="tcp://",
        dashboard_address=None,
        worker_dashboard_address=None,
        scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
        silence_logs=logging.ERROR,
    )


def _bar(total, progress, desc):
    return tqdm(total=total, desc=desc, unit="task", disable=None if progress is None else not progress, leave=True)


def run_tasks(function, configurations, *, workers=None, scheduler=None, processes=True, progress=None, desc="tasks"):
    """``[function(c) for c in configurations]``, each call one task.

    Parameters
    ----------
    function : callable
        A module-level function (picklable) of one configuration.
    configurations : sequence
    workers : int or None
        Size of a local cluster; None (and no ``scheduler``) runs in this process.
    scheduler : str or None
        Address of an existing Dask scheduler (``workers`` is then ignored).
    processes : bool
        Local cluster of processes (default) or of threads in this process.
    progress : bool or None
        Show a progress bar; None = only when standard error is a terminal.
    """
    configurations = list(configurations)
    if scheduler is None and workers is None:
        results = []
        with _bar(len(configurations), progress, desc) as bar:
            for c in configurations:
                results.append(function(c))
                bar.update(1)
        return results

    from distributed import as_completed

    with dask_client(workers, scheduler, processes=processes) as client:
        # pure=False: identical configurations are still separate tasks (no key collisions across sweeps)
        futures = client.map(function, configurations, pure=False)
        with _bar(len(futures), progress, desc) as bar:
            for _ in as_completed(futures):
                bar.update(1)
        return client.gather(futures)


@contextlib.contextmanager
def dask_client(workers=None, scheduler=None, *, processes=True):
    """A Dask client: of a local cluster of ``workers`` (closed on exit), or of the scheduler at address
    ``scheduler`` (``workers`` then ignored); a ParameterError naming ``scheduler`` when it cannot be reached."""
    from distributed import Client

    cluster = None
    if scheduler is None:
        cluster = local_cluster(int(workers), processes=processes)
        client = Client(cluster)
    else:
        try:
            client = Client(str(scheduler), timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise ParameterError("scheduler", f"cannot reach a Dask scheduler at {scheduler!r}: {exc}") from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
