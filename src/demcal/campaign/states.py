"""The calibration loop of one condition as named states (:mod:`demcal.campaign.loop`).

Each state is a small function of what the loop has found so far (:class:`LoopState`)
and of the loop's fixed description (:class:`Loop`); it returns the next state, with the
runs that state needs (:class:`Ask`), or a :class:`Stop`. :func:`drive` is the only place
that runs anything: it checks an ask against the ``[budget]``, hands it to the runner
(which, replaying, only reads the store) and gives its records to the next state. Every
decision is thus a function of the stored runs, taken in the order the loop asked for
them: a replay is a fold of the states over those runs. :data:`TRANSITIONS` lists every
move from one state to another; the driver refuses any other.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd

from demcal._checks import significant
from demcal.campaign.box import Box, fit_box, in_window, out_of_box, point_of
from demcal.campaign.config import Campaign, Condition
from demcal.campaign.discrepancy import CorrectedSurface, Discrepancy
from demcal.campaign.noise import production_noise
from demcal.campaign.outcome import (BUDGET, ITERATIONS, NOISE, NOT_VERIFIED, OUT_OF_REACH, UNFINISHED, VERIFIED,
                                     LoopResult, Step, show)
from demcal.campaign.ascent import AT_LIMITS, PathEnd, SteepestPath, lay_path, read_path, turned_back
from demcal.campaign.replicates import batched, first_batch, production_specs, replicates_needed
from demcal.campaign.solve import round_parameter, solve_condition
from demcal.campaign.store import RunRecord, RunSpec

#: ``run(specs, desc) -> records`` runs what is missing (or, replaying, only reads);
#: it returns None when a spec has no finished run and nothing may be run.
Runner = Callable[[list[RunSpec], str], "list[RunRecord] | None"]

#: ``(state, next state): when`` -- every transition of the loop ("stop" ends it, with
#: the status named). A state that asks for runs also stops when the ``[budget]`` is
#: spent or, replaying, when they are not done yet.
TRANSITIONS: dict[tuple[str, str], str] = {
    ("fit", "solve"): "the corrected surface reaches the target's window (its middle half, or any of it "
                      "once no move is left)",
    ("fit", "path"): "the target lies outside what the box reaches, and a box move is left",
    ("fit", "stop"): "the target lies outside the box and no move is left: out of reach (box_moves = 0, "
                     "or no path leads on), iterations spent (the box_moves made)",
    ("path", "crossing"): "asks the path's cheap runs",
    ("path", "fit"): "no path leads on (a flat model, the limits at once) but the box reaches into the window",
    ("path", "stop"): "out of reach: no path leads on; budget spent, unfinished",
    ("crossing", "solve"): "the path brackets the target (or reads inside its window, or ends at the limits "
                           "within its noise): verify that point first",
    ("crossing", "design"): "the path crosses the target, or reads furthest toward it beyond the box: "
                            "lay a box there",
    ("crossing", "fit"): "the path turns back into an earlier box, or leads nowhere (it ends at the limits, "
                         "or reads worse beyond the box than at its edge) while the box reaches into the "
                         "window: no further move",
    ("crossing", "stop"): "out of reach: the path ends at the limits, or reads worse beyond the box than at "
                          "its edge",
    ("design", "box"): "asks the moved box's design runs",
    ("design", "stop"): "budget spent, unfinished",
    ("box", "fit"): "the moved box is the current one",
    ("solve", "production"): "the point to verify (new: its first batch of replicates)",
    ("solve", "stop"): "out of reach: the re-solve returns the point that already missed",
    ("production", "verdict"): "asks the point's production runs",
    ("production", "stop"): "not verified (no replicates asked for); budget spent, unfinished",
    ("verdict", "stop"): "verified; noise (inside, replicates spent); iterations spent; out of reach (the "
                         "path's end at the limits missed); not verified (runs failed)",
    ("verdict", "production"): "inside the lab window, the interval not yet narrower than the lab sd: more "
                               "replicates",
    ("verdict", "fit"): "the point missed: re-solve with what it taught (a missed point on the path whose "
                        "next box would turn back, or at the limits: no further move)",
    ("verdict", "design"): "the point on the path missed: lay the box around it after all",
}


@dataclass(frozen=True)
class Loop:
    """What one condition's loop is given: fixed while it runs."""

    campaign: Campaign
    condition: Condition
    ci: int  #: the condition's index (its production seeds)
    cheap: str
    production: str
    design_table: pd.DataFrame
    run: Runner
    records: Callable[[], list[RunRecord]]
    seed: int
    limits: np.ndarray  #: :func:`demcal.campaign.box.physical_limits`
    budget: "Budget"
    responses: list[str]
    noise_prior: dict  #: :func:`demcal.campaign.noise.stored_noise`
    first_replicates: int
    box0: Box
    on_box: dict  #: response -> stored bias on box 0 (:func:`demcal.campaign.discrepancy.prior_on_box`)
    #: response -> [(box-0 coded point, production - cheap model)], shared by the conditions
    residuals: dict

    @property
    def cfg(self):
        return self.campaign.calibration


