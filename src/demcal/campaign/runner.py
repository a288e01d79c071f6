"""Plan a campaign's runs, fill the store, run what is pending in parallel.

``demcal run campaign.toml`` = :func:`design_specs` + :func:`run_specs`: each design
point (and replicate) becomes a :class:`~demcal.campaign.store.RunSpec` with its own
seed (conditions with settings of their own get a design each); the store skips what
is already done; pending runs are claimed one at a time as workers free up, so several
runners can share one store; a progress bar shows done / failed / remaining and the
ETA (on a terminal; in a log or a pipe, :class:`RunLog` prints a plain line per tenth
of the runs). Verification runs of ``demcal calibrate`` go through the same
:func:`run_specs`.

While it runs, a runner heartbeats its claims and, every few seconds and once more
before it leaves, puts back the claims of runners that died (their pid gone, or
their heartbeat stale), so that it finishes their runs too. A run's result and its
artifact folder are stored together; a full disk or a read-only folder stops the
runner with one sentence, its claims handed back and no partial folder left. Ctrl-C,
SIGTERM and SIGHUP stop it the same way: its workers stopped, every claim handed back
and every temporary folder removed, any further signal held back until that is done.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np
import pandas as pd

from demcal._checks import significant
from demcal.campaign.config import Campaign
from demcal.campaign.store import RunRecord, RunSpec, Store, StoreError, held_signals, temp_name
from demcal.errors import ConfigError, DataError

#: Seconds between heartbeats of a runner's claims (stale after ``heartbeat_timeout_s``).
HEARTBEAT_S = 5.0

def _round(value: float) -> float:
    """Actual levels without binary noise (0.6000000000000001 -> 0.6)."""
    return significant(value, 12)


def point_settings(campaign: Campaign, parameters: dict[str, float]) -> dict[str, Any]:
    """Every override of one run: the fixed settings plus the factor values."""
    settings = dict(campaign.settings)
    settings.update(parameters)
    return settings


@dataclass(frozen=True)
class DesignPlan:
    """The design points of a campaign and the runs that simulate them."""

    coded: np.ndarray  #: (points, k) coded levels, standard order
    specs: tuple[RunSpec, ...]  #: point-major: all replicates of point 1, then point 2, ...
    points: tuple[int, ...]  #: 0-based design point of each spec
    replicates: tuple[int, ...]  #: 0-based replicate of each spec


def plan_design(campaign: Campaign) -> DesignPlan:
    """One run per design point and replicate, each with its own seed.

    Seeds are ``seed + replicate * points + point``: the centre points get
    different seeds, so their spread is the simulation's own noise (the pure error
    of the ANOVA).
    """
    from demcal.bench.registry import get_experiment

    coded = campaign.design.matrix(len(campaign.factors))
    experiment = get_experiment(campaign.test)
    n = coded.shape[0]
    specs, points, replicates = [], [], []
    for i, row in enumerate(coded):
        parameters, settings = checked_point(campaign, experiment, row, f"design point {i + 1}")
        for r in range(campaign.replicates):
            label = f"design {i + 1}" + (f" r{r + 1}" if campaign.replicates > 1 else "")
            specs.append(RunSpec("design", label, campaign.test, campaign.profile, parameters, settings,
                                 campaign.seed + r * n + i))
            points.append(i)
            replicates.append(r)
    return DesignPlan(coded, tuple(specs), tuple(points), tuple(replicates))


def checked_point(campaign: Campaign, experiment, coded_row, what: str) -> tuple[dict[str, float], dict[str, Any]]:
    """The factor values (``parameters``) and every override (``settings``) of the point
    ``coded_row``; one sentence naming ``what`` (e.g. ``design point 3``) when the bench
    refuses them."""
    from demcal.bench.registry import resolve_settings

    parameters = {f.parameter: _round(f.to_actual(c)) for f, c in zip(campaign.factors, coded_row)}
    settings = point_settings(campaign, parameters)
    try:
        resolve_settings(experiment, settings, campaign.profile)
    except ConfigError as exc:
        raise ConfigError(f"{campaign.path.name}: {what} is not a valid run: {exc}") from None
    return parameters, settings


def design_specs(campaign: Campaign) -> list[RunSpec]:
    """Every design run of ``campaign``: its design, once per distinct set of conditions'
    fixed settings (:meth:`~demcal.campaign.config.Campaign.designs`; its chain resolved
    first), each run labelled with its conditions when there are several designs."""
    from demcal.campaign.chain import resolve_chain

    designs = resolve_chain(campaign).designs()
    if len(designs) == 1:
        return list(plan_design(designs[0][0]).specs)
    specs = []
    for boxed, conditions in designs:
        names = ", ".join(c.name for c in conditions)
        specs += [dataclasses.replace(s, label=f"{names} {s.label}") for s in plan_design(boxed).specs]
    return specs


def open_store(campaign: Campaign) -> Store:
    """The campaign's store, created on first use; records the campaign's name, file and
    file text, after :func:`check_store_owner` found the store is the campaign's."""
    from demcal import __version__

    store = Store(campaign.store_path)
    try:
        check_store_owner(campaign, store)
        store.record_campaign(campaign.name, _source(campaign), __version__, _relative_path(campaign, store))
    except BaseException:
        store.close()
        raise
    return store


