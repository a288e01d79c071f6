"""A campaign run as one GPU ensemble, in numba-cuda's simulator.

Run as a script (``NUMBA_ENABLE_CUDASIM=1``, set by tests/campaign/test_ensemble.py in a
subprocess of its own): a four-run impact campaign at the tiny profile with ``[executor]
backend = "cuda"`` and ``ensemble = 3`` runs through the runner and
:class:`~demcal.campaign.pool.EnsembleExecutor` (three runs join the ensemble at once,
the fourth as the first ends), then each run again alone on the cpu backend in this
process. Prints one JSON line: the store's statuses, each run's response from the
ensemble and alone (as text, every digit), and the backends ``run.json`` recorded.
With the argument ``dying``: :func:`dying`.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

CAMPAIGN = """\
[campaign]
name = "impact ensemble"

[experiment]
test = "impact"
profile = "tiny"

[[factors]]
name = "A"
parameter = "particle.restitution"
low = 0.3
high = 0.7

[[factors]]
name = "B"
parameter = "impact.speed"
low = 0.5
high = 1.5

[design]
type = "full-factorial"

[executor]
backend = "cuda"
ensemble = 3

[[conditions]]
name = "dry"
targets = { restitution = { mean = 0.5, sd = 0.1 } }
"""


DYING = """\
[campaign]
name = "dying ensemble"

[experiment]
test = "test-heap-dying"
profile = "tiny"
plugins = ["campaign_testbench", "dying_testbench"]

[experiment.settings]
"test.sleep_s" = 0.3

[[factors]]
name = "A"
parameter = "particle.restitution"
low = 0.5
high = 0.7

[[factors]]
name = "B"
parameter = "particle.static_friction"
low = 0.3
high = 0.5

[design]
type = "full-factorial"
center = 4

[runs]
seed = 7

[executor]
backend = "cuda"
ensemble = 3

[[conditions]]
name = "dry"
targets = { repose_angle_deg = { mean = 36.0, sd = 2.1 } }
"""

DYING_PLUGIN = """\
import os
import signal
import time

from campaign_testbench import HeapDouble
from demcal.bench.registry import register


class DyingHeap(HeapDouble):
    name = "test-heap-dying"

    def run(self, settings=None, seed=0, **options):
        if seed == int(os.environ.get("DEMCAL_TEST_DIE_SEED", "-1")):
            # early, while the runs beside it sleep through their 0.3 s
            time.sleep(0.05)
            os.kill(os.getpid(), signal.SIGKILL)
        return super().run(settings, seed, **options)


register(DyingHeap())
"""


def dying() -> int:
    """The ensemble worker killed by one run (seed 7 + 5) early in it, each time: that run
    fails after its retry, the runs in flight beside it are tried again on their own
    and recorded once, every other run runs once. Prints the statuses, the failures and
    how often each seed began (the test double's marker files)."""
    import os
    from collections import Counter

    from demcal.campaign.config import load_campaign
    from demcal.campaign.runner import design_results, run_campaign

    with tempfile.TemporaryDirectory() as folder:
        here = Path(__file__).resolve().parent
        (Path(folder) / "dying_testbench.py").write_text(DYING_PLUGIN)
        sys.path[:0] = [folder, str(here)]
        os.environ["PYTHONPATH"] = os.pathsep.join([folder, str(here), os.environ.get("PYTHONPATH", "")])
        marks = Path(folder) / "markers"
        marks.mkdir()
        os.environ["DEMCAL_TEST_MARKERS"] = str(marks)
        os.environ["DEMCAL_TEST_DIE_SEED"] = "12"
        path = Path(folder) / "campaign.toml"
        path.write_text(DYING)
        campaign = load_campaign(path, import_plugins=True).with_workdir(Path(folder) / "work")
        summary = run_campaign(campaign, progress=False)
        table = design_results(campaign)
        counts = Counter(int(p.name.split("-", 1)[0]) for p in marks.iterdir())
    print(json.dumps({"executor": summary.executor, "done": summary.done, "failed": summary.failed,
                      "failures": summary.failures, "status": list(table["status"]),
                      "seeds": [int(s) for s in table["seed"]], "ran": {str(k): v for k, v in counts.items()}}),
          flush=True)
    return 0


def main() -> int:
    from demcal.campaign.config import parse_campaign
    from demcal.campaign.runner import design_results, run_campaign
    from demcal.campaign.task import simulate

    sys.setswitchinterval(1e-5)   # see tests/dem/cuda_sim_cases.py
    if sys.argv[1:] == ["dying"]:
        return dying()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "campaign.toml"
        path.write_text(CAMPAIGN)
        campaign = parse_campaign(CAMPAIGN, path).with_workdir(Path(folder) / "work")
        summary = run_campaign(campaign, progress=False)
        table = design_results(campaign)
        runs = Path(folder) / "work" / "runs"
        backends = sorted({json.loads((runs / name / "run.json").read_text())["backend"]
                           for name in table["artifacts_dir"]})
        together, alone = [], []
        for _, row in table.iterrows():
            run = json.loads((runs / row["artifacts_dir"] / "run.json").read_text())
            together.append(repr(float(row["restitution"])))
            result = simulate("impact", "tiny", run["overrides"], run["seed"], backend="cpu")
            alone.append(repr(float(result["responses"]["restitution"])))
    print(json.dumps({"executor": summary.executor, "status": list(table["status"]),
                      "together": together, "alone": alone, "backends": backends}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