@dataclass(frozen=True)
class Ask:
    """Runs a state needs before the next one: their specs, the progress line's words and
    what a stop says they are."""

    specs: list
    desc: str
    what: str


@dataclass(frozen=True)
class Next:
    state: str
    ask: Ask | None = None


@dataclass(frozen=True)
class Stop:
    status: str
    reason: str


@dataclass
class LoopState:
    """What one condition's loop has found so far."""

    box: Box
    boxes: list[Box]
    history: list[Step] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    transitions: list[tuple[str, str]] = field(default_factory=list)
    moves: int = 0  #: box moves made
    iteration: int = 0  #: solves whose point missed
    replicates: int = 0  #: production replicates asked for at the point
    asked: int = 0  #: the same before the rounding to replicate_batch
    point_key: tuple | None = None  #: the point whose runs these are
    counted: set = field(default_factory=set)  #: production runs already in the residuals
    missed: tuple | None = None  #: (point, target, mean) of the last point outside the lab band
    pending: PathEnd | None = None  #: a point on a path verified before its box's design is laid
    #: why no further move is made (a path turned back into an earlier box, or the limits
    #: stop it while the box reaches into the window): (phrase, the stop's reason)
    turned: tuple[str, str] | None = None
    # the last fit
    models: dict = field(default_factory=dict)
    full: dict = field(default_factory=dict)
    removed: dict = field(default_factory=dict)
    disc: dict = field(default_factory=dict)
    cheap_target: dict = field(default_factory=dict)
    corrected: dict = field(default_factory=dict)
    misses: list = field(default_factory=list)  #: (target, lo, hi) the box does not reach
    outside: tuple | None = None  #: the miss a path leaves the box for
    path: SteepestPath | None = None
    laying: Box | None = None  #: the box whose design is asked for
    # the point to verify
    best: Any = None
    optimization: Any = None
    on_path: dict | None = None
    chosen: dict = field(default_factory=dict)
    coded: Any = None
    predicted: dict = field(default_factory=dict)
    prod: list = field(default_factory=list)  #: its production runs
    specs: list = field(default_factory=list)
    # the last ask, its records, and how many of them the loop had not asked for before
    last_ask: Ask | None = None
    runs: list = field(default_factory=list)
    new: int = 0


class Budget:
    """``[budget]``: the runs the calibration uses (its design and every run the loop asked
    for, in order, so that a replay decides the same) and their summed wall time."""

    def __init__(self, campaign: Campaign):
        self.runs = campaign.calibration.budget_runs
        self.hours = campaign.calibration.budget_cpu_hours

    def exceeded(self, records: Sequence[RunRecord], new: int) -> str | None:
        used = len([r for r in records if r.status in ("done", "failed", "running")])
        if self.runs is not None and used + new > self.runs:
            return (f"the budget of {self.runs} runs is spent ({used} used by this calibration, {new} more needed); "
                    f"raise [budget] runs to go on")
        hours = sum((r.wall_s or 0.0) for r in records if r.status in ("done", "failed")) / 3600.0
        if self.hours is not None and hours >= self.hours:
            return (f"the budget of {self.hours:g} run hours is spent ({hours:.2f} h used); "
                    f"raise [budget] cpu_hours to go on")
        return None


