"""Executors: map the pure run function over design points, locally or on Dask.

A run is a pure function of (virtual test, profile, settings, seed): :func:`simulate`
calls the registered experiment and returns ``RunResult.to_dict()``. :func:`execute`
wraps it for the runner -- artifacts into a temporary folder (the runner moves it into
place in the transaction that records the run), the resolved configuration saved next
to them, errors caught as text -- and both executors just map :func:`execute`:

* :class:`LocalExecutor`: worker processes (spawn or forkserver) of its own, one per
  core by default, each running one task at a time; workers die with the runner and
  leave Ctrl-C, SIGTERM and SIGHUP to it (it stops them, then hands its claims back). A
  worker that dies (killed, out of memory, a crash) costs only its own run: it is
  replaced and that run is tried once more, and a second death is the run's failure;
* :class:`EnsembleExecutor`: one worker process running up to ``ensemble`` runs at
  once as one GPU ensemble (``[executor] ensemble``, backend ``cuda``);
* :class:`DaskExecutor`: a ``dask.distributed`` client, connected to a scheduler
  address (``tcp://host:8786``) or to a ``LocalCluster`` it starts, every port of
  which listens on 127.0.0.1 only. Remote workers must see the campaign's work folder
  at the same path (a shared file system).

The run function and its wrapper are in :mod:`demcal.campaign.task`, the local pool
in :mod:`demcal.campaign.pool`, the Dask executor and its scheduler checks in
:mod:`demcal.campaign.cluster`; every public name of theirs is importable from here.
"""

from __future__ import annotations

from typing import Sequence

# Re-exported; each is read where it lives (a test that changes CONNECT_TIMEOUT_S sets it in cluster).
from demcal.campaign.cluster import CONNECT_TIMEOUT_S, DASK_SCHEMES, LOOPBACK, DaskExecutor  # noqa: F401
from demcal.campaign.cluster import check_scheduler_address, probe_scheduler, scheduler_address_problem  # noqa: F401
from demcal.campaign.pool import EnsembleExecutor, LocalExecutor, cpu_count  # noqa: F401
from demcal.campaign.task import engine_version, execute, import_plugins, simulate  # noqa: F401


def make_executor(kind: str = "local", workers: int = 0, scheduler: str | None = None,
                  start_method: str = "spawn", plugins: Sequence[str] = (), ensemble: int = 0):
    """The executor a campaign's ``[executor]`` table (or the command line) asks for;
    ``ensemble`` > 0 (backend cuda): :class:`EnsembleExecutor` of that many runs."""
    if ensemble:
        return EnsembleExecutor(ensemble, start_method, plugins)
    if scheduler or kind == "dask":
        return DaskExecutor(scheduler, workers, plugins)
    return LocalExecutor(workers, start_method, plugins)
