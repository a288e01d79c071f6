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
* :class:`DaskExecutor`: a ``dask.distributed`` client, connected to a scheduler
  address (``tcp://host:8786``) or to a ``LocalCluster`` it starts, every port of
  which listens on 127.0.0.1 only. Remote workers must see the campaign's work folder
  at the same path (a shared file system).
"""

from __future__ import annotations

import collections
import contextlib
import errno
import importlib
import multiprocessing
import multiprocessing.connection
import os
import shutil
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
             out_dir: str | Path | None = None, plugins: Sequence[str] = (),
             backend: str = "cpu") -> dict[str, Any]:
    """Run one virtual experiment on compute ``backend``; a pure function of its
    arguments.

    Returns ``RunResult.to_dict()``: responses, spread, particle and step counts,
    simulated and wall time, artifact paths.
    """
    from demcal.bench.common import on_backend
    from demcal.bench.registry import get_experiment

    import_plugins(plugins)
    experiment = get_experiment(test)
    with on_backend(backend):
        result = experiment.run(settings=dict(settings), seed=int(seed), profile=profile,
                                out_dir=out_dir)
    return result.to_dict()


def execute(task: Mapping[str, Any]) -> dict[str, Any]:
    """Run one task of the runner; never raises for a failed simulation.

    ``task`` holds ``test, profile, settings, seed, plugins, runs_dir, name`` and
    optionally ``tmp`` (the temporary folder's name, chosen by the runner so that it
    can clean up after a worker it had to stop), ``threads`` (numba threads for
    this run) and ``backend`` (``cpu`` or ``cuda``, recorded in ``run.json``). The
    artifacts of the run (and ``run.json`` with the resolved
    configuration, ``result.json`` or ``error.txt``) are left in ``runs_dir/tmp``;
    the runner moves that folder to ``runs_dir/name`` when it records the run.

    Returns ``{"ok": True, "result": {...}, "artifacts_dir": name, "tmp_dir": tmp, ...}``
    or ``{"ok": False, "error": "one sentence", "traceback": "...", ...}``; a fault of
    the machine rather than of the run (a full disk, a read-only folder) adds
    ``"fatal": "one sentence"`` and leaves no folder behind.
    """
    from demcal.bench.registry import get_experiment, resolve_settings
    from demcal.campaign.store import finite_responses, store_error, temp_name, write_json_atomic

    start = time.perf_counter()
    runs_dir = Path(task["runs_dir"])
    name = task["name"]
    tmp_name = task.get("tmp") or temp_name(name)
    tmp = runs_dir / tmp_name
    outcome: dict[str, Any] = {"artifacts_dir": name, "tmp_dir": tmp_name, "host": socket.gethostname(),
                               "pid": os.getpid()}
    try:
        try:
            if tmp.exists():  # left by this claim's earlier attempt, on a worker that died
                shutil.rmtree(tmp)
            tmp.mkdir(parents=True)
            import_plugins(task.get("plugins", ()))
            experiment = get_experiment(task["test"])
            _limit_threads(task.get("threads"))
            resolved = resolve_settings(experiment, task["settings"], task["profile"])
            write_json_atomic(tmp / "run.json", {
                "test": task["test"], "profile": task["profile"], "seed": task["seed"],
                "overrides": dict(task["settings"]), "settings": resolved, "label": task.get("label", ""),
                "backend": task.get("backend", "cpu"),
            })
            result = simulate(task["test"], task["profile"], task["settings"], task["seed"], tmp,
                              backend=task.get("backend", "cpu"))
            bad = finite_responses(result.get("responses", {}))
            if bad is not None:
                raise _RunFailed(f"response '{bad}' is not a finite number ({result['responses'].get(bad)!r})")
            result["artifacts"] = {key: _relative(value, tmp) for key, value in result.get("artifacts", {}).items()}
            write_json_atomic(tmp / "result.json", result)
            outcome.update(ok=True, result=result)
        except Exception as exc:  # a failed run is data, not a crash of the runner
            if _machine_fault(exc, runs_dir) is not None:
                raise
            message = str(exc) if isinstance(exc, (DemcalError, _RunFailed)) else f"{type(exc).__name__}: {exc}"
            outcome.update(ok=False, error=message.strip() or type(exc).__name__,
                           traceback=traceback.format_exc())
            (tmp / "error.txt").write_text(outcome["traceback"])
    except Exception as exc:
        fault = _machine_fault(exc, runs_dir)
        if fault is None:
            raise
        shutil.rmtree(tmp, ignore_errors=True)  # no folder of 0-byte files
        where = Path(os.fsdecode(fault.filename)) if fault.filename is not None else runs_dir
        if _inside(where, runs_dir):
            sentence = str(store_error(fault, runs_dir, "the run folders"))
        else:  # the experiment's own scratch file elsewhere
            sentence = str(store_error(fault, where, "the file"))
        outcome.update(ok=False, fatal=sentence, error=sentence, traceback=traceback.format_exc())
    outcome["engine_version"] = engine_version()
    outcome["wall_s"] = time.perf_counter() - start
    return outcome


#: File-system errors that are the machine's fault, not the run's: the campaign stops.
_MACHINE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EROFS)


def _machine_fault(exc: BaseException, runs_dir: Path) -> OSError | None:
    """The full disk or read-only folder behind ``exc`` (or its causes), if any.

    No permission counts too when it concerns the run folders themselves.
    """
    seen = exc
    for _ in range(10):
        if seen is None:
            break
        if isinstance(seen, OSError):
            if seen.errno in _MACHINE_ERRNOS:
                return seen
            if (seen.errno in (errno.EACCES, errno.EPERM) and seen.filename is not None
                    and _inside(Path(os.fsdecode(seen.filename)), runs_dir)):
                return seen
        seen = seen.__cause__ or seen.__context__
    return None


def _inside(path: Path, folder: Path) -> bool:
    try:
        path.resolve().relative_to(folder.resolve())
    except (ValueError, OSError):
        return False
    return True


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
        # the engine picks numba's threading layer first (OpenMP before TBB): setting
        # the thread count starts the layer
        from demcal.dem.backend import CpuBackend

        CpuBackend.prepare()
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))


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


def _local_worker(conn, parent_pid: int, threads: int, plugins: Sequence[str]) -> None:
    """A worker process of :class:`LocalExecutor`: receive a task, send its outcome, repeat."""
    try:
        _init_local_worker(parent_pid, threads, plugins)
        broken = None
    except Exception as exc:  # a plug-in that does not import: every task says so
        broken = f"the worker process could not start ({type(exc).__name__}: {exc})"
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):  # the runner is gone
            return
        if task is None:
            return
        if broken:
            outcome = {"ok": False, "error": broken}
        else:
            try:
                outcome = execute(task)
            except BaseException as exc:  # noqa: BLE001 - execute() catches run errors; this is the rest
                outcome = {"ok": False, "error": f"{type(exc).__name__}: {exc}", "traceback": traceback.format_exc()}
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

    def __init__(self, context, initargs: tuple):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_local_worker, args=(child, *initargs), daemon=True,
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


def _died(deaths: Sequence[str]) -> str:
    times = {1: "", 2: " twice"}.get(len(deaths), f" {len(deaths)} times")
    return (f"the worker process running it died{times} ({deaths[-1]}); "
            f"rerun with --retry-failed, with fewer --workers if memory is short")


#: Seconds a connection to a Dask scheduler may take, handshake included.
CONNECT_TIMEOUT_S = 20.0

#: Address schemes of ``distributed.comm`` (``tcp://host:8786`` is the usual one).
DASK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")


def scheduler_address_problem(address: str) -> str | None:
    """What is wrong with a Dask scheduler address, in words; None if it is well formed.

    Checked before anything runs: a known scheme (none means ``tcp``), a host and a
    port from 1 to 65535 (``inproc://`` addresses have no port).
    """
    example = "give one like tcp://HOST:8786"
    text = str(address).strip()
    if not text:
        return f"it is empty; {example}"
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    scheme = scheme.lower()
    if scheme not in DASK_SCHEMES:
        hint = " (http:// is the dashboard's address, not the scheduler's)" if scheme in ("http", "https") else ""
        return (f"'{scheme}' is not a Dask address scheme{hint}; use "
                f"{', '.join(DASK_SCHEMES[:-1])} or {DASK_SCHEMES[-1]}, like tcp://HOST:8786")
    if scheme == "inproc":
        return None if rest.strip("/") else f"it names no process; {example}"
    if rest.startswith("["):  # an IPv6 literal: [::1]:8786
        host, bracket, port = rest[1:].partition("]")
        if not bracket:
            return f"the IPv6 host has no closing ']'; {example}"
        if port and not port.startswith(":"):
            return f"'{port}' after the host is not ':PORT'; {example}"
        port = port[1:] if port else None
    else:
        host, colon, port = rest.rpartition(":")
        if not colon:
            host, port = rest, None
    if not host:
        return f"it has no host; {example}"
    if port is None or port == "":
        return f"it has no port; {example}"
    if not (port.isascii() and port.isdigit()):
        return f"the port '{port}' is not a whole number; {example}"
    if not 1 <= int(port) <= 65535:
        return f"the port {int(port)} is not in 1 to 65535; {example}"
    return None


def check_scheduler_address(address: str, where: str = "--scheduler") -> None:
    """Raise :class:`ConfigError` for a malformed scheduler address."""
    problem = scheduler_address_problem(address)
    if problem:
        raise ConfigError(f"{where} {address} is not a Dask scheduler address: {problem}.")


def _unreachable(address: str, reason: str) -> ConfigError:
    return ConfigError(f"cannot reach the Dask scheduler at {address} ({reason}); "
                       f"start it with `dask scheduler` or check the address.")


def _reason(exc: BaseException) -> str:
    """The root cause of a failed connection, in a few words."""
    seen = exc
    while seen is not None:
        if isinstance(seen, ConnectionRefusedError):
            return "connection refused: nothing listens on that port"
        if isinstance(seen, socket.gaierror):
            return "unknown host"
        seen = seen.__cause__ or seen.__context__
    text = str(exc).strip().rstrip(".")
    return text or type(exc).__name__


def probe_scheduler(address: str, timeout: float | None = None) -> None:
    """Make sure a Dask scheduler answers at ``address`` within ``timeout`` seconds.

    ``distributed.Client`` bounds the TCP connection but not the handshake after it,
    so a server that accepts and says nothing (an HTTP server, a firewall's proxy)
    hung it forever, and one that answers like HTTP had its reply's first bytes read
    as a frame length ("Unable to allocate 3.07 EiB"). Here the whole exchange --
    connection, handshake, the scheduler's identity -- runs on a private event loop
    under a hard deadline, and every failure becomes one :class:`ConfigError` sentence.
    """
    import asyncio
    import threading

    timeout = CONNECT_TIMEOUT_S if timeout is None else float(timeout)
    check_scheduler_address(address)
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    if scheme.lower() == "tls":
        from distributed.security import Security

        if Security().get_connection_args("client").get("ssl_context") is None:
            raise ConfigError(f"{address} is a TLS address but Dask has no TLS certificates configured "
                              f"(distributed.comm.tls in the Dask configuration); configure them or use tcp://.")
    if scheme.lower() in ("tcp", "tls", "ws", "wss"):
        host, _, port = rest.rpartition(":")
        try:  # a refused port or an unknown host is told at once, not after the timeout
            socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
        except socket.timeout:
            raise ConfigError(f"no Dask scheduler answered at {address} within {timeout:g} s; "
                              f"check that `dask scheduler` runs there and that the address is right.") from None
        except OSError as exc:
            raise _unreachable(address, _reason(exc)) from None

    async def identify() -> dict:
        from distributed.comm import connect
        from distributed.security import Security

        comm = await connect(address, timeout=timeout, **Security().get_connection_args("client"))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    outcome: dict[str, Any] = {}

    def attempt() -> None:
        try:
            outcome["identity"] = asyncio.run(asyncio.wait_for(identify(), timeout))
        except BaseException as exc:  # noqa: BLE001 - reported below, whatever it is
            outcome["error"] = exc

    thread = threading.Thread(target=attempt, name="demcal-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout + 5.0)
    error = outcome.get("error")
    if thread.is_alive() or isinstance(error, (asyncio.TimeoutError, TimeoutError)) or (
            isinstance(error, OSError) and "Timed out" in str(error)):
        raise ConfigError(f"no Dask scheduler answered at {address} within {timeout:g} s; "
                          f"check that `dask scheduler` runs there and that the address is right.")
    from distributed.comm.core import CommClosedError

    if isinstance(error, CommClosedError):
        raise _unreachable(address, "the server there closed the connection without a Dask handshake") from None
    if isinstance(error, (MemoryError, ValueError, TypeError, KeyError)) and not isinstance(error, OSError):
        if scheme.lower() in ("tcp", "tls", "ws", "wss"):  # the socket connected above
            # Garbage read as a message: a frame length of exabytes, a broken msgpack.
            raise _unreachable(address, "the server there does not speak Dask's protocol") from None
        raise _unreachable(address, f"{type(error).__name__}: {_reason(error)}") from None
    if error is not None:
        raise _unreachable(address, _reason(error)) from None
    identity = outcome.get("identity")
    kind = identity.get("type") if isinstance(identity, dict) else None
    if kind != "Scheduler":
        what = f"a Dask {kind}, not the scheduler" if kind else "not a Dask scheduler"
        raise _unreachable(address, f"the server there is {what}")


#: The only interface a local Dask cluster listens on.
LOOPBACK = "127.0.0.1"


class DaskExecutor:
    """A ``dask.distributed`` cluster: a scheduler address, or a ``LocalCluster``.

    Parameters
    ----------
    address : ``tcp://host:port`` of a running scheduler; None starts a ``LocalCluster``
        of ``workers`` single-threaded worker processes (used by tests and laptops).
        With an address, ``workers`` is ignored: the cluster's worker threads count.
    """

    kind = "dask"

    def __init__(self, address: str | None = None, workers: int = 0, plugins: Sequence[str] = ()):
        try:
            from distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover - a dependency
            raise ConfigError("the dask executor needs the 'distributed' package; pip install distributed.") from None
        self.plugins = tuple(plugins)
        self._cluster = None
        self._futures: set = set()  #: submitted, not yet handed back by :meth:`wait`
        if address:
            probe_scheduler(address)
            try:
                self._client = Client(address, timeout=f"{CONNECT_TIMEOUT_S:g}s")
                info = self._client.scheduler_info()
            except Exception as exc:  # noqa: BLE001 - the scheduler went away since the probe
                raise _unreachable(address, _reason(exc)) from None
            self.workers = max(1, sum(w.get("nthreads", 1) for w in info.get("workers", {}).values()))
            self.address = address
        else:
            self.workers = workers or cpu_count()
            # Every port on the loopback interface: the scheduler, the workers, their
            # nannies and the HTTP servers (/health, /info), which ":0" opened on all
            # interfaces. No dashboard; its HTTP server on a free port (the default 8787
            # warned "Port 8787 is already in use" whenever another Dask ran here). A
            # task whose worker died is retried once, as in the local pool.
            self._cluster = LocalCluster(
                n_workers=self.workers, threads_per_worker=1, processes=True, host=LOOPBACK,
                dashboard_address=f"{LOOPBACK}:0", worker_dashboard_address=f"{LOOPBACK}:0",
                scheduler_kwargs={"dashboard": False, "allowed_failures": LocalExecutor.RETRIES})
            self._client = Client(self._cluster)
            self.address = self._cluster.scheduler_address
        self.threads = 1

    @property
    def description(self) -> str:
        return f"Dask cluster at {self.address} ({self.workers} worker threads)"

    def submit(self, task: Mapping[str, Any]):
        future = self._client.submit(execute, dict(task, threads=self.threads), pure=False,
                                     key=f"demcal-{task['name']}-{os.urandom(4).hex()}")
        self._futures.add(future)
        return future

    def wait(self, handles: Sequence[Any], timeout: float) -> list[tuple[Any, dict[str, Any]]]:
        from distributed import wait

        try:
            done, _ = wait(list(handles), timeout=timeout, return_when="FIRST_COMPLETED")
        except TimeoutError:
            return []
        finished = []
        for future in done:
            self._futures.discard(future)
            try:
                finished.append((future, future.result()))
            except Exception as exc:  # a worker lost with the task, a cancelled future
                finished.append((future, {"ok": False, "error": f"Dask could not run it ({type(exc).__name__}: {exc})"}))
        return finished

    def close(self, cancel: bool = False) -> None:
        """Disconnect, and stop the ``LocalCluster`` if this executor started one.

        ``cancel`` (the runner stops: Ctrl-C, SIGTERM, an error): on a cluster of its
        own, closing it stops its workers; on a remote one, every task not yet finished
        is cancelled first, so that no queued run starts after the runner handed its
        claims back. A task already running on a remote worker cannot be stopped from
        here: it finishes unrecorded, and the temporary folder it may leave is removed
        by the next runner on the campaign.
        """
        try:
            if cancel and self._futures and self._cluster is None:
                with contextlib.suppress(Exception):  # a scheduler already gone cancels nothing
                    self._client.cancel(list(self._futures), force=True)
            self._futures.clear()
        finally:
            self._client.close()
            if self._cluster is not None:
                self._cluster.close()


def make_executor(kind: str = "local", workers: int = 0, scheduler: str | None = None,
                  start_method: str = "spawn", plugins: Sequence[str] = ()):
    """The executor a campaign's ``[executor]`` table (or the command line) asks for."""
    if scheduler or kind == "dask":
        return DaskExecutor(scheduler, workers, plugins)
    return LocalExecutor(workers, start_method, plugins)
