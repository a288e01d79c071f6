"""SIGTERM and SIGHUP stop demcal as Ctrl-C does, and leave nothing behind (issue 37).

`demcal run` stopped by a signal -- with runs in flight, between a claim and its task,
with a second signal during the clean-up of the first, sent to its whole process group
as Slurm and systemd send it -- says one sentence and exits with 128 + the signal's
number, leaves no row ``running`` in the store and no ``.tmp-``/``.old-`` folder under
``runs/``, and a resume finishes the same runs with the same bits as a run never
stopped. On the ``test-heap`` double (``campaign_testbench.py``);
benchmarks/sigterm_kills.py sends SIGTERM at random moments to `demcal run` on the
example campaign at the tiny profile (benchmarks/studies/sigterm-2026-11-28).
"""

from __future__ import annotations

import concurrent.futures
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign
from demcal.campaign.runner import run_campaign
from demcal.campaign.store import Store, held_signals
from demcal.cli import NO_COMMAND, main

from conftest import InlineExecutor
from test_faults import settled

ROOT = Path(__file__).resolve().parents[2]
INTERRUPTED = "demcal: interrupted{how}; finished results are kept."


@pytest.fixture(autouse=True)
def _signals_as_in_a_terminal():
    """Each test starts with the handlers of a command typed in a terminal (Ctrl-C raises
    KeyboardInterrupt, SIGTERM and SIGHUP stop), whatever the suite was started under: a
    background job (`make test &`) ignores SIGINT, `nohup` ignores SIGHUP, and demcal
    rightly keeps an ignored signal ignored."""
    wanted = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL,
              signal.SIGHUP: signal.SIG_DFL}
    before = {number: signal.signal(number, handler) for number, handler in wanted.items()}
    yield
    for number, handler in before.items():
        signal.signal(number, handler)


def hidden(campaign) -> set[str]:
    """Temporary and old folders under ``runs/`` (none may stay)."""
    runs = campaign.workdir / "runs"
    return {p.name for p in runs.iterdir() if p.name.startswith(".")} if runs.is_dir() else set()


def counts(campaign) -> dict[str, int]:
    with Store(campaign.store_path, readonly=True) as store:
        return store.counts()


# ---------------------------------------------------------------- the command line
def test_no_command_is_exit_status_2_with_the_help_on_stderr(capsys):
    assert main([]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith("usage: demcal") and "run " in err
    assert err.strip().splitlines()[-1] == f"demcal: error: {NO_COMMAND}"


@pytest.mark.parametrize("signum, status, how", [(signal.SIGTERM, 143, " (SIGTERM)"),
                                                 (signal.SIGHUP, 129, " (SIGHUP)"),
                                                 (signal.SIGINT, 130, "")])
def test_a_stop_signal_is_one_sentence_and_128_plus_its_number(capsys, monkeypatch, signum, status, how):
    """Inside a command, each signal is an interrupt; the handlers are put back after."""
    seen = {}

    def command(args):
        seen["hup"] = signal.getsignal(signal.SIGHUP)
        signal.raise_signal(signum)
        seen["went on"] = True

    monkeypatch.setattr("demcal.cli.campaign._demo", command)
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    assert main(["demo"]) == status
    assert "went on" not in seen
    assert capsys.readouterr().err.strip() == INTERRUPTED.format(how=how)
    assert {s: signal.getsignal(s) for s in before} == before


def test_an_ignored_sighup_stays_ignored(capsys, monkeypatch):
    """`nohup demcal run ...`: a closed terminal does not stop the command."""
    monkeypatch.setattr("demcal.cli.campaign._demo", lambda args: signal.raise_signal(signal.SIGHUP))
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        assert main(["demo"]) == 0
        assert signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)


def test_held_signals_note_a_signal_and_deliver_it_once_at_the_end():
    seen = []
    previous = signal.signal(signal.SIGTERM, lambda number, frame: seen.append(number))
    try:
        with held_signals():
            signal.raise_signal(signal.SIGTERM)
            with held_signals():  # nested: held until the outer block ends
                signal.raise_signal(signal.SIGTERM)
            assert seen == []
        assert seen == [signal.SIGTERM]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        with pytest.raises(KeyboardInterrupt):  # Ctrl-C held, then raised after the block ran whole
            with held_signals():
                signal.raise_signal(signal.SIGINT)
                seen.append("ran whole")
        assert seen[-1] == "ran whole"
    finally:
        signal.signal(signal.SIGTERM, previous)