def missing(specs, records) -> int:
    """How many of ``specs`` have no finished (done or failed) run in ``records``."""
    done = {r.key for r in records if r.status in ("done", "failed")}
    return len({s.key for s in specs} - done)


def spend(loop: Loop, ask: Ask):
    """Run ``ask`` within the budget: ``(records, new, None)`` with ``new`` the runs the
    loop had not asked for before, or ``(None, 0, Stop)``."""
    new = missing(ask.specs, loop.records())
    reason = loop.budget.exceeded(loop.records(), new)
    if reason:
        return None, 0, Stop(BUDGET, reason)
    done = loop.run(ask.specs, ask.desc)
    if done is None:
        return None, 0, Stop(UNFINISHED, f"{ask.what} are not done yet; run `demcal calibrate "
                                         f"{loop.campaign.path}` to finish them")
    return done, new, None


def drive(loop: Loop, s: LoopState) -> LoopResult:
    """Go from state to state, from ``fit``, until one stops: the loop's result."""
    state = "fit"
    while True:
        step = STATES[state](loop, s)
        if isinstance(step, Next) and step.ask is not None:
            s.last_ask = step.ask
            s.runs, s.new, stopped = spend(loop, step.ask)
            step = stopped or step
        to = step.state if isinstance(step, Next) else "stop"
        if (state, to) not in TRANSITIONS:
            raise RuntimeError(f"the calibration loop went from {state!r} to {to!r}, which TRANSITIONS does not "
                               f"list")
        s.transitions.append((state, to))
        if isinstance(step, Stop):
            return result(s, step)
        state = to


def result(s: LoopState, stop: Stop) -> LoopResult:
    return LoopResult(status=stop.status, reason=stop.reason, box=s.box, boxes=s.boxes, models=s.models,
                      full=s.full, removed=s.removed, discrepancy=s.disc, best=s.best, optimization=s.optimization,
                      production=s.prod, specs=s.specs, history=s.history, notes=s.notes,
                      cheap_target=s.cheap_target, on_path=s.on_path, transitions=s.transitions)


def fit(loop: Loop, s: LoopState):
    """Fit the box's cheap runs and the discrepancy; check what the corrected surface reaches."""
    from demcal.optimize import reachable_range

    campaign, condition, cfg, box = loop.campaign, loop.condition, loop.cfg, s.box
    s.full, s.models, s.removed, fit_notes, _ = fit_box(campaign, box, loop.records(), loop.cheap, loop.design_table)
    s.notes.extend(n for n in fit_notes if n not in s.notes)
    s.disc = {r: Discrepancy(loop.residuals.get(r, []), loop.on_box.get(r)) for r in loop.responses}
    centre0 = loop.box0.to_coded(box.centre)
    s.cheap_target = {t.response: t.mean - s.disc[t.response](centre0)[0] for t in condition.targets}
    s.corrected = {r: CorrectedSurface(s.models[r], s.disc[r], box, loop.box0) for r in loop.responses}
    s.misses = []
    for t in condition.targets:
        lo, hi = reachable_range(s.corrected[t.response], seed=loop.seed)
        if out_of_box(t.mean, t.sd, lo, hi):
            s.misses.append((t, lo, hi))
    if not s.misses:
        return Next("solve")
    if (s.moves >= cfg.box_moves or s.turned) and all(in_window(*m) for m in s.misses):
        _solved_at_edge(loop, s)
        return Next("solve")
    t, lo, hi = s.misses[0]
    if s.turned is not None:
        return Stop(OUT_OF_REACH, s.turned[1])
    if s.moves >= cfg.box_moves:
        return Stop(OUT_OF_REACH if cfg.box_moves == 0 else ITERATIONS,
                    f"the target {t.response} = {t.mean:g} lies outside what box {box.index} reaches "
                    f"({lo:.2f} to {hi:.2f} with the discrepancy) and the {cfg.box_moves} box moves "
                    f"allowed are spent; raise [calibration] box_moves or widen the factor levels")
    s.outside = s.misses[0]
    return Next("path")


