"""The Dask executor: a ``dask.distributed`` client, and the scheduler address it needs.

:class:`DaskExecutor` connects to a scheduler address (``tcp://host:8786``), checked
first (:func:`scheduler_address_problem`) and probed under a hard deadline
(:func:`probe_scheduler`), or to a ``LocalCluster`` it starts, every port of which
listens on 127.0.0.1 only. Remote workers must see the campaign's work folder at the
same path (a shared file system).
"""

from __future__ import annotations

import contextlib
import os
import socket
from typing import Any, Mapping, Sequence

from demcal.campaign.pool import LocalExecutor, cpu_count
from demcal.campaign.task import execute
from demcal.errors import ConfigError


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