def check_store_owner(campaign: Campaign, store: Store) -> None:
    """One :class:`DataError` sentence when the store is another campaign's: it records
    another campaign name, or another file that says something else under this name
    (a copy of the file with the same text shares the store: results are keyed by the
    campaign's name)."""
    recorded = store.campaign()
    if recorded is None:
        return
    where = store.path.parent
    other = recorded.get("path")
    other_name = Path(other).name if other else "another file"
    if recorded["name"] != campaign.name:
        raise DataError(
            f"{where} holds the results of campaign '{recorded['name']}' ({other_name}), not of "
            f"'{campaign.name}' ({campaign.path.name}); give {campaign.path.name} its own [campaign] workdir, "
            f"or name it '{recorded['name']}' if it is the same campaign.")
    source = _source(campaign)
    if (other and other != _relative_path(campaign, store) and source and recorded["source"]
            and source != recorded["source"]):
        raise DataError(
            f"{campaign.path.name} and {other_name} both claim the store {where} as campaign "
            f"'{campaign.name}' but differ; give {campaign.path.name} another [campaign] name (its own store) "
            f"or its own [campaign] workdir, so that their results do not mix.")


def _source(campaign: Campaign) -> str:
    try:
        return campaign.path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return ""


def _relative_path(campaign: Campaign, store: Store) -> str:
    """The campaign file relative to the store's folder (a moved pair keeps it)."""
    try:
        return os.path.relpath(campaign.path.resolve(), store.path.parent.resolve())
    except (OSError, ValueError):
        return str(campaign.path)


@dataclass
class RunSummary:
    """What one call of :func:`run_specs` did."""

    total: int
    done: int = 0  #: done in the store after the call (this call's and earlier)
    failed: int = 0
    ran: int = 0  #: runs this call executed
    skipped: int = 0  #: already done before the call
    elsewhere: int = 0  #: still running in another runner
    elapsed_s: float = 0.0
    executor: str = ""
    failures: list[tuple[str, str]] = field(default_factory=list)  #: (label, error)

    def sentence(self, name: str) -> str:
        parts = [f"{name}: {self.done} of {self.total} runs done"]
        if self.failed:
            parts.append(f"{self.failed} failed (rerun with --retry-failed)")
        if self.elsewhere:
            parts.append(f"{self.elsewhere} still running in another runner")
        if self.ran:
            parts.append(f"{self.ran} run now in {self.elapsed_s / 60:.1f} min on {self.executor}")
        if self.skipped:
            parts.append(f"{self.skipped} already done")
        return "; ".join(parts) + "."


def run_specs(
    campaign: Campaign,
    specs: Sequence[RunSpec],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    executor=None,
    desc: str | None = None,
) -> RunSummary:
    """Run every spec not yet done; keep going through failures; resumable.

    Parameters
    ----------
    workers : processes (None: the campaign's ``[executor] workers``, 0: one per core).
    scheduler : a Dask scheduler address; overrides the campaign's executor.
    retry_failed : put failed runs back to pending first.
    executor : an executor to reuse (not closed here).
    """
    from demcal.campaign.executors import engine_version, make_executor

    unique: dict[str, RunSpec] = {}
    for spec in specs:
        unique.setdefault(spec.key, spec)
    keys = list(unique)
    summary = RunSummary(total=len(keys))
    store = open_store(campaign)
    own_executor = executor is None
    try:
        store.add(unique.values())
        if retry_failed:
            store.retry_failed(keys)
        store.reclaim_stale(campaign.executor.heartbeat_timeout_s)
        remove_leftovers(store)
        before = store.counts(keys)
        summary.skipped = before["done"]
        if before["pending"]:
            from demcal.dem.backend import BACKENDS

            # one sentence now (numba-cuda or a GPU missing), not one failed run per run
            BACKENDS[campaign.executor.backend].prepare()
            if executor is None:
                config = campaign.executor
                executor = make_executor(
                    config.kind, config.workers if workers is None else workers,
                    scheduler or config.scheduler, config.start_method, campaign.plugins,
                    ensemble=config.ensemble)
            summary.executor = executor.description
            _drain(store, unique, executor, summary, campaign, progress, desc or campaign.name,
                   before, engine_version)
            remove_leftovers(store)  # of workers that died in this call
        after = store.counts(keys)
        summary.done, summary.failed, summary.elsewhere = after["done"], after["failed"], after["running"]
        summary.failures = [(r.label, r.error or "") for r in store.records(keys) if r.status == "failed"]
    finally:
        if own_executor and executor is not None:
            executor.close()
        store.close()
    return summary


