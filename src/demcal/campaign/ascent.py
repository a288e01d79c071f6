"""The path of steepest ascent (or descent) the calibration loop follows out of a box
(:mod:`demcal.campaign.loop`, step 2): laid from the box centre along the corrected
surface's gradient, its points simulated at the cheap profile and read at the
production one, and where it meets the target (Montgomery, *Design and Analysis of
Experiments*, §11.2; Myers, Montgomery & Anderson-Cook, *Response Surface Methodology*,
ch. 5)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from demcal._checks import significant
from demcal.campaign.box import INSIDE_TOL, Box, box_parameters, clean
from demcal.campaign.discrepancy import CorrectedSurface
from demcal.campaign.outcome import OUT_OF_REACH, Step, show
from demcal.campaign.seeds import PATH_SEED
from demcal.campaign.store import RunRecord, RunSpec

#: the words every "the limits stop the path" reason carries (the loop tells those stops
#: from a flat model's by them)
AT_LIMITS = "within the parameters' physical limits"


@dataclass(frozen=True)
class PathEnd:
    """Where a path of steepest ascent (or descent) met its target: the new box around
    the crossing (its design not yet run) and, when two path points bracket the target,
    the crossing point itself, read off the path by linear interpolation between them
    (where the production reading meets the target): its parameters and the cheap
    response there. With ``limit`` set it is instead the path's best point where the
    parameters' limits stopped it short of the target (:func:`end_in_reach`): ``box`` is
    then the box the path left (no move), ``steps`` that step twice and ``reading`` its
    production reading. With ``nearest`` set the path crossed nothing and the point is its
    step nearest the target, read inside the lab window (:func:`_nearest_in_window`):
    ``box`` is the box the classic method would lay next, ``reading`` the step's
    production reading."""

    box: Box
    response: str
    sign: float  #: +1 ascent, -1 descent
    point: dict[str, float] | None = None
    cheap: float = float("nan")
    steps: tuple = ()  #: the path steps the point lies between (1 = the box's model at its edge)
    #: why the path stopped at the parameters' limits short of the target, when the point
    #: is its best simulated step, measured because the lab window is within its noise
    limit: str | None = None
    reading: float = float("nan")  #: the path's production reading at the point
    #: the path crossed nothing, and the point is its step nearest the target, read
    #: inside the lab window (:func:`_nearest_in_window`); ``box`` is the moved box
    nearest: bool = False


@dataclass(frozen=True)
class SteepestPath:
    """A path laid from the centre of ``box`` toward ``target``, before its runs: its
    points in the box's coded units (step ``ks[i]`` at ``points[i]``; step 1 lies in the
    box, the model predicts it) and the cheap runs of the steps beyond it."""

    box: Box
    model: Any  #: the corrected surface (what the production profile gives)
    target: float  #: the lab's mean
    lo: float  #: what the box reaches
    hi: float
    sign: float  #: +1 ascent, -1 descent
    grad: np.ndarray  #: the signed gradient at the box centre [coded]
    coded_lo: np.ndarray  #: the physical limits in the box's coded units
    coded_hi: np.ndarray
    points: list
    ks: list
    specs: list  #: the cheap runs of steps ``ks[1:]``, ``path_replicates`` seeds each
    where: list  #: the step of each spec

    @property
    def way(self) -> str:
        return "ascent" if self.sign > 0 else "descent"


def lay_path(campaign, condition, box: Box, model, target: float, lo: float, hi: float, limits: np.ndarray,
             cfg, cheap: str) -> SteepestPath | tuple[str, str]:
    """The path of steepest ascent (or descent) from ``box`` toward ``target``, or
    ``(status, reason)`` where none leads on (a flat model, limits that stop it at once).

    ``model`` is the corrected surface (what the production profile gives) and
    ``target`` the lab's mean, while the path points run at the cheap profile
    (:func:`read_path` reads them at the production profile). The projected path: a
    factor at its limit stops; the others go on, rescaled so the fastest free factor
    still moves one half-width per step."""
    k = len(campaign.factors)
    sign = 1.0 if target > hi else -1.0
    grad = sign * np.asarray(model.gradient(np.zeros(k)), float)
    coded_lo = (limits[:, 0] - box.centre) / box.half
    coded_hi = (limits[:, 1] - box.centre) / box.half
    if np.max(np.abs(grad)) < 1e-12:
        return OUT_OF_REACH, (f"the model is flat at the centre of box {box.index}, so no path leads toward "
                              f"{condition.targets[0].response} = {target:g}")
    points, ks, x = [], [], np.zeros(k)
    for j in range(1, cfg.path_points + 2):
        free = ~(((x >= coded_hi - 1e-9) & (grad > 0)) | ((x <= coded_lo + 1e-9) & (grad < 0)))
        g = np.where(free, grad, 0.0)
        if np.max(np.abs(g)) < 1e-12:
            break  # every factor that moves the response is at a limit
        x = np.clip(x + g / np.max(np.abs(g)), coded_lo, coded_hi)
        if j > 1 and np.all(np.abs(x) <= 1 + INSIDE_TOL):
            break  # held inside the box the model already covers
        points.append(x.copy())
        ks.append(j)
    from demcal.campaign.runner import point_settings

    specs, where = [], []
    for j, x in zip(ks[1:], points[1:]):
        params = box_parameters(campaign, box, x, limits)
        for r in range(cfg.path_replicates):
            seed = campaign.seed + PATH_SEED + 997 * box.index + 10 * j + r
            specs.append(RunSpec("path", f"path box {box.index} step {j}" + (f" r{r + 1}" if r else ""),
                                 campaign.test, cheap, params, point_settings(campaign, params), seed))
            where.append(j)
    if not specs:
        return OUT_OF_REACH, (f"{model.response} = {target:g} lies beyond what the test reaches {AT_LIMITS}: they "
                              f"stop the path of steepest {'ascent' if sign > 0 else 'descent'} from box "
                              f"{box.index} at once")
    return SteepestPath(box, model, target, lo, hi, sign, grad, coded_lo, coded_hi, points, ks, specs, where)


def _readings(path: SteepestPath, done: Sequence[RunRecord], cheap: str, production: str):
    """``(measured, ys, cheap_ys, said)``: each simulated step's mean cheap response, the
    path read at the production profile (``ys[0]`` the box's model at step 1; the
    discrepancy at each point added when the profiles differ: the crossing is where the
    *production* response meets the lab, not where the cheap one does), the cheap
    readings, and how a history line says them."""
    model, response = path.model, path.model.response
    by_step: dict[int, list[float]] = {}
    for j, rec in zip(path.where, done):
        if rec.status == "done" and response in rec.responses:
            by_step.setdefault(j, []).append(float(rec.responses[response]))
    measured = [float(np.mean(by_step[j])) if j in by_step else np.nan for j in path.ks[1:]]
    shift = [0.0] * len(measured)
    if production != cheap and isinstance(model, CorrectedSurface):
        shift = [float(model.predict(x)) - float(model.model.predict(x)) for x in path.points[1:]]
    ys = [float(model.predict(path.points[0]))] + [m + d for m, d in zip(measured, shift)]
    said = ", ".join(f"{y:.2f}" for y in measured)
    if any(shift):
        said += (f" at the {cheap} profile, read as " + ", ".join(f"{y:.2f}" for y in ys[1:])
                 + f" at the {production} profile (the discrepancy there added)")
    cheap_ys = [float(getattr(model, "model", model).predict(path.points[0]))] + measured
    return measured, ys, cheap_ys, said


def _crossing(path: SteepestPath, ys):
    """``(crossing, bracket)``: where the path's readings first reach the target (coded;
    None if nowhere) and, when the readings at two points bracket it, ``(below, i, frac)``."""
    sign, target, points = path.sign, path.target, path.points
    for i in range(1, len(ys)):
        if np.isfinite(ys[i]) and sign * (ys[i] - target) >= 0:
            a = ys[i - 1] if np.isfinite(ys[i - 1]) else ys[0]
            frac = 1.0 if ys[i] == a else float(np.clip((target - a) / (ys[i] - a), 0.0, 1.0))
            crossing = points[i - 1] + frac * (points[i] - points[i - 1])
            # bracketed by two values read at the points themselves
            return crossing, ((i - 1, i, frac) if np.isfinite(ys[i - 1]) else None)
    return None, None


def read_path(campaign, condition, path: SteepestPath, done: Sequence[RunRecord], new: int, limits: np.ndarray,
              cfg, cheap: str, production: str, moves: int, history: list, iteration: int):
    """Read the path's runs (``done``; ``new`` of them not asked for before), add its line
    to ``history``: the :class:`PathEnd` to go on from, or ``(status, reason)`` when the
    loop must stop."""
    box, target, sign, points, ks = path.box, path.target, path.sign, path.points, path.ks
    measured, ys, cheap_ys, said = _readings(path, done, cheap, production)
    history.append(Step(iteration, box.index, "path", new,
                        f"target {target:g} outside box {box.index} ({path.lo:.2f} to {path.hi:.2f}); steepest "
                        f"{path.way} gave " + said + f" at steps {', '.join(map(str, ks[1:]))}",
                        point={f.parameter: significant(v, 4)
                               for f, v in zip(campaign.factors, box.to_actual(points[-1]))}))
    crossing, bracket = _crossing(path, ys)
    nearest = None  # the step to verify when the path crosses nothing (_nearest_in_window)
    crossed = crossing is not None
    if crossing is None:
        if _at_limit(path) or len(points) < cfg.path_points + 1:
            best = np.nanmax(ys) if sign > 0 else np.nanmin(ys)
            reason = (f"{path.model.response} = {target:g} lies beyond what the test reaches {AT_LIMITS}: the "
                      f"steepest path from box {box.index} ends at the limits at {best:.2f}")
            end = end_in_reach(campaign, condition, path, ys, measured, limits, cfg, reason)
            return (OUT_OF_REACH, reason) if end is None else end
        nearest = _nearest_in_window(condition, path.model.response, sign, ys, cfg)
        if nearest is None and _gains_nothing(path, ys):
            return OUT_OF_REACH, _peaks_in_box(path, ys)
        crossing = points[-1]
    point = None
    if bracket is not None and not np.all(np.abs(crossing) <= 1 + INSIDE_TOL):
        below, i, frac = bracket
        point = box_parameters(campaign, box, crossing, limits)
        cheap_at = cheap_ys[below] + frac * (cheap_ys[i] - cheap_ys[below])
        steps = (ks[below], ks[i])
    if np.all(np.abs(crossing) <= 1 + INSIDE_TOL):  # no further than the box itself
        crossing = points[-1]
    how = "crossed it near " if crossed else "ran its length toward it without crossing it, ending near "
    moved = _moved_box(campaign, path, crossing, limits, moves, how)
    response = path.model.response
    if point is None:
        if nearest is not None:
            return PathEnd(moved, response, sign, box_parameters(campaign, box, points[nearest], limits),
                           float(measured[nearest - 1]), (ks[nearest], ks[nearest]), reading=float(ys[nearest]),
                           nearest=True)
        return PathEnd(moved, response, sign)
    return PathEnd(moved, response, sign, point, float(cheap_at), steps)


def _at_limit(path: SteepestPath) -> bool:
    """Whether every factor that moves the response is at its limit at the path's end."""
    last, grad = path.points[-1], path.grad
    return not np.any((np.abs(grad) > 1e-12) & ~(((last >= path.coded_hi - 1e-9) & (grad > 0))
                                                   | ((last <= path.coded_lo + 1e-9) & (grad < 0))))