def _solved_at_edge(loop: Loop, s: LoopState) -> None:
    """Note why a box that misses the middle half of a lab window is solved at its edge:
    no move is left, but it reaches into each window, and the verification accepts any
    mean inside the window."""
    turned, cfg = s.turned, loop.cfg
    why = (f"{turned[0]}, so" if turned else f"the {cfg.box_moves} box moves allowed are spent and")
    for t, lo, hi in s.misses:
        note = (f"{loop.condition.name}: {why} box "
                f"{s.box.index} reaches {t.response} {lo:.2f} to {hi:.2f} with the discrepancy, into "
                f"the lab window {t.mean:g} ± {t.sd:g} but not its middle half: solved at the "
                f"box's edge")
        if note not in s.notes:
            s.notes.append(note)


def path(loop: Loop, s: LoopState):
    """Lay the path of steepest ascent (or descent) out of the box; ask for its cheap runs."""
    t, lo, hi = s.outside
    laid = lay_path(loop.campaign, loop.condition, s.box, s.corrected[t.response], t.mean, lo, hi, loop.limits,
                    loop.cfg, loop.cheap)
    if isinstance(laid, tuple):
        return _no_path(loop, s, *laid)
    s.path = laid
    return Next("crossing", Ask(laid.specs, f"{loop.campaign.name} {loop.condition.name} path",
                                f"the path runs of box {s.box.index}"))


def _no_path(loop: Loop, s: LoopState, status: str, reason: str):
    """No path leads on (the limits stop it, or the model is flat): the box is the last,
    solved at its edge when it reaches into each lab window, as when the moves are spent."""
    if status == OUT_OF_REACH and all(in_window(*m) for m in s.misses):
        why = "the parameters' limits stop the path from it" if AT_LIMITS in reason else "no path leads on from it"
        s.turned = (why, reason)
        return Next("fit")
    return Stop(status, reason)


def crossing(loop: Loop, s: LoopState):
    """Read the path's runs: verify where it meets the target, lay a box there, or stop."""
    campaign, condition, cfg = loop.campaign, loop.condition, loop.cfg
    moved = read_path(campaign, condition, s.path, s.runs, s.new, loop.limits, cfg, loop.cheap, loop.production,
                      s.moves, s.history, s.iteration)
    if isinstance(moved, tuple):
        return _no_path(loop, s, *moved)
    if moved.limit is None:  # (a path's end at the limits is measured, not moved to)
        s.moves += 1
    if cfg.verify_on_path and moved.point is not None and len(condition.targets) == 1:
        # The path crossed the target between two of its points: verify there first;
        # the new box's design is laid only if that point misses.
        s.pending = moved
        return Next("solve")
    if (back := turned_back(moved, s.boxes, s.box, s.outside[0], condition)) is not None:
        s.notes.append(back)
        s.turned = ("a path turned back", back)
        return Next("fit")
    s.laying = moved.box
    return Next("design")


def design(loop: Loop, s: LoopState):
    """Ask for the moved box's design (earlier runs inside it count)."""
    from demcal.campaign.runner import plan_design

    moved, campaign = s.laying, loop.campaign
    plan = plan_design(moved.campaign(campaign, campaign.calibration.box_replicates))
    specs = [dataclasses.replace(spec, label=f"box {moved.index} {spec.label}") for spec in plan.specs]
    return Next("box", Ask(specs, f"{campaign.name} box {moved.index} design",
                           f"the design runs of box {moved.index}"))


def new_box(loop: Loop, s: LoopState):
    """The moved box, its design run, is the current one."""
    moved, added, asked = s.laying, s.new, len(s.last_ask.specs)
    centre = {f.parameter: significant(c, 3) for f, c in zip(loop.campaign.factors, moved.centre)}
    s.history.append(Step(s.iteration, moved.index, "design", added,
                          f"box {moved.index}: " + show(centre)
                          + f" ± half-widths; {asked} design runs ({asked - added} done before)"))
    s.box, s.laying = moved, None
    s.boxes.append(moved)
    return Next("fit")