#: ``runs/.<run folder>.tmp-<hex>`` (artifacts being written) and ``.old-<hex>`` (an
#: older folder being replaced): what :func:`~demcal.campaign.store.temp_dir` and
#: :func:`~demcal.campaign.store.publish_dir` leave behind when a process dies.
_LEFTOVER = re.compile(r"^\.(?P<name>.+-(?P<key>[0-9a-f]{10}))\.(?P<what>tmp|old)-[0-9a-f]{8}$")


def remove_leftovers(store: Store) -> int:
    """Remove the temporary folders of runs that no live runner is working on.

    A runner killed with ``kill -9``, a worker killed mid-run or a Ctrl-C leave
    ``runs/.<name>.tmp-*`` folders behind. Call after :meth:`Store.reclaim_stale`:
    every run still ``running`` then belongs to a runner that is alive (its pid on
    this host, or a fresh heartbeat), and its folders are kept -- that runner's worker
    may be writing them. The folder list is read *before* the claims, so a folder
    created by a claim made in between is never in it. An ``.old-*`` folder goes
    only once its run's folder is in place. Returns how many folders were removed.
    """
    try:
        entries = [(path, match) for path in store.runs_dir.iterdir()
                   if (match := _LEFTOVER.match(path.name)) and path.is_dir()]
    except FileNotFoundError:
        return 0
    if not entries:
        return 0
    busy = {key[:10] for key in store.running_keys()}
    removed = 0
    for path, match in entries:
        if match["key"] in busy:
            continue
        if match["what"] == "old" and not (store.runs_dir / match["name"]).is_dir():
            continue  # the only copy of that run's artifacts: publish_dir stopped half way
        with held_signals():  # not half a folder: it would be left for the next runner
            shutil.rmtree(path, ignore_errors=True)
        removed += not path.exists()
    return removed


class RunLog:
    """The runner's progress where stderr is not a terminal (a log file, a pipe, a batch
    job): plain lines, each ended by a newline and none holding a carriage return, instead
    of tqdm's bar redrawn in place. A line when the runs start, then one when a finished
    run brings the count to a new tenth of the total or comes :attr:`INTERVAL_S` after
    the last line, and one for the last run: a dozen lines for any campaign. It has the
    few methods of tqdm the runner calls (``n``, ``update``, ``set_postfix_str``,
    ``write``, ``close``).
    """

    #: Seconds after which a finished run is logged even within the same tenth.
    INTERVAL_S = 60.0

    def __init__(self, total: int, initial: int, desc: str, file, clock=time.monotonic):
        self.total, self.n, self.desc, self.file, self.clock = int(total), int(initial), desc, file, clock
        self.postfix = ""
        self._initial = self.n
        self._start = self._last = clock()
        self._tenth = self._tenths(self.n)
        self.write(f"{desc}: {self.total} runs, {self.n} of them finished before")

    def _tenths(self, n: int) -> int:
        return 10 * n // max(self.total, 1)

    def set_postfix_str(self, text: str, refresh: bool = False) -> None:
        self.postfix = text

    def update(self, step: int = 1) -> None:
        """Count ``step`` finished runs; log a line when one is due."""
        if not step:
            return
        self.n += step
        now = self.clock()
        if self.n >= self.total or self._tenths(self.n) > self._tenth or now - self._last >= self.INTERVAL_S:
            self._tenth, self._last = self._tenths(self.n), now
            self.write(self.line(now))

    def line(self, now: float) -> str:
        """``design: 12/29 runs (41 %), failed 0, remaining 17, 00:41 elapsed, ETA 00:58``."""
        from tqdm import tqdm

        elapsed = now - self._start
        ran = self.n - self._initial
        parts = [f"{self.desc}: {self.n}/{self.total} runs ({100 * self.n // max(self.total, 1)} %)"]
        parts += [item.replace("=", " ") for item in self.postfix.split()]
        parts.append(f"{tqdm.format_interval(elapsed)} elapsed")
        if ran > 0 and self.n < self.total:
            parts.append(f"ETA {tqdm.format_interval(elapsed / ran * (self.total - self.n))}")
        return ", ".join(parts)

    def write(self, text: str) -> None:
        """Print ``text`` on a line of its own."""
        try:
            self.file.write(text.rstrip("\n") + "\n")
            self.file.flush()
        except (OSError, ValueError):  # the reader went away: progress is not worth dying for
            pass

    def close(self) -> None:
        pass


