"""Fixtures for the campaign tests: a test-double experiment and campaign files.

The runner is exercised with ``test-heap`` (``campaign_testbench.py``), a
deterministic function of settings and seed that takes a fraction of a second;
the real virtual experiments are covered by the slow tests.
"""

from __future__ import annotations

import os
from collections import Counter
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

# Reading a campaign file never imports its plugins (only `demcal run`, `calibrate` and
# `demo` do, with load_campaign(..., import_plugins=True)); the tests that load the
# test doubles' campaigns directly find them registered in this process.
import campaign_testbench  # noqa: E402,F401  registers test-heap
import loop_testbench  # noqa: E402,F401  registers the loop's fidelity double

#: The paper's repose factors (Table 3): name, setting, level -1, level +1.
FACTORS = (
    ("A", "particle.restitution", 0.5, 0.7),
    ("B", "particle.static_friction", 0.3, 0.5),
    ("C", "particle.rolling_friction", 0.1, 0.3),
    ("D", "particle.damping_factor", 0.0, 0.2),
)


def factor_tables(names: str) -> str:
    """The campaign-file ``[[factors]]`` tables of the named :data:`FACTORS`."""
    return "".join(f'[[factors]]\nname = "{n}"\nparameter = "{p}"\nlow = {lo}\nhigh = {hi}\n\n'
                   for n, p, lo, hi in FACTORS if n in names)


#: A complete campaign on the test double: 4 factors, Box-Behnken with 5 centre points.
CAMPAIGN = """\
[campaign]
name = "test campaign"

[experiment]
test = "test-heap"
profile = "tiny"
plugins = ["campaign_testbench"]

[experiment.settings]
"test.sleep_s" = {sleep}

""" + factor_tables("ABCD") + """\
[design]
type = "box-behnken"
center = 5

[runs]
seed = 7

[model]
order = "quadratic"

[[conditions]]
name = "6.26 %"
targets = {{ repose_angle_deg = {{ mean = 36.0, sd = 2.1 }} }}

[[conditions]]
name = "14.1 %"
targets = {{ repose_angle_deg = {{ mean = 42.0, sd = 2.2 }} }}

[verification]
replicates = 2

[executor]
workers = 2
"""


@pytest.fixture(autouse=True)
def _plugin_on_path(monkeypatch):
    """Subprocesses (pool workers, `demcal run`) must import the test double too."""
    parts = [str(HERE)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(parts))


@pytest.fixture
def markers(tmp_path, monkeypatch):
    """Each execution of the test double drops a file here, named by its seed."""
    folder = tmp_path / "markers"
    folder.mkdir()
    monkeypatch.setenv("DEMCAL_TEST_MARKERS", str(folder))

    def count() -> Counter:
        return Counter(int(p.name.split("-", 1)[0]) for p in folder.iterdir())

    return count


@pytest.fixture
def campaign_file(tmp_path):
    """Write the test campaign (optionally edited) and return its path.

    ``campaign_file(sleep=0.05, replace={"old": "new"})``
    """

    def write(sleep: float = 0.02, replace: dict[str, str] | None = None, name: str = "campaign.toml") -> Path:
        path = tmp_path / name
        path.write_text(edited(CAMPAIGN.format(sleep=sleep), replace))
        return path

    return write


def edited(text: str, replace: dict[str, str] | None = None) -> str:
    """``text`` with each key of ``replace`` (which must occur) replaced once by its value."""
    for old, new in (replace or {}).items():
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def local_and_dask_results(campaign, root: Path):
    """Run ``campaign`` through a 2-process local pool and a 2-worker Dask
    ``LocalCluster`` into two work folders; return both design result tables."""
    from demcal.campaign.executors import DaskExecutor
    from demcal.campaign.runner import design_results, run_campaign

    local = campaign.with_workdir(root / "local")
    dask = campaign.with_workdir(root / "dask")
    run_campaign(local, workers=2, progress=False)
    executor = DaskExecutor(None, workers=2, plugins=campaign.plugins)
    try:
        run_campaign(dask, progress=False, executor=executor)
    finally:
        executor.close()
    return design_results(local), design_results(dask)


class InlineExecutor:
    """An executor double that runs each task at once in this process (no pool to start).

    It maps :func:`demcal.campaign.executors.execute` like the real executors, so the
    runner's store, claims and artifact folders are exercised; ``ran`` counts tasks.
    """

    kind = "inline"
    description = "this process (test double)"

    def __init__(self, workers: int = 2):
        self.workers = workers
        self.threads = 1
        self.ran = 0

    def submit(self, task):
        import concurrent.futures

        from demcal.campaign.executors import execute

        future = concurrent.futures.Future()
        future.set_result(execute(dict(task, threads=self.threads)))
        self.ran += 1
        return future

    def wait(self, handles, timeout):
        return [(handle, handle.result()) for handle in handles if handle.done()]

    def close(self, cancel: bool = False) -> None:
        pass
