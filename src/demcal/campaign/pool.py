"""The local executor: worker processes of its own, one task at a time each.

:class:`LocalExecutor` starts worker processes (spawn or forkserver), one per core by
default, each running :func:`~demcal.campaign.task.execute` on one task at a time;
workers die with the runner and leave Ctrl-C, SIGTERM and SIGHUP to it (it stops them,
then hands its claims back). A worker that dies (killed, out of memory, a crash) costs
only its own run: it is replaced and that run is tried once more, and a second death
is the run's failure.

:class:`EnsembleExecutor` (``[executor] ensemble = N`` with backend ``cuda``) is one
worker process that runs up to N tasks at once as one GPU ensemble
(:mod:`demcal.dem.cuda.ensemble`): each task it receives joins the ensemble at once, and
each outcome comes back as its run ends, so the runner records runs one by one and a
kill loses only the runs in flight (tried once more, as a dead local worker's).
"""

from __future__ import annotations

import collections
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading
import time
import traceback
from typing import Any, Mapping, Sequence

from demcal.campaign.task import execute, import_plugins


def cpu_count() -> int:
    """Cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _init_local_worker(parent_pid: int, threads: int, plugins: Sequence[str]) -> None:
    """Pool worker start-up: die with the runner, leave Ctrl-C, SIGTERM and SIGHUP to it,
    cap threads.

    A terminal sends Ctrl-C and SIGHUP, and Slurm and systemd send SIGTERM, to every
    process of the job: a worker that died of it would count as a crash of its run
    (retried, then failed). The runner stops its workers itself when it stops, and a
    worker whose runner is gone dies with it (``PR_SET_PDEATHSIG``).
    """
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_IGN)
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


def _messages(conn):
    """What the runner sends a worker, until it says stop (None) or is gone."""
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):  # the runner is gone
            return
        if message is None:
            return
        yield message


def _local_worker(conn, parent_pid: int, threads: int, plugins: Sequence[str]) -> None:
    """A worker process of :class:`LocalExecutor`: receive a task, send its outcome, repeat."""
    try:
        _init_local_worker(parent_pid, threads, plugins)
        broken = None
    except Exception as exc:  # a plug-in that does not import: every task says so
        broken = f"the worker process could not start ({type(exc).__name__}: {exc})"
    for task in _messages(conn):
        if broken:
            outcome = {"ok": False, "error": broken}
        else:
            outcome = _safe_execute(task)
        conn.send(outcome)


class _Task:
    """The handle of one submitted task (the runner's key for it)."""

    __slots__ = ("task", "deaths", "outcome")

    def __init__(self, task: dict[str, Any]):
        self.task = task
        self.deaths: list[str] = []  #: how each worker that ran it died
        self.outcome: dict[str, Any] | None = None


class _Worker:
    """One worker process and the pipe to it."""

    def __init__(self, context, initargs: tuple, target=_local_worker):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=target, args=(child, *initargs), daemon=True,
                                       name="demcal-worker")
        self.process.start()
        child.close()
        self.task: _Task | None = None

    def stop(self, kill: bool) -> None:
        if kill and self.process.is_alive():
            self.process.kill()
        else:
            try:
                self.conn.send(None)
            except (OSError, ValueError):
                pass
        self.process.join(5.0)
        if self.process.is_alive():  # pragma: no cover - a worker stuck in C code
            self.process.kill()
            self.process.join(5.0)
        self.conn.close()


def _death(exitcode: int | None) -> str:
    """How a worker process ended, in words."""
    if exitcode is None:
        return "it stopped answering"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        if -exitcode == signal.SIGKILL:
            return f"killed by {name}: out of memory, or killed by someone"
        return f"killed by {name}"
    return f"it exited with status {exitcode}"