def _progress_bar(total: int, initial: int, desc: str, progress: bool):
    """tqdm's bar on a terminal (or a silent one without ``progress``), else a
    :class:`RunLog` of plain lines, both on stderr."""
    from tqdm import tqdm

    from demcal.dem.reporters import _is_terminal

    if progress and not _is_terminal(sys.stderr):
        return RunLog(total, initial, desc, sys.stderr)
    return tqdm(total=total, initial=initial, desc=desc, unit="run", disable=not progress, file=sys.stderr,
                dynamic_ncols=True, smoothing=0.1)


def _drain(store: Store, specs: dict[str, RunSpec], executor, summary: RunSummary, campaign: Campaign,
           progress: bool, desc: str, before: dict[str, int], engine_version) -> None:
    keys = list(specs)
    runs_dir = store.runs_dir.resolve()
    timeout = campaign.executor.heartbeat_timeout_s
    beat_s = min(HEARTBEAT_S, timeout / 4)  # several beats before a claim may be thought stale
    in_flight: dict[Any, tuple[RunRecord, str]] = {}  #: handle -> (claim, temporary folder name)
    folders: dict[int, str] = {}  #: run id -> temporary folder name, from its claim until it is settled
    failed = before["failed"]
    bar = _progress_bar(len(keys), before["done"] + before["failed"], desc, progress)

    def advance(step: int) -> None:
        remaining = len(keys) - bar.n - step
        bar.set_postfix_str(f"failed={failed} remaining={remaining}", refresh=False)
        bar.update(step)

    def reclaim() -> int:
        """Claims of dead runners back to pending, their temporary folders removed."""
        count = store.reclaim_stale(timeout)
        if count:
            remove_leftovers(store)
        return count

    advance(0)
    start = time.perf_counter()
    next_beat = time.monotonic() + beat_s
    fatal = None  #: a full disk or a read-only folder: claim nothing more, record the runs in flight, stop
    try:
        while True:
            while fatal is None and len(in_flight) < executor.workers:
                record = store.claim(keys)
                if record is None:
                    break
                spec = specs[record.key]
                tmp = temp_name(spec.dirname)
                folders[record.id] = tmp  # before its worker can make it: the clean-up knows it
                in_flight[executor.submit(_task(campaign, spec, runs_dir, tmp))] = (record, tmp)
            if not in_flight:
                if fatal is not None:
                    raise StoreError(fatal)
                if reclaim():  # a runner that died holding claims is noticed before we leave
                    continue
                break
            for handle, outcome in executor.wait(list(in_flight), timeout=beat_s):
                record, tmp = in_flight[handle]
                if outcome.get("fatal"):  # not the run's fault: it goes back to pending
                    if fatal is None and len(in_flight) > 1 and progress:
                        bar.write(f"stopping after the {len(in_flight) - 1} runs in flight: {outcome['fatal']}")
                    fatal = fatal or outcome["fatal"]
                    _hand_back(store, record, runs_dir / tmp)
                    del in_flight[handle], folders[record.id]
                    continue
                ok = _record_outcome(store, record, specs[record.key], tmp, outcome, runs_dir, engine_version)
                del in_flight[handle], folders[record.id]
                if not ok:
                    failed += 1
                    if progress:  # without the bar, the caller reports summary.failures
                        bar.write(f"{record.label} failed: {outcome.get('error')}")
                summary.ran += 1
                advance(1)
            if time.monotonic() >= next_beat:
                store.heartbeat()
                reclaim()
                next_beat = time.monotonic() + beat_s
    except BaseException:
        # Ctrl-C, SIGTERM, SIGHUP, a full disk or an error of the runner itself
        _stop(store, executor, runs_dir, folders)
        raise
    finally:
        bar.close()
        summary.elapsed_s = time.perf_counter() - start


def _task(campaign: Campaign, spec: RunSpec, runs_dir: Path, tmp: str) -> dict[str, Any]:
    """The task an executor runs for ``spec`` (:func:`demcal.campaign.task.execute`),
    its artifacts written to ``runs_dir / tmp``."""
    return {
        "test": spec.test, "profile": spec.profile, "settings": dict(spec.settings),
        "seed": spec.seed, "plugins": list(campaign.plugins), "label": spec.label,
        "runs_dir": str(runs_dir), "name": spec.dirname, "tmp": tmp,
        "backend": campaign.executor.backend,
    }