def solve(loop: Loop, s: LoopState):
    """The point to verify: the path's, when one waits, else the corrected surface's best."""
    campaign, condition = loop.campaign, loop.condition
    if s.pending is not None:
        _path_point(loop, s)
    else:
        boxed = s.box.campaign(campaign)
        s.best, s.optimization, _ = solve_condition(boxed, s.corrected, condition, seed=loop.seed)
        s.chosen = {f.parameter: round_parameter(float(s.best[f"actual:{f.name}"])) for f in boxed.factors}
        s.coded = s.box.to_coded([s.chosen[f.parameter] for f in campaign.factors])
        s.predicted = {r: float(s.corrected[r].predict(s.coded)) for r in loop.responses}
    key = tuple(sorted(s.chosen.items()))
    if s.missed is not None and key == s.missed[0]:
        # the re-solve returns the point that already missed: nothing learnt moves it
        t, mean = s.missed[1:]
        return Stop(OUT_OF_REACH, f"{t.response}: the best point of box {s.box.index} on the corrected "
                    f"surface is the one whose production mean {mean:.2f} already misses {t.mean:g} ± "
                    f"{t.sd:g}, and what its runs taught does not move it: the target lies at the edge "
                    f"of what the test reaches here; widen the factor limits or raise "
                    f"[calibration] box_moves")
    if key != s.point_key:
        _new_point(loop, s, key)
    return Next("production")


def _path_point(loop: Loop, s: LoopState) -> None:
    """The point on the path that waits (``s.pending``) as the point to verify."""
    end = s.pending
    s.chosen = dict(end.point)
    s.coded = s.box.to_coded([s.chosen[f.parameter] for f in loop.campaign.factors])
    s.predicted = {t.response: t.mean for t in loop.condition.targets}  # where the path reads the target
    s.on_path = {"point": dict(s.chosen), "box": s.box.index, "steps": end.steps,
                 "way": "ascent" if end.sign > 0 else "descent"}
    if end.limit is not None:  # the path's end at the limits, short of the target
        s.on_path.update(limit=True, reading=end.reading)
        s.predicted = {end.response: end.reading}
    elif end.nearest:  # the path's step nearest the target, inside the lab window
        s.on_path.update(nearest=True, reading=end.reading)
        s.predicted = {end.response: end.reading}


def _new_point(loop: Loop, s: LoopState, key: tuple) -> None:
    """A new point: no run of it yet (a stop before they finish reports none, not the
    last point's); its first batch of replicates."""
    cfg = loop.cfg
    s.prod, s.specs = [], []
    noise = production_noise(loop.campaign, loop.records(), loop.production, loop.responses, loop.noise_prior)
    s.point_key = key
    s.asked = first_batch(noise, loop.condition.targets, loop.first_replicates, cfg.min_replicates)
    if loop.production != loop.cheap and not any(loop.residuals.values()):
        # a probe: nothing is known of production - cheap yet (one run, never rounded up)
        s.replicates = s.asked = min(s.asked, 1)
    else:
        s.replicates = batched(s.asked, 0, cfg.replicate_batch, cfg.max_replicates)


def production(loop: Loop, s: LoopState):
    """Ask for the point's production replicates."""
    campaign, condition = loop.campaign, loop.condition
    if s.replicates == 0:
        return Stop(NOT_VERIFIED, "no production replicates are asked for ([verification] replicates = 0)")
    specs = production_specs(campaign, condition, loop.ci, s.chosen, loop.production, s.replicates)
    if s.replicates > s.asked and loop.budget.exceeded(loop.records(), missing(specs, loop.records())):
        # the seeds the rounding to replicate_batch adds do not fit the budget: what the
        # noise asks for may
        s.replicates = s.asked
        specs = production_specs(campaign, condition, loop.ci, s.chosen, loop.production, s.replicates)
    s.specs = specs
    for r in loop.responses:  # a stored bias used beyond the points it was measured at
        d = s.disc[r]
        far = d.prior.bias.outside(specs[0].settings) if d.kind == "stored" and specs else []
        if far:
            note = (f"{condition.name}: the first production point lies outside the points the stored "
                    f"{loop.cheap} → {loop.production} bias of {r} was measured at (" + ", ".join(far)
                    + "): its run tests an extrapolation of that bias, and the loop learns the bias from it")
            if note not in s.notes:
                s.notes.append(note)
    return Next("verdict", Ask(specs, f"{campaign.name} {condition.name} production",
                               f"the production runs at {show(s.chosen)}"))


