"""One run as a task: the pure run function, and the wrapper every executor maps.

A run is a pure function of (virtual test, profile, settings, seed): :func:`simulate`
calls the registered experiment and returns ``RunResult.to_dict()``. :func:`execute`
wraps it for the runner -- artifacts into a temporary folder (the runner moves it into
place in the transaction that records the run), the resolved configuration saved next
to them, errors caught as text, a full disk or a read-only folder told apart as the
machine's fault.
"""

from __future__ import annotations

import errno
import importlib
import os
import shutil
import socket
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Mapping, Sequence

from demcal.errors import DemcalError


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
