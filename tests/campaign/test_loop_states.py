"""The calibration loop as named states (:mod:`demcal.campaign.states`): every transition
of its table is walked, and docs/calibration.md shows that table.

The walk runs the real loop on the two-fidelity test double (``loop_testbench.py``)
answered in memory (:class:`Memory`: no store, no worker processes), over campaigns
that reach each transition (the cases of ``test_loop.py``, a few in one campaign).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from demcal.campaign.config import parse_campaign
from demcal.campaign.loop import run_condition
from demcal.campaign.runner import plan_design
from demcal.campaign.states import TRANSITIONS
from demcal.campaign.store import RunRecord

import loop_testbench
from test_loop import write

DOCS = Path(__file__).resolve().parents[2] / "docs" / "calibration.md"


class Memory:
    """A runner answering each run with the test double at once; ``unfinished``: the
    kinds of run it leaves not done (a replay of a store whose runs are under way)."""

    def __init__(self, unfinished: tuple[str, ...] = ()):
        self.unfinished = unfinished
        self.done: dict[str, RunRecord] = {}

    def record(self, spec) -> RunRecord:
        if spec.key not in self.done:
            try:
                result = loop_testbench.FidelityDouble().run(spec.settings, spec.seed, spec.profile)
                status, responses, error = "done", dict(result.responses), None
            except RuntimeError as exc:
                status, responses, error = "failed", {}, str(exc)
            self.done[spec.key] = RunRecord(
                id=len(self.done) + 1, key=spec.key, kind=spec.kind, label=spec.label, test=spec.test,
                profile=spec.profile, parameters=dict(spec.parameters), settings=dict(spec.settings),
                seed=spec.seed, status=status, responses=responses, result={}, artifacts_dir=None, attempts=1,
                started_at=0.0, finished_at=0.0, wall_s=0.01, engine_version="test", error=error, owner=None,
                pid=None, host=None, heartbeat=None)
        return self.done[spec.key]

    def run(self, specs, desc):
        if any(spec.kind in self.unfinished for spec in specs):
            return None
        return [self.record(spec) for spec in specs]

    def records(self) -> list[RunRecord]:
        return list(self.done.values())


def walk(folder: Path, edits: tuple = (), unfinished: tuple[str, ...] = (), **kw) -> list:
    """Every condition's loop of ``write``'s campaign (``edits``: text replacements) on
    :class:`Memory`."""
    path = write(folder, **kw)
    text = path.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new)
    campaign = parse_campaign(text, path)
    memory = Memory(unfinished)
    plan = plan_design(campaign)
    rows = []
    for spec, point in zip(plan.specs, plan.points):
        record = memory.record(spec)
        row = {f.name: float(c) for f, c in zip(campaign.factors, plan.coded[point])}
        row.update({r: record.responses.get(r, float("nan")) for r in campaign.response_names})
        rows.append(row)
    table = pd.DataFrame(rows)
    production = campaign.calibration.production or campaign.profile
    residuals: dict = {}
    return [run_condition(campaign, condition, ci, cheap=campaign.profile, production=production,
                          design_table=table, run=memory.run, records=memory.records, residuals=residuals)
            for ci, condition in enumerate(campaign.conditions)]


#: box 0's edges as hard limits on the factors that raise the angle: no path leaves it
AT_BOX_EDGES = tuple((f"high = {hi}\n", f"high = {hi}\nhard_high = {hi}\n") for hi in (0.7, 0.5, 0.3))
NO_MOVE = (("box_moves = 4", "box_moves = 0"),)

#: campaigns (``write``'s keywords; ``edits``: text replacements) that together take
#: every transition
CASES = {
    "a box move, a bias learnt": dict(),
    "a point on the path that misses": dict(outside=40.5, bias_slope=4.0),
    "no path leaves the box, the window in reach": dict(outside=37.3, edits=AT_BOX_EDGES),
    "out of reach within hard limits": dict(hard=True),
    "a path that falls from the box edge": dict(outside=36.5, curvature=125.0),
    "beyond the peak in the box": dict(outside=40.0, curvature=125.0),
    "no box move allowed": dict(edits=NO_MOVE),
    # the cheap bias shrinks with mu: the corrected surface reads the box edge high
    "the edge point misses again": dict(outside=39.1, bias_slope=-30.0, edits=NO_MOVE),
    "the budget spent at a design": dict(budget="[budget]\nruns = 25\n"),
    "production runs under way": dict(unfinished=("verification",)),
}


def test_every_transition_of_the_table_is_walked(tmp_path):
    taken: dict[tuple[str, str], str] = {}
    for i, (name, kw) in enumerate(CASES.items()):
        folder = tmp_path / str(i)
        folder.mkdir()
        for loop in walk(folder, **kw):
            for pair in loop.transitions:
                taken.setdefault(pair, name)
    assert set(taken) <= set(TRANSITIONS)
    assert sorted(set(TRANSITIONS) - set(taken)) == []


def markdown_table() -> str:
    """The transitions as docs/calibration.md shows them."""
    lines = ["| state | next | when |", "| --- | --- | --- |"]
    lines += [f"| `{a}` | `{b}` | {when} |" for (a, b), when in TRANSITIONS.items()]
    return "\n".join(lines)


def test_the_docs_show_the_transition_table():
    assert markdown_table() in DOCS.read_text(encoding="utf-8"), markdown_table()
