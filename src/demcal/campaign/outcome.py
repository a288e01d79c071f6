"""What a condition's calibration loop found: the statuses it ends with, the lines of its
history and its result (:mod:`demcal.campaign.loop`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from demcal.campaign.box import Box
from demcal.campaign.discrepancy import CorrectedSurface
from demcal.campaign.store import RunRecord, RunSpec

#: Why a condition's loop ended.
VERIFIED, OUT_OF_REACH, BUDGET, ITERATIONS, NOISE, UNFINISHED, NOT_VERIFIED = (
    "verified", "out of reach", "budget spent", "iterations spent", "noise", "unfinished", "not verified")


@dataclass
class Step:
    """One line of a condition's loop history."""

    iteration: int
    box: int
    stage: str  #: "solve", "path", "design", "production"
    runs: int  #: runs this step added (runs the loop had asked for before are not counted again)
    text: str
    predicted: float | None = None
    simulated: float | None = None
    half_width: float | None = None
    discrepancy: str = ""
    point: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass
class LoopResult:
    """What the loop found for one condition."""

    status: str
    reason: str
    box: Box
    boxes: list[Box]
    models: dict  #: response -> the (reduced) model of the final box
    full: dict
    removed: dict
    discrepancy: dict  #: response -> Discrepancy
    best: Any  #: the chosen solution (pd.Series) in the final box
    optimization: Any
    production: list[RunRecord]  #: the runs at the chosen point
    specs: list[RunSpec]
    history: list[Step]
    notes: list[str]
    cheap_target: dict[str, float]
    #: set when the production point lies on a path of steepest ascent (no box around it):
    #: ``point`` (its parameters), ``box`` (the box the path left), ``steps`` (the two path
    #: steps it lies between), ``way`` ("ascent" or "descent"); at the path's end at the
    #: limits (:func:`demcal.campaign.ascent.end_in_reach`) also ``limit`` (True) and ``reading`` (the path's
    #: production reading there), and ``steps`` is that step twice
    on_path: dict | None = None
    #: the states the loop went through, as ``(state, next state)`` pairs
    #: (:data:`demcal.campaign.states.TRANSITIONS`)
    transitions: list[tuple[str, str]] = field(default_factory=list)

    def corrected(self) -> dict:
        """Response -> the final box's model plus its production discrepancy
        (:class:`CorrectedSurface`), for the responses that have a discrepancy."""
        box0 = self.boxes[0]
        return {r: CorrectedSurface(m, self.discrepancy[r], self.box, box0) for r, m in self.models.items()
                if r in self.discrepancy}

    def runs_by_stage(self) -> dict[str, int]:
        """Runs each stage asked for ("path", "design", "production"), done before or now."""
        out: dict[str, int] = {}
        for step in self.history:
            out[step.stage] = out.get(step.stage, 0) + step.runs
        return out


def show(params: dict[str, float]) -> str:
    """Parameters as a history line writes them: ``name = value, ...``."""
    return ", ".join(f"{k} = {v:g}" for k, v in params.items())