def verdict(loop: Loop, s: LoopState):
    """Read the point's production runs against the lab: verified, more replicates, or
    what its miss leads to."""
    done = s.prod = s.runs
    ok = [r for r in done if r.status == "done"]
    _learn(loop, s, ok)
    if len(ok) < len(done):
        failed = [r for r in done if r.status != "done"]
        return Stop(NOT_VERIFIED, f"{len(failed)} production runs failed ({failed[0].label}: "
                    f"{failed[0].error}); rerun them with --retry-failed")
    noise = production_noise(loop.campaign, loop.records(), loop.production, loop.responses, loop.noise_prior)
    found = [_judge(loop, s, t, ok, noise) for t in loop.condition.targets]
    if all(v[3] and v[4] for v in found):
        return Stop(VERIFIED, "the production mean lies inside the lab's mean ± sd and its 95 % "
                    "interval is narrower than the lab sd" + _verified_where(s))
    if all(v[3] for v in found):
        return _more_replicates(loop, s, found, noise)
    t, mean, *_ = next(v for v in found if not v[3])
    s.missed = (s.point_key, t, mean)
    if s.pending is not None:
        return _missed_on_path(loop, s, t, mean)
    s.iteration += 1
    if s.iteration >= loop.cfg.iterations:
        return Stop(ITERATIONS, f"{t.response}: the production mean {mean:.2f} still misses "
                    f"{t.mean:g} ± {t.sd:g} after {loop.cfg.iterations} solves on the corrected surface; "
                    f"raise [calibration] iterations")
    return Next("fit")


def _learn(loop: Loop, s: LoopState, ok: list[RunRecord]) -> None:
    """What the point's runs teach about production - cheap (each run once)."""
    pending = s.pending
    for rec in ok:
        if rec.key not in s.counted:
            s.counted.add(rec.key)
            x0 = loop.box0.to_coded(point_of(loop.campaign, rec))
            for r in loop.responses:
                if r in rec.responses:
                    # on a path beyond the box, the cheap response measured along the path
                    # (interpolated), not the box's model extrapolated
                    cheap_here = (pending.cheap if pending is not None and r == pending.response
                                  else float(s.models[r].predict(s.coded)))
                    loop.residuals.setdefault(r, []).append((x0, float(rec.responses[r]) - cheap_here))


def _judge(loop: Loop, s: LoopState, t, ok: list[RunRecord], noise: dict) -> tuple:
    """``(target, mean, half, inside, narrow, sd)`` of one target; its history line."""
    from scipy import stats

    values = np.array([r.responses[t.response] for r in ok])
    mean = float(values.mean())
    sd, df, own = noise.get(t.response, (float("nan"), 0, 0))
    half = float(stats.t.ppf(0.975, df) * sd / math.sqrt(len(values))) if df > 0 else float("inf")
    inside = t.sd is None or abs(mean - t.mean) <= t.sd
    narrow = t.sd is None or half < t.sd
    s.history.append(Step(s.iteration, s.box.index, "production", s.new,
                          f"{loop.production} x{len(values)}{_where(s)}: {mean:.2f} ± {half:.2f} (95 %; "
                          + (f"seed sd {sd:.2f} pooled over the production points"
                             + (" and the stored study's" if own < df else "")
                             + f", df {df}" + (f" ({own} the campaign's own)" if 0 < own < df else "")
                             if df > 0 else "seed sd not known yet: no production point has two runs")
                          + f") against {t.mean:g} ± {t.sd if t.sd is not None else float('nan'):g}",
                          predicted=s.predicted[t.response], simulated=mean, half_width=half,
                          discrepancy=s.disc[t.response].describe(), point=dict(s.chosen)))
    return t, mean, half, inside, narrow, sd