# ---------------------------------------------------------------- a signal in the runner's clean-up
class Parked:
    """An executor whose tasks start (each makes its temporary folder, as a worker does)
    and never end; the signals of the case come from inside it."""

    kind = "parked"
    description = "parked tasks (test double)"

    def __init__(self, moment: str):
        self.workers, self.threads = 2, 1
        self.moment, self.submitted, self.cancelled = moment, 0, None

    def submit(self, task):
        self.submitted += 1
        if self.moment == "between a claim and its task" and self.submitted == 2:
            signal.raise_signal(signal.SIGTERM)
        folder = Path(task["runs_dir"]) / task["tmp"]
        folder.mkdir()
        (folder / "run.json").write_text("{}\n")
        return concurrent.futures.Future()

    def wait(self, handles, timeout):
        signal.raise_signal(signal.SIGTERM)  # two runs in flight
        return []

    def close(self, cancel: bool = False) -> None:
        if cancel:
            self.cancelled = True
            signal.raise_signal(signal.SIGTERM)  # a second signal while the workers are stopped


@pytest.mark.parametrize("moment", ["runs in flight", "between a claim and its task"])
def test_signals_during_the_clean_up_leave_no_claim_and_no_folder(campaign_file, monkeypatch, capsys, moment):
    """A second SIGTERM while the runner stops its workers and a SIGHUP while it hands
    its claims back: both are held until the clean-up is done (a KeyboardInterrupt
    there used to leave the claims ``running`` and their folders in ``runs/``)."""
    campaign = load_campaign(campaign_file())
    executor = Parked(moment)
    monkeypatch.setattr("demcal.campaign.executors.make_executor", lambda *a, **k: executor)
    release = Store.release

    def interrupted_release(self, run_ids=None):
        signal.raise_signal(signal.SIGHUP)
        return release(self, run_ids)

    monkeypatch.setattr(Store, "release", interrupted_release)
    assert main(["run", str(campaign.path), "--quiet"]) == 143
    assert capsys.readouterr().err.strip() == INTERRUPTED.format(how=" (SIGTERM)")
    assert executor.cancelled is True
    assert counts(campaign) == {"pending": 29, "running": 0, "done": 0, "failed": 0}
    assert hidden(campaign) == set()


# ---------------------------------------------------------------- `demcal run` killed
def _demcal_run(path: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "demcal", "run", str(path), "--quiet"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)


def _wait_for(campaign, process, done: int) -> None:
    """Until ``done`` runs are done and another is in flight."""
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline and process.poll() is None:
        if campaign.store_path.is_file():
            state = counts(campaign)
            if state["done"] >= done and state["running"]:
                return
        time.sleep(0.02)
    raise AssertionError(f"`demcal run` did not reach {done} runs done (status {process.poll()})")


#: (what, runs done before the kill, to whom, signals sent back to back: the second one
#: lands in the handling or the clean-up of the first)
KILLS = (
    ("the runner, runs in flight", 4, "runner", 1),
    ("its process group, workers included (Slurm, systemd), twice", 12, "group", 2),
)


def test_demcal_run_stopped_by_sigterm_leaves_nothing_and_resumes_to_the_same_bits(campaign_file, tmp_path):
    path = campaign_file(sleep=0.15)
    campaign = load_campaign(path)
    for what, done, to, times in KILLS:
        process = _demcal_run(path)
        try:
            _wait_for(campaign, process, done)
            for _ in range(times):
                if to == "group":
                    os.killpg(process.pid, signal.SIGTERM)
                else:
                    process.send_signal(signal.SIGTERM)
            out, err = process.communicate(timeout=60)
        finally:
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
        assert process.returncode == 143, (what, err)
        assert err.strip().splitlines()[-1] == INTERRUPTED.format(how=" (SIGTERM)"), (what, err)
        state = counts(campaign)
        assert (state["running"], state["failed"]) == (0, 0), (what, state)
        assert hidden(campaign) == set(), what
    resumed = subprocess.run([sys.executable, "-m", "demcal", "run", str(path), "--quiet"], capture_output=True,
                             text=True, timeout=120)
    assert resumed.returncode == 0, resumed.stderr
    assert "29 of 29 runs done" in resumed.stdout and "already done" in resumed.stdout, resumed.stdout
    assert len(settled(campaign)["done"]) == 29
    # The same campaign never stopped, in a folder of its own: the same bits.
    clean_path = tmp_path / "clean" / path.name
    clean_path.parent.mkdir()
    clean_path.write_text(path.read_text())
    clean = load_campaign(clean_path)
    run_campaign(clean, progress=False, executor=InlineExecutor())
    with Store(campaign.store_path, readonly=True) as stopped, Store(clean.store_path, readonly=True) as never:
        assert {r.key: r.responses for r in stopped.records()} == {r.key: r.responses for r in never.records()}


@pytest.mark.slow
def test_ten_sigterms_at_random_moments(campaign_file, tmp_path):
    """benchmarks/sigterm_kills.py on the test double: 10 kills, then a resume with the same bits."""
    path = campaign_file(sleep=0.3)
    out = tmp_path / "kills.jsonl"
    done = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "sigterm_kills.py"), "--campaign", str(path),
                           "--profile", "", "--kills", "10", "--out", str(out)],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "; OK." in done.stdout
