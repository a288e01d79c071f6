"""Executors: map the pure run function over design points, locally or on Dask.

A run is a pure function of (virtual test, profile, settings, seed): :func:`simulate`
calls the registered experiment and returns ``RunResult.to_dict()``. :func:`execute`
wraps it for the runner -- artifacts into a temporary folder renamed into place,
the resolved configuration saved next to them, errors caught as text -- and both
executors just map :func:`execute`:

* :class:`LocalExecutor`: a ``concurrent.futures.ProcessPoolExecutor`` (spawn or
  forkserver) with one worker per core by default; workers die with the runner;
* :class:`DaskExecutor`: a ``dask.distributed`` client, connected to a scheduler
  address (``tcp://host:8786``) or to a ``LocalCluster`` it starts. Remote workers
  must see the campaign's work folder at the same path (a shared file system).
"""

from __future__ import annotations

import concurrent.futures
import importlib
import multiprocessing
import os
import signal
import socket
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Mapping, Sequence

from demcal.errors import ConfigError, DemcalError


def cpu_count() -> int:
    """Cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def engine_version() -> str:
    """What produced a result: demcal's version and the numba it compiled with."""
    from demcal import __version__

    parts = [f"demcal {__version__}"]
    numba = sys.modules.get("numba")
    if numba is not None:
        parts.append(f"numba {numba.__version__}")
    return ", ".join(parts)


def import_plugins(plugins: Sequence[str]) -> None:
    """Import modules that register extra virtual experiments."""
    for module in plugins:
        importlib.import_module(module)


def simulate(test: str, profile: str, settings: Mapping[str, Any], seed: int,
             out_dir: str | Path | None = None, plugins: Sequence[str] = ()) -> dict[str, Any]:
    """Run one virtual experiment; a pure function of its arguments.

    Returns ``RunResult.to_dict()``: responses, spread, particle and step counts,
    simulated and wall time, artifact paths.
    """
    from demcal.bench.registry import get_experiment

    import_plugins(plugins)
    experiment = get_experiment(test)
    result = experiment.run(settings=dict(settings), seed=int(seed), profile=profile, out_dir=out_dir)
    return result.to_dict()


def execute(task: Mapping[str, Any]) -> dict[str, Any]:
    """Run one task of the runner; never raises for a failed simulation.

    ``task`` holds ``test, profile, settings, seed, plugins, runs_dir, name`` and
    optionally ``threads`` (numba threads for this run). The artifacts of the run
    (and ``run.json`` with the resolved configuration, ``result.json`` or
    ``error.txt``) end up in ``runs_dir/name``, moved there in one rename.

    Returns ``{"ok": True, "result": {...}, "artifacts_dir": name, "engine_version": ...}``
    or ``{"ok": False, "error": "one sentence", "traceback": "...", ...}``.
    """
    from demcal.bench.registry import get_experiment, resolve_settings
    from demcal.campaign.store import finite_responses, publish_dir, temp_dir, write_json_atomic

    start = time.perf_counter()
    runs_dir = Path(task["runs_dir"])
    name = task["name"]
    tmp = temp_dir(runs_dir, name)
    outcome: dict[str, Any] = {"artifacts_dir": name, "host": socket.gethostname(), "pid": os.getpid()}
    try:
        import_plugins(task.get("plugins", ()))
        experiment = get_experiment(task["test"])
        _limit_threads(task.get("threads"))
        resolved = resolve_settings(experiment, task["settings"], task["profile"])
        write_json_atomic(tmp / "run.json", {
            "test": task["test"], "profile": task["profile"], "seed": task["seed"],
            "overrides": dict(task["settings"]), "settings": resolved, "label": task.get("label", ""),
        })
        result = simulate(task["test"], task["profile"], task["settings"], task["seed"], tmp)
        bad = finite_responses(result.get("responses", {}))
        if bad is not None:
            raise _RunFailed(f"response '{bad}' is not a finite number ({result['responses'].get(bad)!r})")
        result["artifacts"] = {key: _relative(value, tmp) for key, value in result.get("artifacts", {}).items()}
        write_json_atomic(tmp / "result.json", result)
        outcome.update(ok=True, result=result)
    except Exception as exc:  # a failed run is data, not a crash of the runner
        message = str(exc) if isinstance(exc, (DemcalError, _RunFailed)) else f"{type(exc).__name__}: {exc}"
        outcome.update(ok=False, error=message.strip() or type(exc).__name__,
                       traceback=traceback.format_exc())
        (tmp / "error.txt").write_text(outcome["traceback"])
    outcome["engine_version"] = engine_version()
    outcome["wall_s"] = time.perf_counter() - start
    publish_dir(tmp, runs_dir / name)
    return outcome


class _RunFailed(Exception):
    pass


def _relative(path: str, folder: Path) -> str:
    """An artifact path relative to its run folder (the folder is renamed)."""
    try:
        return str(Path(path).resolve().relative_to(folder.resolve()))
    except ValueError:
        return str(path)


def _limit_threads(threads: int | None) -> None:
    if not threads:
        return
    numba = sys.modules.get("numba")
    if numba is not None:
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))


