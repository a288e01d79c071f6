"""``demcal demo``: the reference paper's two campaigns end to end.

The workflow behind the command (registered in :mod:`demcal.cli.campaign`); it lives in
the command-line layer because it drives both the campaigns and the report, which sit
below it.

Copies ``examples/residual-film-soil`` into ``OUT/campaigns``, runs the repose design
(29 runs) and calibrates it (verification replicates included), then the sliding one
(17 runs per moisture content: its runs of each condition take the inter-particle values
the repose campaign calibrated for it, ``from_campaign``), and writes one report with both
campaigns and the paper's re-analysis. Each campaign is calibrated before the next one
runs, so a campaign chained to an earlier one finds its calibration.
One executor serves every step, so workers start (and numba loads its cache) once.
Re-running the demo resumes: finished runs are kept in ``OUT/campaigns/*-runs``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from demcal.errors import ConfigError

CAMPAIGNS = ("repose.toml", "sliding.toml")


def examples_dir() -> Path:
    """The ``examples/residual-film-soil`` folder of the source tree."""
    here = Path(__file__).resolve()
    for parent in here.parents:
        candidate = parent / "examples" / "residual-film-soil"
        if (candidate / CAMPAIGNS[0]).is_file():
            return candidate
    raise ConfigError("cannot find examples/residual-film-soil; run the demo from a demcal source checkout "
                      "(pip install -e .).")


def _with_profiles(campaign, profile: str):
    """The campaign with its design profile and production profile for ``demcal demo
    --profile PROFILE``."""
    from demcal.bench.common import MEDIUM
    from demcal.bench.registry import get_experiment

    cheap = profile
    if profile == "paper":
        cheap = MEDIUM if MEDIUM in get_experiment(campaign.test).profiles else "quick"
    return campaign.with_profile(cheap).with_production(profile)


def run_demo(out: str | Path = "demo-output", profile: str = "quick", workers: int | None = None,
             progress: bool = True) -> Path:
    """Run, calibrate and report both example campaigns; returns the report's path."""
    from demcal.campaign.calibrate import calibrate, describe
    from demcal.campaign.config import load_campaign
    from demcal.campaign.executors import make_executor
    from demcal.campaign.runner import run_campaign
    from demcal.report.campaign_report import write_report

    start = time.perf_counter()
    out = Path(out)
    folder = out / "campaigns"
    source = examples_dir()
    # Every option is checked on the examples where they lie, before anything is written.
    for name in CAMPAIGNS:
        _with_profiles(load_campaign(source / name), profile)
    _copy_examples(source, folder)
    # The loop's two fidelities: designs at the cheap profile, verification at the
    # production one (`--profile paper`: designs at the test's medium profile where it has
    # one, the incline's, whose response is the paper bed's within 1 deg; else at quick).
    campaigns = [_with_profiles(load_campaign(folder / name, import_plugins=True), profile) for name in CAMPAIGNS]

    config = campaigns[0].executor
    executor = make_executor(config.kind, config.workers if workers is None else workers, config.scheduler,
                             config.start_method, campaigns[0].plugins, ensemble=config.ensemble)
    calibrations = []
    try:
        for campaign in campaigns:  # in order: a chained campaign needs the calibration of the one before
            summary = run_campaign(campaign, executor=executor, progress=progress)
            _say(summary.sentence(campaign.name))
            for label, error in summary.failures[:5]:
                _say(f"  {label}: {error}")
            calibration = calibrate(campaign, executor=executor, progress=progress)
            _say(describe(calibration))
            calibrations.append(calibration)
    finally:
        executor.close()
    path = write_report(campaigns, out / "report", calibrations,
                        title=f"demcal demo: the residual-film-soil calibration (profile {profile})")
    _say(f"demo finished in {(time.perf_counter() - start) / 60:.1f} min on {executor.description}.")
    return path


def _copy_examples(source: Path, folder: Path) -> None:
    """The example's campaign files, lab record and tables into ``folder``; a file already
    there is kept when it is the example's, and refused when it differs (an edited campaign
    is the user's, never replaced). A file-system error names the copy, not the example."""
    from demcal._files import write_atomic

    files = [p for p in sorted(source.iterdir()) if p.is_file() and p.suffix in (".toml", ".csv", ".md")]
    for path in files:
        target = folder / path.name
        if target.exists() and (not target.is_file() or target.read_bytes() != path.read_bytes()):
            raise ConfigError(f"{target} is not the example's {path.name} (edited?), and the demo never replaces "
                              "a file of yours; move it away, or give the demo another --out folder.")
    folder.mkdir(parents=True, exist_ok=True)
    for path in files:
        target = folder / path.name
        if not target.exists():
            write_atomic(target, path.read_bytes())


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)