def _peaks_in_box(path: SteepestPath, ys) -> str:
    """Why no box is laid beyond a box whose path reads no further toward the target than
    the box itself reaches (:func:`_gains_nothing`)."""
    box, sign = path.box, path.sign
    edge = path.hi if sign > 0 else path.lo
    return (f"{path.model.response} = {path.target:g}: the path of steepest {path.way} from box {box.index} "
            f"reads {', '.join(f'{y:.2f}' for y in ys[1:] if np.isfinite(y))} beyond the box, no "
            f"{'higher' if sign > 0 else 'lower'} than box {box.index} reaches itself ({edge:.2f}): the "
            f"response peaks in box {box.index}, so no box is laid beyond it and the target lies beyond "
            f"what the test reaches")


def _moved_box(campaign, path: SteepestPath, crossing, limits: np.ndarray, moves: int, how: str) -> Box:
    """The next box, of the original half-widths, around ``crossing`` (held inside the limits)."""
    box = path.box
    centre = box.to_actual(crossing)
    half0 = np.array([0.5 * (f.high - f.low) for f in campaign.factors])
    half = np.minimum(half0, 0.5 * (limits[:, 1] - limits[:, 0]))
    centre = np.clip(centre, limits[:, 0] + half, limits[:, 1] - half)
    return Box(box.index + 1, tuple(clean(centre - half, limits)), tuple(clean(centre + half, limits)),
               reason=(f"move {moves + 1}: {path.model.response} target {path.target:g} outside box {box.index} "
                       f"({path.lo:.2f} to {path.hi:.2f}); the steepest path " + how
                       + show({f.parameter: significant(c, 3) for f, c in zip(campaign.factors, centre)})))