def _init_local_worker(parent_pid: int, threads: int, plugins: Sequence[str]) -> None:
    """Pool worker start-up: die with the runner, leave Ctrl-C to it, cap threads."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:  # pragma: no cover
            pass
        if os.getppid() != parent_pid:  # the runner died before prctl
            os._exit(1)
    os.environ.setdefault("NUMBA_NUM_THREADS", str(threads))
    os.environ.setdefault("OMP_NUM_THREADS", str(threads))
    import_plugins(plugins)


class LocalExecutor:
    """A process pool on this machine.

    Parameters
    ----------
    workers : processes; 0 means one per core.
    start_method : ``"spawn"`` or ``"forkserver"`` (never fork: numba and threads).
    plugins : modules each worker imports to register extra experiments.
    """

    kind = "local"

    def __init__(self, workers: int = 0, start_method: str = "spawn", plugins: Sequence[str] = ()):
        self.workers = workers or cpu_count()
        self.threads = max(1, cpu_count() // self.workers)
        self.start_method = start_method
        self.plugins = tuple(plugins)
        self._pool = self._new_pool()

    @property
    def description(self) -> str:
        return f"{self.workers} local worker process{'es' if self.workers != 1 else ''}"

    def _new_pool(self) -> concurrent.futures.ProcessPoolExecutor:
        return concurrent.futures.ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=multiprocessing.get_context(self.start_method),
            initializer=_init_local_worker,
            initargs=(os.getpid(), self.threads, self.plugins),
        )

    def submit(self, task: Mapping[str, Any]) -> concurrent.futures.Future:
        return self._pool.submit(execute, dict(task, threads=self.threads))

    def wait(self, handles: Sequence[Any], timeout: float) -> list[tuple[Any, dict[str, Any]]]:
        """Wait up to ``timeout`` seconds; return ``(handle, outcome)`` for each finished one."""
        done, _ = concurrent.futures.wait(handles, timeout=timeout,
                                          return_when=concurrent.futures.FIRST_COMPLETED)
        finished = []
        broken = False
        for future in done:
            try:
                finished.append((future, future.result()))
            except concurrent.futures.process.BrokenProcessPool:
                broken = True
                finished.append((future, _died()))
            except Exception as exc:  # pragma: no cover - execute() catches run errors
                finished.append((future, {"ok": False, "error": f"{type(exc).__name__}: {exc}"}))
        if broken:  # a worker was killed (out of memory, segfault): start a fresh pool
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = self._new_pool()
        return finished

    def close(self, cancel: bool = False) -> None:
        if cancel:
            for process in list(getattr(self._pool, "_processes", {}).values()):
                process.terminate()
        self._pool.shutdown(wait=not cancel, cancel_futures=cancel)


def _died() -> dict[str, Any]:
    return {"ok": False, "error": "the worker process running it died (crash or out of memory); "
                                  "rerun with --retry-failed"}


class DaskExecutor:
    """A ``dask.distributed`` cluster: a scheduler address, or a ``LocalCluster``.

    Parameters
    ----------
    address : ``tcp://host:port`` of a running scheduler; None starts a ``LocalCluster``
        of ``workers`` single-threaded worker processes (used by tests and laptops).
    """

    kind = "dask"

    def __init__(self, address: str | None = None, workers: int = 0, plugins: Sequence[str] = ()):
        try:
            from distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover - a dependency
            raise ConfigError("the dask executor needs the 'distributed' package; pip install distributed.") from None
        self.plugins = tuple(plugins)
        self._cluster = None
        if address:
            try:
                self._client = Client(address, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise ConfigError(f"cannot reach the Dask scheduler at {address} ({exc}); "
                                  f"start it with `dask scheduler` or check the address.") from None
            info = self._client.scheduler_info()
            self.workers = max(1, sum(w.get("nthreads", 1) for w in info.get("workers", {}).values()))
            self.address = address
        else:
            self.workers = workers or cpu_count()
            self._cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1, processes=True,
                                         dashboard_address=None)
            self._client = Client(self._cluster)
            self.address = self._cluster.scheduler_address
        self.threads = 1

    @property
    def description(self) -> str:
        return f"Dask cluster at {self.address} ({self.workers} worker threads)"

    def submit(self, task: Mapping[str, Any]):
        return self._client.submit(execute, dict(task, threads=self.threads), pure=False,
                                   key=f"demcal-{task['name']}-{os.urandom(4).hex()}")

    def wait(self, handles: Sequence[Any], timeout: float) -> list[tuple[Any, dict[str, Any]]]:
        from distributed import wait

        try:
            done, _ = wait(list(handles), timeout=timeout, return_when="FIRST_COMPLETED")
        except TimeoutError:
            return []
        finished = []
        for future in done:
            try:
                finished.append((future, future.result()))
            except Exception as exc:  # a worker lost with the task, a cancelled future
                finished.append((future, {"ok": False, "error": f"Dask could not run it ({type(exc).__name__}: {exc})"}))
        return finished

    def close(self, cancel: bool = False) -> None:
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_executor(kind: str = "local", workers: int = 0, scheduler: str | None = None,
                  start_method: str = "spawn", plugins: Sequence[str] = ()):
    """The executor a campaign's ``[executor]`` table (or the command line) asks for."""
    if scheduler or kind == "dask":
        return DaskExecutor(scheduler, workers, plugins)
    return LocalExecutor(workers, start_method, plugins)