def _where(s: LoopState) -> str:
    """Where a point on the path lies, as a production line says it ("" for a solved point)."""
    pending, index = s.pending, s.box.index
    if pending is None:
        return ""
    if pending.limit is not None:
        return f" at the end of the path from box {index} (step {pending.steps[0]}, at the parameters' limits)"
    if pending.nearest:
        return (f" on the path from box {index} (step {pending.steps[0]}, its nearest to the target, read "
                f"{pending.reading:.2f} inside the lab window)")
    return f" on the path from box {index} (between steps {pending.steps[0]} and {pending.steps[1]})"


def _verified_where(s: LoopState) -> str:
    """Where a verified point on the path lies, as the stop's reason says it."""
    pending = s.pending
    if pending is None:
        return ""
    return (f", at {'the end of' if pending.limit is not None else 'a point on'} the path of steepest "
            f"{'ascent' if pending.sign > 0 else 'descent'} from box {s.box.index}"
            + (", where the parameters' limits stop it short of the lab mean" if pending.limit is not None else
               ", its step nearest the lab mean, which it did not cross" if pending.nearest else "")
            + " (no design was laid around it, so there is no solution set)")


def _more_replicates(loop: Loop, s: LoopState, found: list, noise: dict):
    """Inside, but not yet sure: more replicates where the noise asks for them."""
    cfg = loop.cfg
    if s.replicates >= cfg.max_replicates:
        t, mean, half, *_ = next(v for v in found if not v[4])
        return Stop(NOISE, f"{t.response}: the mean {mean:.2f} is inside the lab spread, but its 95 % "
                    f"interval ± {half:.2f} is not narrower than the lab sd {t.sd:g} after "
                    f"{s.replicates} replicates; raise [calibration] max_replicates")
    need = s.replicates + 1
    for t, mean, half, inside, narrow, sd in found:
        if not narrow and t.sd:
            df = noise.get(t.response, (float("nan"), 0, 0))[1]
            if df < 1 or not np.isfinite(sd):  # a probe inside the band: what replicates asks for
                need = max(need, loop.first_replicates)
            else:
                need = max(need, replicates_needed(sd, df, s.replicates, t.sd, cfg.max_replicates))
    s.asked = min(cfg.max_replicates, need)
    s.replicates = batched(need, s.replicates, cfg.replicate_batch, cfg.max_replicates)
    return Next("production")


def _missed_on_path(loop: Loop, s: LoopState, t, mean: float):
    """The point on the path missed: the result no longer names it (nor an older solve's);
    lay the box the classic method lays, unless no further move is to be made."""
    pending = s.pending
    if pending.limit is not None:  # the path's best point at the limits, measured and missed
        reason = f"{pending.limit}; its production runs there gave {mean:.2f}, outside {t.mean:g} ± {t.sd:g}"
        if not all(in_window(*m) for m in s.misses):
            return Stop(OUT_OF_REACH, reason)
    s.on_path = s.best = s.optimization = None
    s.prod, s.specs = [], []
    s.pending = None
    if pending.limit is not None:
        # the box still reaches into the window: solved at its edge after all
        s.turned = ("the parameters' limits stop the path from it", reason)
        return Next("fit")
    # with what the point taught in the discrepancy
    if (back := turned_back(pending, s.boxes, s.box, t, loop.condition, missed=not pending.nearest)) is not None:
        s.notes.append(back)
        s.turned = ("a path turned back", back)
        return Next("fit")
    s.laying = pending.box
    return Next("design")


#: state name -> the function that takes the loop on from it
STATES: dict[str, Callable[[Loop, LoopState], Next | Stop]] = {
    "fit": fit, "path": path, "crossing": crossing, "design": design, "box": new_box, "solve": solve,
    "production": production, "verdict": verdict}