class LocalExecutor:
    """Worker processes on this machine, one task at a time each.

    Unlike a ``concurrent.futures`` pool, which breaks as a whole when one worker
    dies (failing every run in flight), a dead worker here costs only its own run:
    the worker is replaced, the run is tried once more on the new one, and only a
    second death is recorded as the run's failure, with its cause.

    Parameters
    ----------
    workers : processes; 0 means one per core.
    start_method : ``"spawn"`` or ``"forkserver"`` (never fork: numba and threads).
    plugins : modules each worker imports to register extra experiments.
    """

    kind = "local"

    #: Times a run is started again after the worker running it died.
    RETRIES = 1

    def __init__(self, workers: int = 0, start_method: str = "spawn", plugins: Sequence[str] = ()):
        self.workers = workers or cpu_count()
        self.threads = max(1, cpu_count() // self.workers)
        self.start_method = start_method
        self.plugins = tuple(plugins)
        self._context = multiprocessing.get_context(start_method)
        self._pool: list[_Worker] = []
        self._queue: collections.deque[_Task] = collections.deque()

    @property
    def description(self) -> str:
        return f"{self.workers} local worker process{'es' if self.workers != 1 else ''}"

    def submit(self, task: Mapping[str, Any]) -> _Task:
        handle = _Task(dict(task, threads=self.threads))
        self._queue.append(handle)
        self._dispatch()
        return handle

    def _dispatch(self) -> None:
        """Hand queued tasks to idle workers, starting workers up to ``self.workers``."""
        for worker in [w for w in self._pool if w.task is None and not w.process.is_alive()]:
            self._pool.remove(worker)  # died idle, after sending its last outcome
            worker.stop(kill=True)
        while self._queue:
            worker = next((w for w in self._pool if w.task is None), None)
            if worker is None:
                if len(self._pool) >= self.workers:
                    return
                worker = _Worker(self._context, (os.getpid(), self.threads, self.plugins))
                self._pool.append(worker)
            handle = self._queue.popleft()
            worker.task = handle
            try:
                worker.conn.send(handle.task)
            except (OSError, ValueError):  # it died before it got the task
                self._lost(worker)

    def _lost(self, worker: _Worker) -> None:
        """``worker`` died: retry its run on a fresh worker, or fail the run after a second death."""
        worker.process.join(1.0)
        handle = worker.task
        worker.task = None
        self._pool.remove(worker)
        worker.stop(kill=True)
        if handle is None:
            return
        handle.deaths.append(_death(worker.process.exitcode))
        if len(handle.deaths) <= self.RETRIES:
            self._queue.appendleft(handle)
        else:
            handle.outcome = {"ok": False, "error": _died(handle.deaths)}

    def wait(self, handles: Sequence[Any], timeout: float) -> list[tuple[Any, dict[str, Any]]]:
        """Wait up to ``timeout`` seconds; return ``(handle, outcome)`` for each finished one."""
        deadline = time.monotonic() + timeout
        while True:
            finished = [(h, h.outcome) for h in handles if h.outcome is not None]
            busy = [w for w in self._pool if w.task is not None]
            left = deadline - time.monotonic()
            if finished or not busy or left <= 0:
                return finished
            ready = multiprocessing.connection.wait([w.conn for w in busy] + [w.process.sentinel for w in busy],
                                                    timeout=left)
            for worker in busy:
                if worker.conn in ready or worker.process.sentinel in ready:
                    self._collect(worker)
            self._dispatch()

    def _collect(self, worker: _Worker) -> None:
        """Take the outcome ``worker`` sent, or handle its death."""
        try:
            if worker.conn.poll():
                outcome = worker.conn.recv()
                worker.task.outcome, worker.task = outcome, None
                return
        except (EOFError, OSError):
            pass
        if not worker.process.is_alive() or worker.conn.closed:
            self._lost(worker)

    def close(self, cancel: bool = False) -> None:
        """Stop the workers: at once (``cancel``, their runs are lost) or once idle."""
        self._queue.clear()
        for worker in self._pool:
            worker.stop(kill=cancel or worker.task is not None)
        self._pool.clear()


def _safe_execute(task: dict[str, Any]) -> dict[str, Any]:
    try:
        return execute(task)
    except BaseException as exc:  # noqa: BLE001 - execute() catches run errors; this is the rest
        return {"ok": False, "error": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc()}


def _ensemble_worker(conn, parent_pid: int, plugins: Sequence[str]) -> None:
    """The worker process of :class:`EnsembleExecutor`: every ``(ident, task)`` received
    joins one ensemble at once; ``(ident, outcome)`` is sent as each run ends."""
    lock = threading.Lock()

    def send(message) -> None:
        with lock:
            try:
                conn.send(message)
            except (OSError, ValueError):  # the runner is gone
                pass

    try:
        _init_local_worker(parent_pid, 1, plugins)
        from demcal.dem.cuda.ensemble import Ensemble

        ensemble = Ensemble()
    except Exception as exc:  # no device, a plug-in that does not import: every task says so
        broken = f"the ensemble worker could not start ({type(exc).__name__}: {exc})"
        for ident, _ in _messages(conn):
            send((ident, {"ok": False, "error": broken}))
        return

    def receive() -> None:
        for ident, task in _messages(conn):
            ensemble.add(lambda task=task: _safe_execute(task),
                         lambda outcome, ident=ident: send((ident, outcome)))
        ensemble.close()

    threading.Thread(target=receive, daemon=True, name="demcal-ensemble-receive").start()
    ensemble.serve()


class EnsembleExecutor:
    """One worker process stepping up to ``size`` runs together on the GPU.

    The runner keeps ``size`` runs in flight (:attr:`workers`); each task submitted goes
    to the worker at once and joins its ensemble (:mod:`demcal.dem.cuda.ensemble`),
    whose rounds step every run whose simulation waits for steps. Outcomes come back
    one by one. A worker that dies costs the runs in flight: each is tried once more on
    a new worker, on its own (no other run beside it), and a second death is its
    failure, as with :class:`LocalExecutor`.

    Parameters
    ----------
    size : runs in one ensemble.
    start_method : ``"spawn"`` or ``"forkserver"``.
    plugins : modules the worker imports to register extra experiments.
    """

    kind = "ensemble"
    RETRIES = 1

    def __init__(self, size: int, start_method: str = "spawn", plugins: Sequence[str] = ()):
        self.workers = max(1, int(size))
        self.threads = 1
        self.plugins = tuple(plugins)
        self._context = multiprocessing.get_context(start_method)
        self._worker: _Worker | None = None
        self._running: dict[int, _Task] = {}
        self._queue: collections.deque[_Task] = collections.deque()
        self._ident = 0

    @property
    def description(self) -> str:
        return f"one GPU ensemble of up to {self.workers} run{'s' if self.workers != 1 else ''}"

    def submit(self, task: Mapping[str, Any]) -> _Task:
        handle = _Task(dict(task, threads=1))
        self._queue.append(handle)
        self._dispatch()
        return handle

    def _dispatch(self) -> None:
        """Send queued tasks to the worker (started if need be). A run whose worker died
        is tried again on its own, so that a second death is its own and not a run's
        that happened to share its ensemble."""
        if self._worker is not None and not self._worker.process.is_alive():
            self._lost()
        while self._queue:
            if self._running and (self._queue[0].deaths
                                  or any(h.deaths for h in self._running.values())):
                return
            if self._worker is None:
                self._worker = _Worker(self._context, (os.getpid(), self.plugins), target=_ensemble_worker)
            handle = self._queue.popleft()
            self._ident += 1
            self._running[self._ident] = handle
            try:
                self._worker.conn.send((self._ident, handle.task))
            except (OSError, ValueError):  # it died before it got the task
                self._lost()

    def _drain(self, worker: _Worker) -> None:
        """Take every outcome the worker has sent."""
        try:
            while worker.conn.poll():
                ident, outcome = worker.conn.recv()
                handle = self._running.pop(ident, None)
                if handle is not None:
                    handle.outcome = outcome
        except (EOFError, OSError):
            pass

    def _lost(self) -> None:
        """The worker died: the outcomes it sent before are kept; its other runs in flight
        are tried again, or fail after a second death."""
        worker, self._worker = self._worker, None
        self._drain(worker)
        worker.process.join(1.0)
        worker.stop(kill=True)
        death = _death(worker.process.exitcode)
        for handle in reversed(list(self._running.values())):
            handle.deaths.append(death)
            if len(handle.deaths) <= self.RETRIES:
                self._queue.appendleft(handle)   # first, each on its own (_dispatch)
            else:
                handle.outcome = {"ok": False, "error": _died(handle.deaths)}
        self._running.clear()

    def wait(self, handles: Sequence[Any], timeout: float) -> list[tuple[Any, dict[str, Any]]]:
        """Wait up to ``timeout`` seconds; return ``(handle, outcome)`` for each finished one."""
        deadline = time.monotonic() + timeout
        while True:
            finished = [(h, h.outcome) for h in handles if h.outcome is not None]
            left = deadline - time.monotonic()
            worker = self._worker
            if finished or worker is None or not self._running or left <= 0:
                return finished
            multiprocessing.connection.wait([worker.conn, worker.process.sentinel], timeout=left)
            self._drain(worker)
            if not worker.process.is_alive():
                self._lost()
            self._dispatch()

    def close(self, cancel: bool = False) -> None:
        """Stop the worker: at once (``cancel``, its runs are lost) or once idle."""
        self._queue.clear()
        if self._worker is not None:
            self._worker.stop(kill=cancel or bool(self._running))
            self._worker = None
        self._running.clear()


def _died(deaths: Sequence[str]) -> str:
    times = {1: "", 2: " twice"}.get(len(deaths), f" {len(deaths)} times")
    return (f"the worker process running it died{times} ({deaths[-1]}); "
            f"rerun with --retry-failed, with fewer --workers if memory is short")