def _hand_back(store: Store, record: RunRecord, folder: Path) -> None:
    """Put back to pending a run whose worker met a full disk or a read-only folder, and
    remove its temporary ``folder``."""
    with contextlib.suppress(StoreError):  # on a full disk it stays claimed by this runner,
        store.release([record.id])       # which is gone when it exits
    shutil.rmtree(folder, ignore_errors=True)


def _stop(store: Store, executor, runs_dir: Path, folders: dict[int, str]) -> None:
    """Stop the workers, hand every claim back at once so the next runner need not wait
    for them to go stale, and leave no half-written folder (``folders``: run id ->
    temporary folder name) -- with further signals held back until that is done.

    Every claim of this runner, not only those in flight: an interrupt may come between
    a claim and its task. On a full disk even that write may fail: the claims then stay
    with this runner, which is gone once it exits, and the next one takes them back
    (reclaim_stale).
    """
    with held_signals():
        try:
            executor.close(cancel=True)
        finally:
            with contextlib.suppress(StoreError):
                store.release()
            for tmp in folders.values():
                shutil.rmtree(runs_dir / tmp, ignore_errors=True)


def _record_outcome(store: Store, record: RunRecord, spec: RunSpec, tmp: str, outcome: dict[str, Any],
                    runs_dir, engine_version) -> bool:
    """Store one run's outcome and move its folder into place, together; True if it succeeded.

    A run another runner has taken over meanwhile (this one's claim went stale) is
    that runner's: its folder here is removed and nothing is recorded.
    """
    version = outcome.get("engine_version") or engine_version()
    folder = runs_dir / tmp
    # Only a folder that execute() completed; a worker that died leaves a partial one.
    publish = (folder, runs_dir / spec.dirname) if outcome.get("tmp_dir") and folder.is_dir() else None
    if publish is None:
        shutil.rmtree(folder, ignore_errors=True)
    if outcome.get("ok"):
        owned = store.finish(record.id, outcome["result"], spec.dirname if publish else outcome.get("artifacts_dir"),
                             version, publish=publish)
    else:
        owned = store.fail(record.id, outcome.get("error", "unknown error"), version, outcome.get("wall_s"),
                           publish=publish, artifacts_dir=spec.dirname if publish else None)
    if not owned:
        shutil.rmtree(folder, ignore_errors=True)
    return bool(outcome.get("ok"))


def run_campaign(campaign: Campaign, *, workers: int | None = None, scheduler: str | None = None,
                 retry_failed: bool = False, progress: bool = True, executor=None) -> RunSummary:
    """Simulate every design point of ``campaign`` (what ``demcal run`` does)."""
    return run_specs(campaign, design_specs(campaign), workers=workers, scheduler=scheduler, retry_failed=retry_failed,
                     progress=progress, executor=executor, desc=f"{campaign.name} design")


def design_results(campaign: Campaign, store: Store | None = None) -> pd.DataFrame:
    """The design with its results: one row per run, standard order.

    Columns: ``run`` (standard order, 1-based), ``replicate``, one coded column per
    factor (its name, e.g. ``A``), one actual column per factor (its parameter key),
    ``seed``, ``status``, each response, ``wall_s``, ``key``, ``artifacts_dir``.
    Runs not done have NaN responses.
    """
    plan = plan_design(campaign)
    own = store is None
    if own:
        store = Store(campaign.store_path, readonly=True)
    try:
        records = {r.key: r for r in store.records([s.key for s in plan.specs])}
    finally:
        if own:
            store.close()
    rows = []
    for spec, point, replicate in zip(plan.specs, plan.points, plan.replicates):
        record = records.get(spec.key)
        row: dict[str, Any] = {"run": point + 1, "replicate": replicate + 1}
        for factor, coded in zip(campaign.factors, plan.coded[point]):
            row[factor.name] = float(coded)
        row.update(spec.parameters)
        row["seed"] = spec.seed
        row["status"] = record.status if record else "missing"
        for response in campaign.response_names:
            value = record.responses.get(response) if record and record.status == "done" else None
            row[response] = float(value) if value is not None else np.nan
        row["wall_s"] = record.wall_s if record else np.nan
        row["key"] = spec.key
        row["artifacts_dir"] = record.artifacts_dir if record else None
        rows.append(row)
    return pd.DataFrame(rows)
