"""Dask scheduler addresses: a wrong one is one sentence (exit status 2) in bounded time.

Nothing here needs a Dask scheduler: the servers are local sockets that refuse,
answer like an HTTP server or accept and say nothing.
"""

from __future__ import annotations

import socket
import threading
import time
import warnings

import pytest

from demcal.campaign.config import load_campaign
from demcal.cli import main
from demcal.errors import ConfigError

pytest.importorskip("distributed")


def _one_sentence(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("demcal: error: "), err
    return err


@pytest.fixture
def fast_connect(monkeypatch):
    """Connection attempts give up after 1 s instead of 20 s."""
    monkeypatch.setattr("demcal.campaign.cluster.CONNECT_TIMEOUT_S", 1.0)


class _Server:
    """A local TCP server in a thread: ``reply`` (bytes) after the first read, or silence."""

    def __init__(self, reply: bytes | None):
        self.reply = reply
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.conns: list[socket.socket] = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def address(self) -> str:
        return f"tcp://127.0.0.1:{self.port}"

    def _serve(self) -> None:
        while not self.stop.is_set():
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            self.conns.append(conn)
            if self.reply is not None:
                conn.settimeout(2)
                try:
                    conn.recv(65536)
                    conn.sendall(self.reply)
                except OSError:
                    pass

    def close(self) -> None:
        self.stop.set()
        self.thread.join(2)
        for conn in self.conns:
            conn.close()
        self.sock.close()


@pytest.fixture
def server():
    servers = []

    def start(reply: bytes | None = None) -> _Server:
        servers.append(_Server(reply))
        return servers[-1]

    yield start
    for s in servers:
        s.close()


@pytest.mark.parametrize("address, words", [
    ("http://127.0.0.1:8799", "'http'"),
    ("tcp://127.0.0.1:notaport", "'notaport'"),
    ("tcp://127.0.0.1:0", "1 to 65535"),
    ("tcp://127.0.0.1:70000", "1 to 65535"),
    ("tcp://127.0.0.1", "no port"),
    ("tcp://:8786", "no host"),
])
def test_malformed_scheduler_address_is_one_sentence(campaign_file, capsys, address, words):
    path = campaign_file()
    start = time.monotonic()
    assert main(["run", str(path), "--quiet", "--scheduler", address]) == 2
    err = _one_sentence(capsys)
    assert f"--scheduler {address}" in err and words in err and "tcp://" in err, err
    assert time.monotonic() - start < 10
    assert not load_campaign(path).store_path.exists()  # refused before anything was set up


def test_malformed_scheduler_in_the_campaign_file_names_its_line(campaign_file, capsys):
    path = campaign_file(replace={"[executor]\nworkers = 2": '[executor]\nworkers = 2\nscheduler = "http://127.0.0.1:8799"'})
    with pytest.raises(ConfigError, match=r"line \d+.*scheduler.*'http'"):
        load_campaign(path)
    assert main(["run", str(path), "--quiet"]) == 2
    assert "'http'" in _one_sentence(capsys)


def test_well_formed_addresses_pass_the_check():
    from demcal.campaign.executors import scheduler_address_problem

    for address in ("tcp://127.0.0.1:8786", "tls://scheduler.lab:8786", "127.0.0.1:8786", "tcp://[::1]:8786",
                    "ucx://10.0.0.2:13337", "inproc://10.0.0.2/123/1"):
        assert scheduler_address_problem(address) is None, address


def test_nothing_listening_is_one_sentence(campaign_file, capsys, fast_connect):
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()  # nothing listens there now
    start = time.monotonic()
    assert main(["run", str(campaign_file()), "--quiet", "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    err = _one_sentence(capsys)
    assert f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}" in err and "check the address" in err
    assert time.monotonic() - start < 5


def test_a_server_that_answers_like_http_is_not_a_dask_scheduler(campaign_file, capsys, fast_connect, server):
    """Dask read the reply's first 8 bytes ("HTTP/1.1") as a frame length: 3.07 EiB."""
    http = server(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")
    start = time.monotonic()
    assert main(["run", str(campaign_file()), "--quiet", "--scheduler", http.address]) == 2
    err = _one_sentence(capsys)
    assert f"cannot reach the Dask scheduler at {http.address}" in err and "check the address" in err
    assert "EiB" not in err and "allocate" not in err
    assert time.monotonic() - start < 5


def test_a_server_that_says_nothing_is_given_up_on_in_time(campaign_file, capsys, fast_connect, server):
    silent = server(None)
    start = time.monotonic()
    assert main(["run", str(campaign_file()), "--quiet", "--scheduler", silent.address]) == 2
    err = _one_sentence(capsys)
    assert f"no Dask scheduler answered at {silent.address} within 1 s" in err, err
    assert time.monotonic() - start < 5


def test_local_dask_cluster_does_not_warn_about_the_dashboard_port(campaign_file):
    """Another Dask (here: a socket) on 8787 made LocalCluster warn 'Port 8787 is already in use'."""
    from demcal.campaign.executors import DaskExecutor

    blocker = socket.socket()
    try:
        blocker.bind(("0.0.0.0", 8787))
        blocker.listen(1)
    except OSError:
        pass  # already taken by someone else: just as good
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            executor = DaskExecutor(None, workers=1, plugins=load_campaign(campaign_file()).plugins)
            executor.close()
    finally:
        blocker.close()
    assert not [w for w in caught if "already in use" in str(w.message)], [str(w.message) for w in caught]


def test_a_real_scheduler_passes_the_probe_and_runs_the_campaign(campaign_file):
    """Guard: the probe (handshake + identity) accepts a genuine scheduler, not its workers."""
    from distributed import LocalCluster

    from demcal.campaign.executors import probe_scheduler
    from demcal.campaign.runner import run_campaign

    campaign = load_campaign(campaign_file())
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=":0",
                      scheduler_kwargs={"dashboard": False}) as cluster:
        probe_scheduler(cluster.scheduler_address, timeout=5)
        (worker,) = cluster.scheduler_info["workers"]
        with pytest.raises(ConfigError, match="a Dask Worker, not the scheduler"):
            probe_scheduler(worker, timeout=5)
        summary = run_campaign(campaign, scheduler=cluster.scheduler_address, workers=7, progress=False)
    assert (summary.done, summary.failed) == (29, 0)
    assert "(2 worker threads)" in summary.executor  # --workers is ignored on a cluster


def test_local_dask_cluster_listens_on_loopback_only(campaign_file):
    """Issue 20: with ``[executor] kind = "dask"`` an HTTP port on 0.0.0.0 answered
    /health, /info/main/workers.html and a logs page although the dashboard was off."""
    import ipaddress

    import psutil

    from demcal.campaign.executors import DaskExecutor

    executor = DaskExecutor(None, workers=2, plugins=load_campaign(campaign_file()).plugins)
    try:
        me = psutil.Process()
        listening = [(process.pid, conn.laddr) for process in [me, *me.children(recursive=True)]
                     for conn in process.net_connections(kind="inet") if conn.status == psutil.CONN_LISTEN]
    finally:
        executor.close()
    # scheduler, its HTTP server, and per worker: worker, its HTTP server, nanny
    assert len(listening) >= 7, listening
    outside = [(pid, addr) for pid, addr in listening
               if ipaddress.ip_address(addr.ip) not in ipaddress.ip_network("127.0.0.0/8")]
    assert not outside, outside