def _gains_nothing(path: SteepestPath, ys) -> bool:
    """Whether no simulated step of the path reads further toward the target than the
    box itself reaches (its model's reach ``path.hi`` on an ascent, ``path.lo`` on a
    descent; ``ys[0]`` is the model at step 1 and does not count).

    The classic method follows a path only while its response keeps rising (Montgomery,
    *Design and Analysis of Experiments*, 8th ed., §11.2: experiments are run along the
    path "until no further increase in response is observed"); a path that finds nothing
    beyond what its box already reaches has found the response's peak in that box, and
    a box laid at its end would be laid where the response is lower. (The demo's quick
    14.1 % repose path from box 0, whose model reaches 38.25 deg, read 37.10, 34.36 and
    31.10 deg at steps 2-4; the loop laid a 29-run box at step 4, 28 Nov 2026.)"""
    edge = path.hi if path.sign > 0 else path.lo
    read = [path.sign * y for y in ys[1:] if np.isfinite(y)]
    return bool(read) and max(read) <= path.sign * edge


def _nearest_in_window(condition, response: str, sign: float, ys, cfg) -> int | None:
    """The path step to verify when the path ran its length without crossing the lab mean,
    or None: its simulated step nearest the target in the target's direction (the
    highest reading on an ascent), when that reading lies inside the lab window.

    The verification accepts any production mean inside the window, so a path that
    reaches into it has found what the classic method's next box would be laid to find:
    the point is measured at the production profile first, and the box laid around the
    path's end only if it misses (as after a missed crossing). (The paper-profile 14.1 %
    sliding path from box 1 read 27.81, 30.39 and 28.84 at steps 2-4, inside 30.46 ±
    3.2 and 0.07 short of its mean; a 34-run box laid at step 4 reached 27.19 at most.)"""
    best = _best_step(condition, response, sign, ys, cfg)
    if best is None:
        return None
    target, i = best
    return i if abs(ys[i] - target.mean) <= target.sd else None


def _best_step(condition, response: str, sign: float, ys, cfg):
    """``(target, i)``: the condition's one lab target (with an sd) and the path's simulated
    step read furthest toward it (``ys[0]`` is the box's own model), for verifying on the
    path; None where the loop verifies only solved points or nothing was simulated."""
    target = next((t for t in condition.targets if t.response == response), None)
    if not cfg.verify_on_path or len(condition.targets) != 1 or target is None or not target.sd:
        return None
    simulated = [i for i in range(1, len(ys)) if np.isfinite(ys[i])]
    if not simulated:
        return None
    return target, max(simulated, key=lambda j: sign * ys[j])


def end_in_reach(campaign, condition, path: SteepestPath, ys, measured, limits, cfg, reason) -> PathEnd | None:
    """The path's best simulated point as a :class:`PathEnd` to verify, when the path ends
    at the parameters' limits without crossing the target but that point's production
    reading lies within its own 95 % noise of the lab window; else None.

    Such a reading may be the window's edge met within the noise (the paper-sized incline
    saturates at 27-28 deg with the 14.1 % particles, where that target's window starts
    at 27.26): whether the test reaches the window is then a question for the production
    profile, not for one cheap run, so the loop measures it there before it calls the
    target out of reach. The noise is the box model's residual sd (one cheap run's scatter
    about the surface) with the discrepancy's standard error."""
    model, sign = path.model, path.sign
    best = _best_step(condition, model.response, sign, ys, cfg)
    if best is None:
        return None
    target, i = best
    se = 0.0
    if isinstance(model, CorrectedSurface):  # the discrepancy's sd at the point (box-0 coded)
        se = float(model.discrepancy(model.to_box0(path.points[i]))[1])
        se = se if np.isfinite(se) else 0.0
    noise = 1.96 * math.sqrt(max(float(getattr(model, "mse", 0.0)), 0.0) + se * se)
    edge = target.mean - sign * target.sd
    if sign * (ys[i] - edge) < -noise:
        return None
    point = box_parameters(campaign, path.box, path.points[i], limits)
    return PathEnd(path.box, model.response, sign, point, float(measured[i - 1]), (path.ks[i], path.ks[i]),
                   limit=reason, reading=float(ys[i]))


def turned_back(end: PathEnd, boxes: Sequence[Box], box: Box, target, condition, missed: bool = False) -> str | None:
    """Why no box is laid where the path ended, or None.

    A path that ends inside a box the loop has already been in has turned back: the
    gradient of the box it left points the way it came, because the response peaks
    between the two (the paper-profile incline saturates near 27-28 deg at mu' 0.9-1.1
    with the 14.1 % particles: the box beyond the peak sends the path back to the box
    before it, whose path sends it out again). Laying that box again would repeat its
    design with new seeds; the loop instead makes no further move and treats the box it
    is in as the last one (solved at its edge when it reaches into the lab window, else
    out of reach)."""
    centre = end.box.centre
    # (the box the path left does not count: a path held at the parameters' limits may
    # end with its new box overlapping the old one, which is no turn)
    back = next((b for b in boxes if b.index != box.index and np.all(np.abs(b.to_coded(centre)) <= 1 + INSIDE_TOL)),
                None)
    if back is None:
        return None
    way = "ascent" if end.sign > 0 else "descent"
    how = (f"crossing {target.response} = {target.mean:g} where the production runs missed it" if missed
           else f"without crossing {target.response} = {target.mean:g}")
    return (f"{condition.name}: the path of steepest {way} from box {box.index} turns back into box {back.index} "
            f"{how} (its new box would lie inside box {back.index}): the response peaks between them, so no "
            f"further move is made and box {box.index} is the last; the target lies beyond what the test "
            f"reaches along the paths")
