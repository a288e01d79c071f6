"""The closed calibration loop: move the box, correct between fidelities, verify.

``demcal calibrate`` runs one loop per condition (paper §2.3 and §3.2 made a loop), on
that condition's campaign (:meth:`~demcal.campaign.config.Campaign.for_condition`): a
condition with fixed settings of its own (``[conditions.settings]``, ``from_campaign``)
starts from its own design, and every run its loop asks for -- path points, moved
boxes' designs, production runs -- carries those settings:

1. **Fit and solve** the campaign's response model on the cheap profile's runs inside
   the current box (box 0 is the campaign's own design). The target the cheap model
   must meet is the lab's mean minus the *discrepancy* between the production profile
   and the cheap model: until production runs exist, the bias measured between the two
   profiles in a bench study and stored with them (:mod:`demcal.bench.profiles`, e.g.
   ``quick`` -> ``paper``) where one applies to the campaign's settings, else zero. A
   stored bias that is linear in a material value (the funnel's, in the rolling
   friction) keeps its slope after production runs exist; they set its level.
2. **Move the box** when that target lies outside what the model reaches in the box
   by more than half the lab sd (a box that reaches the middle half of the lab's
   window is solved where it is, at its edge: the verification accepts any mean inside
   the window, and a move costs a path and a new design):
   the classic path of steepest ascent (or descent) from the box centre, along the
   model's gradient there in coded units, scaled so the factor with the largest effect
   moves one half-width per step (Montgomery, *Design and Analysis of Experiments*,
   §11.2; Myers, Montgomery & Anderson-Cook, *Response Surface Methodology*, ch. 5).
   Each parameter stays inside its physical limits (the bench setting's range,
   restitution in (0, 1], and the factor's ``hard_low`` / ``hard_high``); a factor at
   its limit stops moving and the others go on (the projected path). Points beyond the
   box edge are simulated at the cheap profile; where the simulated response, read at
   the production profile (the discrepancy at each point added), crosses the target,
   a new design of the campaign's kind is laid around that point (the original
   half-widths), and every earlier cheap design or path run inside the new box is
   fitted with it. Where two path points bracket the target, the crossing is
   verified first (``verify_on_path``) and the box is laid only if it misses. A path
   that crosses nothing lays its box around the step read furthest toward the target
   (:func:`_peak`), and none where every step reads worse than the box's own edge. When the
   path ends at the limits without crossing, the condition stops: the target is out of
   the test's reach, unless the lab window lies within the noise of the path's best
   point, which is then measured at the production profile first (verified there, or
   out of reach with that figure: :func:`_end_in_reach`); when it turns back into an
   earlier box (the response peaks between them), no further move is made
   (:func:`_turned_back`).
3. **Production runs** at the solution nearest the box centre, with replicates (their
   seed-to-seed sd, pooled over every production point, is the noise, with the stored
   profile studies' replicated production runs pooled in where they measured this
   test's production profile: :func:`stored_noise`; once it is known, a new point's
   first batch is the fewest replicates it says are enough, between
   ``min_replicates`` and ``replicates``: :func:`first_batch`). While nothing is
   known of the discrepancy (the first point of a campaign whose production profile is
   not its cheap one) a single run probes it first: if it lands outside the lab band,
   the loop re-solves with what it taught instead of replicating a point it will leave. The
   discrepancy ``production - cheap model`` is modelled as an additive bias with its
   standard error, and, once there are ``k + 2`` distinct production points, as a
   Gaussian process in the coded factors (scikit-learn's
   ``GaussianProcessRegressor``, a constant x RBF kernel plus white noise) around that
   bias. The model is re-solved on the corrected surface and the loop repeats.
4. **Stop** when the production mean at the chosen parameters lies inside the lab's
   mean +- sd and the half-width of its 95 % interval (Student t, pooled sd) is below
   the lab sd -- more replicates are run while the mean is inside but the interval is
   not narrow enough -- or when ``[calibration] iterations`` or
   ``max_replicates`` are spent, the ``[budget]`` is spent, or the target is out of
   reach. Each stop says why in one sentence.

Every decision is a deterministic function of the runs in the store (fits, seeded
searches, seeds derived from the point and replicate), so a loop that is interrupted
replays to where it was and runs only what is missing, and ``demcal report`` replays it
without running anything.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd

from demcal._checks import significant
from demcal.campaign.config import Campaign, Condition
# pooled_sd: demcal.report.benchmark imports it from here
from demcal.campaign.noise import pooled_sd, production_noise, stored_noise  # noqa: F401
from demcal.campaign.seeds import BOX_SEED, PATH_SEED
from demcal.campaign.solve import fit_models, round_parameter, solve_condition
from demcal.campaign.store import RunRecord, RunSpec

#: A point counts as inside a box up to this far beyond its coded edge.
INSIDE_TOL = 1e-6
#: the words every "the limits stop the path" reason of :func:`_move` carries (the loop
#: tells those stops from a flat model's by them)
AT_LIMITS = "within the parameters' physical limits"

#: Why a condition's loop ended.
VERIFIED, OUT_OF_REACH, BUDGET, ITERATIONS, NOISE, UNFINISHED, NOT_VERIFIED = (
    "verified", "out of reach", "budget spent", "iterations spent", "noise", "unfinished", "not verified")


@dataclass(frozen=True)
class Box:
    """A design box in actual units; box 0 is the campaign's own."""

    index: int
    low: tuple[float, ...]
    high: tuple[float, ...]
    reason: str = "the campaign's design box"

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.low) + np.asarray(self.high))

    @property
    def half(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.high) - np.asarray(self.low))

    def campaign(self, campaign: Campaign, replicates: int | None = None) -> Campaign:
        """The campaign with this box's factor levels (and its own design seeds), with
        ``replicates`` seeds per design point if given (a moved box: ``[calibration]
        box_replicates``)."""
        if self.index == 0:
            return campaign
        factors = tuple(dataclasses.replace(f, low=significant(lo), high=significant(hi))
                        for f, lo, hi in zip(campaign.factors, self.low, self.high))
        return dataclasses.replace(campaign, factors=factors, seed=campaign.seed + BOX_SEED * self.index,
                                   replicates=replicates or campaign.replicates)

    def to_coded(self, actual) -> np.ndarray:
        return (np.asarray(actual, float) - self.centre) / self.half

    def to_actual(self, coded) -> np.ndarray:
        return self.centre + np.asarray(coded, float) * self.half

    def to_dict(self, campaign: Campaign) -> dict[str, Any]:
        return {"index": self.index, "reason": self.reason,
                "low": {f.parameter: significant(v) for f, v in zip(campaign.factors, self.low)},
                "high": {f.parameter: significant(v) for f, v in zip(campaign.factors, self.high)}}


def _parameters(campaign: Campaign, box: Box, coded, limits: np.ndarray) -> dict[str, float]:
    """The campaign's factor settings at a point in ``box``'s coded units, held inside the
    physical limits and rounded as the store keys them."""

    actual = _clean(box.to_actual(coded), limits)
    return {f.parameter: round_parameter(v) for f, v in zip(campaign.factors, actual)}


def _clean(values, limits: np.ndarray) -> np.ndarray:
    """Actual values clipped to their limits and rid of binary noise (-2.8e-17 -> 0)."""
    return np.clip(np.round(np.asarray(values, float), 10), limits[:, 0], limits[:, 1]) + 0.0


def physical_limits(campaign: Campaign, profile: str) -> np.ndarray:
    """``(k, 2)`` limits of each factor in actual units: the bench setting's range,
    restitution in (0, 1], and the factor's ``hard_low`` / ``hard_high``."""
    from demcal.bench.registry import get_experiment

    table = get_experiment(campaign.test).settings(profile)
    out = []
    for f in campaign.factors:
        setting = table[f.parameter]
        lo = -math.inf if setting.low is None else float(setting.low)
        hi = math.inf if setting.high is None else float(setting.high)
        if "restitution" in f.parameter.rsplit(".", 1)[-1]:
            lo, hi = max(lo, 1e-3), min(hi, 1.0)
        if f.hard_low is not None:
            lo = max(lo, f.hard_low)
        if f.hard_high is not None:
            hi = min(hi, f.hard_high)
        out.append((lo, hi))
    return np.array(out, dtype=float)


def fit_box(campaign: Campaign, box: Box, records: Sequence[RunRecord], cheap: str, design_table=None):
    """Full and reduced models of the cheap runs inside ``box`` (box 0: its design only)."""

    boxed = box.campaign(campaign)
    if box.index == 0 and design_table is not None:
        table = design_table
    else:
        rows = []
        for r in campaign_runs(campaign, records, cheap, kinds=("design", "path")):
            x = _point(campaign, r)
            coded = box.to_coded(x)
            if np.all(np.abs(coded) <= 1 + INSIDE_TOL):
                row = {f.name: float(c) for f, c in zip(campaign.factors, coded)}
                row.update({name: r.responses.get(name, np.nan) for name in campaign.response_names})
                rows.append(row)
        table = pd.DataFrame(rows, columns=campaign.factor_names + campaign.response_names)
    return fit_models(boxed, table) + (table,)


def campaign_runs(campaign: Campaign, records: Sequence[RunRecord], profile: str | None = None,
                  kinds: tuple[str, ...] | None = None):
    """Done runs of this campaign's test with its fixed settings (and every factor set),
    at ``profile`` and of ``kinds`` when given."""
    params = {f.parameter for f in campaign.factors}
    fixed = dict(campaign.settings)
    for r in records:
        if (r.status != "done" or r.test != campaign.test or (profile is not None and r.profile != profile)
                or (kinds is not None and r.kind not in kinds) or not params <= set(r.parameters)):
            continue
        if {k: v for k, v in r.settings.items() if k not in params} != fixed:
            continue
        yield r


def _point(campaign: Campaign, record: RunRecord) -> np.ndarray:
    return np.array([float(record.parameters[f.parameter]) for f in campaign.factors])


class StoredPrior:
    """A stored profile bias (:class:`demcal.bench.profiles.ProfileBias`) on a campaign's
    box-0 coded units: ``to_settings`` maps a coded point to the settings the bias reads.

    The bias is linear in the settings and the settings in the coded units, so its mean
    is ``offset + slope . x0``; ``slope`` is None for a constant bias (or without
    ``to_settings``: then the bias is taken at its reference)."""

    def __init__(self, bias, to_settings: Callable[[np.ndarray], dict] | None = None, k: int = 0):
        self.bias, self.k = bias, k
        self._to = to_settings if to_settings is not None else (lambda x0: {})
        self.offset = float(bias.at(self._to(np.zeros(k)))[0])
        self.slope = None
        if getattr(bias, "terms", ()) and to_settings is not None:
            self.slope = np.array([bias.at(self._to(np.eye(k)[j]))[0] - self.offset for j in range(k)])

    def __call__(self, x0) -> tuple[float, float]:
        return tuple(float(v) for v in self.bias.at(self._to(np.asarray(x0, float))))

    def linear(self, pts0: np.ndarray) -> np.ndarray | float:
        """The slope part at box-0 coded points (0 for a constant bias)."""
        return 0.0 if self.slope is None else np.atleast_2d(pts0) @ self.slope

    def describe(self) -> str:
        return self.bias.describe()


class Discrepancy:
    """``production - cheap model`` as an additive bias (+ a Gaussian process once
    there are ``k + 2`` distinct production points).

    Each residual is a production run's response minus the cheap model of the box it
    was solved in, at its point (so a moved box keeps what earlier boxes learnt); the
    Gaussian process works in the coded units of the campaign's own box, box 0. A stored
    prior (:class:`StoredPrior`) is the discrepancy until residuals exist; a linear one
    keeps its slope after (the residuals are taken about it and set its level).
    """

    def __init__(self, residuals: Sequence[tuple[np.ndarray, float]], prior=None):
        if prior is not None and not isinstance(prior, StoredPrior):
            prior = StoredPrior(prior)
        self.n = len(residuals)
        self.kind = "none"
        self.bias, self.bias_se = 0.0, float("nan")
        self.gp = None
        self.distinct = 0
        self.prior = prior
        self.slope = prior.slope if prior is not None else None
        if not residuals:
            if prior is not None:  # a bias measured between the profiles (demcal.bench.profiles)
                self.kind = "stored"
                # its uncertainty at a new point: the model's se there and the points' scatter
                self.bias, self.bias_se = prior.offset, prior(np.zeros(prior.k))[1]
            return
        x = np.array([p for p, _ in residuals], dtype=float)
        res = np.array([r for _, r in residuals], dtype=float)
        if self.slope is not None:
            res = res - x @ self.slope
        self.kind = "additive"
        self.bias = float(res.mean())
        self.bias_se = float(res.std(ddof=1) / math.sqrt(len(res))) if len(res) > 1 else float("nan")
        distinct = np.unique(np.round(x, 6), axis=0)
        self.distinct = len(distinct)
        if len(distinct) >= x.shape[1] + 2:
            from sklearn.gaussian_process import GaussianProcessRegressor
            from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

            import warnings

            from sklearn.exceptions import ConvergenceWarning

            kernel = (ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(x.shape[1]), (0.1, 100.0))
                      + WhiteKernel(1.0, (1e-4, 1e2)))
            with warnings.catch_warnings():
                # a factor the discrepancy does not depend on drives its length scale to the
                # bound (flat along it): the expected answer, not a failed fit
                warnings.simplefilter("ignore", ConvergenceWarning)
                self.gp = GaussianProcessRegressor(kernel, normalize_y=False, random_state=0,
                                                   n_restarts_optimizer=2).fit(x, res - self.bias)
            self.kind = "gaussian process"

    def linear(self, pts0) -> np.ndarray | float:
        """The stored slope's part at box-0 coded points (0 without one)."""
        return 0.0 if self.prior is None else self.prior.linear(pts0)

    def __call__(self, coded0) -> tuple[float, float]:
        """Mean and standard deviation of the discrepancy at one point (box-0 coded)."""
        if self.kind == "stored":
            return self.prior(coded0)
        line = float(np.ravel(self.linear(coded0))[0]) if self.slope is not None else 0.0
        if self.gp is None:
            return self.bias + line, self.bias_se
        mean, sd = self.gp.predict(np.atleast_2d(coded0), return_std=True)
        return self.bias + line + float(mean[0]), float(sd[0])

    def describe(self) -> str:
        if self.kind == "none":
            return "no production run yet (discrepancy 0)"
        if self.kind == "stored":
            return f"no production run yet: {self.prior.describe()}"
        se = f" ± {self.bias_se:.2f}" if np.isfinite(self.bias_se) else ""
        text = f"additive bias {self.bias:+.2f}{se} from {self.n} production runs"
        if self.slope is not None:
            text += f" about the stored slope ({self.prior.describe()})"
        if self.gp is not None:
            text += f", Gaussian process over {self.distinct} points ({self.gp.kernel_})"
        return text


class CorrectedSurface:
    """A box's response surface plus the discrepancy: what the production profile gives."""

    def __init__(self, model, discrepancy: Discrepancy, box: Box | None = None, box0: Box | None = None):
        self.model, self.discrepancy = model, discrepancy
        self.factors, self.response = model.factors, model.response
        # box coded -> box-0 coded: x0 = x * scale + shift
        if box is None or box0 is None:
            self._scale, self._shift = 1.0, 0.0
        else:
            self._scale, self._shift = box.half / box0.half, (box.centre - box0.centre) / box0.half

    def __getattr__(self, name):  # everything else (to_actual, fit, ...) is the model's
        return getattr(self.model, name)

    @property
    def y(self) -> np.ndarray:
        """The fitted runs' responses, shifted by the discrepancy's bias and stored slope at
        their points (the optimiser's default limits)."""
        y = self.model.y + self.discrepancy.bias
        return y if self.discrepancy.slope is None else y + self._line(np.atleast_2d(self.model.x))

    def to_box0(self, coded):
        """Coded units of this box -> those of box 0 (the discrepancy's)."""
        return np.asarray(coded) * self._scale + self._shift

    def _gp(self, pts: np.ndarray) -> np.ndarray:
        return self.discrepancy.gp.predict(self.to_box0(pts))

    def _line(self, coded: np.ndarray):
        """The stored slope's part (box coded in, per point out), 0 without one."""
        if self.discrepancy.slope is None:
            return 0.0
        line = self.discrepancy.linear(self.to_box0(np.atleast_2d(coded)))
        return line[0] if coded.ndim == 1 else line

    def predict(self, coded):
        coded = np.asarray(coded, float)
        base = self.model.predict(coded) + self._line(coded)
        if self.discrepancy.gp is None:
            return base + self.discrepancy.bias
        extra = self.discrepancy.bias + self._gp(np.atleast_2d(coded))
        return base + (extra[0] if coded.ndim == 1 else extra)

    def gradient(self, coded):
        coded = np.asarray(coded, float)
        grad = self.model.gradient(coded)
        if self.discrepancy.slope is not None:
            grad = grad + self.discrepancy.slope * self._scale
        if self.discrepancy.gp is None:
            return grad
        pts = np.atleast_2d(coded)
        h = 1e-4
        g = np.zeros_like(pts)
        for j in range(pts.shape[1]):
            step = np.zeros(pts.shape[1])
            step[j] = h
            g[:, j] = (self._gp(pts + step) - self._gp(pts - step)) / (2 * h)
        return grad + (g[0] if coded.ndim == 1 else g)


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
    #: limits (:func:`_end_in_reach`) also ``limit`` (True) and ``reading`` (the path's
    #: production reading there), and ``steps`` is that step twice
    on_path: dict | None = None

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


#: ``run(specs, desc) -> records`` runs what is missing (or, replaying, only reads);
#: it returns None when a spec has no finished run and nothing may be run.
Runner = Callable[[list[RunSpec], str], "list[RunRecord] | None"]


def out_of_box(mean: float, sd: float | None, lo: float, hi: float) -> bool:
    """Whether a target calls for a box move: the box's reach ``[lo, hi]`` misses the
    middle half of the lab window ``mean +- sd`` (the mean itself without an sd). A box
    that reaches it is solved where it is: the verification accepts any mean inside the
    window, and a move costs a path and a new design."""
    near = 0.5 * sd if sd else 0.0
    return hi < mean - near or lo > mean + near


def in_window(target, lo: float, hi: float) -> bool:
    """Whether the box's reach ``[lo, hi]`` meets the lab window ``mean +- sd`` at all
    (a target without an sd: never, the window is its mean alone and out_of_box decides)."""
    return bool(target.sd) and hi >= target.mean - target.sd and lo <= target.mean + target.sd


def prior_on_box(bias, campaign: Campaign, condition: Condition, box0: Box, profile: str) -> StoredPrior:
    """A stored bias read at the settings of box-0 coded points: the bench's defaults at
    ``profile``, the campaign's and the condition's fixed settings, the factors' values."""
    from demcal.bench.registry import get_experiment

    try:
        base = {k: s.default for k, s in get_experiment(campaign.test).settings(profile).items()}
    except Exception:  # a plug-in without settings for this profile: the bias's reference
        base = {}
    base = {**base, **campaign.settings, **condition.fixed}
    names = [f.parameter for f in campaign.factors]

    def to_settings(x0):
        return {**base, **dict(zip(names, box0.to_actual(x0)))}

    return StoredPrior(bias, to_settings, len(names))


def stored_priors(campaign: Campaign, cheap: str, production: str) -> dict:
    """Response -> the bias measured between ``cheap`` and ``production`` for the campaign's
    test (:mod:`demcal.bench.profiles`), where one applies to its fixed settings."""
    from demcal.bench import profiles

    if cheap == production or profiles.applies(campaign.settings):
        return {}
    out = {}
    for name in campaign.response_names:
        bias = profiles.stored(campaign.test, name, cheap, production)
        if bias is not None:
            out[name] = bias
    return out


def run_condition(campaign: Campaign, condition: Condition, ci: int, *, cheap: str, production: str,
                  design_table: pd.DataFrame, run: Runner, records: Callable[[], list[RunRecord]],
                  residuals: dict[str, list] | None = None, seed: int = 0) -> LoopResult:
    """The loop for one condition (module docstring)."""
    from demcal.optimize import reachable_range

    cfg = campaign.calibration
    limits = physical_limits(campaign, cheap)
    priors = stored_priors(campaign, cheap, production)
    first_replicates = cfg.replicates or campaign.verification_replicates
    budget = Budget(campaign)
    responses = [t.response for t in condition.targets]
    noise_prior = stored_noise(campaign, production, responses)
    f0 = campaign.factors
    box = Box(0, tuple(f.low for f in f0), tuple(f.high for f in f0))
    boxes = [box]
    history: list[Step] = []
    notes: list[str] = []
    moves = 0
    replicates = asked = first_replicates  # asked: before the rounding to replicate_batch
    box0 = box
    on_box = {r: prior_on_box(b, campaign, condition, box0, cheap) for r, b in priors.items()}
    #: response -> [(box-0 coded point, production - cheap model)], shared by the conditions
    residuals = {} if residuals is None else residuals
    counted: set[str] = set()
    point_key = None

    def stop(status: str, reason: str, **state) -> LoopResult:
        return LoopResult(status=status, reason=reason, box=box, boxes=boxes, models=state.get("models", {}),
                          full=state.get("full", {}), removed=state.get("removed", {}),
                          discrepancy=state.get("disc", {}), best=state.get("best"),
                          optimization=state.get("optimization"), production=state.get("prod", []),
                          specs=state.get("specs", []), history=history, notes=notes,
                          cheap_target=state.get("cheap_target", {}), on_path=state.get("on_path"))

    iteration = 0
    state: dict[str, Any] = {}
    hold = None
    missed = None  # (point, target, mean) of the last production point outside the lab band
    pending: PathEnd | None = None  # a path crossing verified before its box's design is laid
    #: why no further move is made (a path turned back into an earlier box, or the limits
    #: stop it while the box reaches into the window): (phrase, the stop's reason)
    turned: tuple[str, str] | None = None
    while True:
        on_path = None
        if hold is None:  # else: the same point again, with more replicates
            full, models, removed, fit_notes, table = fit_box(campaign, box, records(), cheap, design_table)
            notes.extend(n for n in fit_notes if n not in notes)
            state.update(models=models, full=full, removed=removed)
            disc = {r: Discrepancy(residuals.get(r, []), on_box.get(r)) for r in responses}
            state["disc"] = disc
            centre0 = box0.to_coded(box.centre)
            cheap_target = {t.response: t.mean - disc[t.response](centre0)[0] for t in condition.targets}
            state["cheap_target"] = cheap_target
            # Reachability on the corrected surface.
            corrected = {r: CorrectedSurface(models[r], disc[r], box, box0) for r in responses}
            misses = []
            for t in condition.targets:
                lo, hi = reachable_range(corrected[t.response], seed=seed)
                if out_of_box(t.mean, t.sd, lo, hi):
                    misses.append((t, lo, hi))
            outside = misses[0] if misses else None
            if misses and (moves >= cfg.box_moves or turned) and all(in_window(*m) for m in misses):
                # No move left, but the box reaches into each lab window (not its middle
                # half): the verification accepts any mean inside the window, so solve at
                # the box's edge and verify there rather than stop.
                why = (f"{turned[0]}, so" if turned else f"the {cfg.box_moves} box moves allowed are spent and")
                for t, lo, hi in misses:
                    note = (f"{condition.name}: {why} box "
                            f"{box.index} reaches {t.response} {lo:.2f} to {hi:.2f} with the discrepancy, into "
                            f"the lab window {t.mean:g} ± {t.sd:g} but not its middle half: solved at the "
                            f"box's edge")
                    if note not in notes:
                        notes.append(note)
                outside = None
            if outside is not None:
                t, lo, hi = outside
                if turned is not None:
                    return stop(OUT_OF_REACH, turned[1], **state)
                if moves >= cfg.box_moves:
                    return stop(OUT_OF_REACH if cfg.box_moves == 0 else ITERATIONS,
                                f"the target {t.response} = {t.mean:g} lies outside what box {box.index} reaches "
                                f"({lo:.2f} to {hi:.2f} with the discrepancy) and the {cfg.box_moves} box moves "
                                f"allowed are spent; raise [calibration] box_moves or widen the factor levels",
                                **state)
                moved = _move(campaign, condition, box, corrected[t.response], t.mean, lo, hi, limits, run,
                              records, budget, history, iteration, moves, cheap, cfg, production)
                if isinstance(moved, tuple):
                    if moved[0] == OUT_OF_REACH and all(in_window(*m) for m in misses):
                        # no path leads on (the limits stop it, or the model is flat), but
                        # this box reaches into each lab window: solved at its edge, as when
                        # the moves are spent
                        why = ("the parameters' limits stop the path from it" if AT_LIMITS in moved[1]
                               else "no path leads on from it")
                        turned = (why, moved[1])
                        continue
                    return stop(*moved, **state)
                if moved.limit is None:  # (a path's end at the limits is measured, not moved to)
                    moves += 1
                if cfg.verify_on_path and moved.point is not None and len(condition.targets) == 1:
                    # The path crossed the target between two of its points: verify there
                    # first; the new box's design is laid only if that point misses.
                    pending = on_path = moved
                elif (back := _turned_back(moved, boxes, box, t, condition)) is not None:
                    notes.append(back)
                    turned = ("a path turned back", back)
                    continue
                else:
                    laid = _lay_box(campaign, moved.box, run, records, budget, history, iteration)
                    if isinstance(laid, tuple):
                        return stop(*laid, **state)
                    box = laid
                    boxes.append(box)
                    continue
            if on_path is not None:
                chosen = dict(on_path.point)
                coded = box.to_coded([chosen[f.parameter] for f in f0])
                predicted = {t.response: t.mean for t in condition.targets}  # where the path reads the target
                state["on_path"] = {"point": dict(chosen), "box": box.index, "steps": on_path.steps,
                                    "way": "ascent" if on_path.sign > 0 else "descent"}
                if on_path.limit is not None:  # the path's end at the limits, short of the target
                    state["on_path"].update(limit=True, reading=on_path.reading)
                    predicted = {on_path.response: on_path.reading}
                elif on_path.nearest:  # the path's step nearest the target, inside the lab window
                    state["on_path"].update(nearest=True, reading=on_path.reading)
                    predicted = {on_path.response: on_path.reading}
            else:
                # Solve on the corrected surface.
                best, optimization, solve_notes = solve_condition(box.campaign(campaign), corrected, condition,
                                                                  seed=seed)
                state.update(best=best, optimization=optimization)
                chosen = {f.parameter: round_parameter(float(best[f"actual:{f.name}"]))
                          for f in box.campaign(campaign).factors}
                coded = box.to_coded([chosen[f.parameter] for f in f0])
                predicted = {r: float(corrected[r].predict(coded)) for r in responses}
            key = tuple(sorted(chosen.items()))
            if missed is not None and key == missed[0]:
                # the re-solve returns the point that already missed: nothing learnt moves it
                t, mean = missed[1:]
                return stop(OUT_OF_REACH, f"{t.response}: the best point of box {box.index} on the corrected "
                            f"surface is the one whose production mean {mean:.2f} already misses {t.mean:g} ± "
                            f"{t.sd:g}, and what its runs taught does not move it: the target lies at the edge "
                            f"of what the test reaches here; widen the factor limits or raise "
                            f"[calibration] box_moves", **state)
            if key != point_key:
                # a new point: no run of it yet (a stop before they finish reports none,
                # not the last point's)
                state.update(prod=[], specs=[])
                noise = production_noise(campaign, records(), production, responses, noise_prior)
                point_key = key
                asked = first_batch(noise, condition.targets, first_replicates, cfg.min_replicates)
                if production != cheap and not any(residuals.values()):
                    # a probe: nothing is known of production - cheap yet (one run, never rounded up)
                    replicates = asked = min(asked, 1)
                else:
                    replicates = batched(asked, 0, cfg.replicate_batch, cfg.max_replicates)
        hold = None
        if replicates == 0:
            return stop(NOT_VERIFIED, "no production replicates are asked for ([verification] replicates = 0)",
                        **state)
        specs = _production_specs(campaign, condition, ci, chosen, production, replicates)
        if replicates > asked and budget.exceeded(records(), _missing(specs, records())):
            # the seeds the rounding to replicate_batch adds do not fit the budget: what the
            # noise asks for may
            replicates = asked
            specs = _production_specs(campaign, condition, ci, chosen, production, replicates)
        state["specs"] = specs
        for r in responses:  # a stored bias used beyond the points it was measured at
            d = disc[r]
            far = d.prior.bias.outside(specs[0].settings) if d.kind == "stored" and specs else []
            if far:
                note = (f"{condition.name}: the first production point lies outside the points the stored "
                        f"{cheap} → {production} bias of {r} was measured at (" + ", ".join(far)
                        + "): its run tests an extrapolation of that bias, and the loop learns the bias from it")
                if note not in notes:
                    notes.append(note)
        done, new, stopped = _spend(specs, f"{campaign.name} {condition.name} production",
                               f"the production runs at {_show(chosen)}", campaign, run, records, budget)
        if stopped:
            return stop(*stopped, **state)
        state["prod"] = done
        ok = [r for r in done if r.status == "done"]
        for rec in ok:  # what this point teaches about production - cheap
            if rec.key not in counted:
                counted.add(rec.key)
                x0 = box0.to_coded(_point(campaign, rec))
                for r in responses:
                    if r in rec.responses:
                        # on a path beyond the box, the cheap response measured along the path
                        # (interpolated), not the box's model extrapolated
                        cheap_here = (pending.cheap if pending is not None and r == pending.response
                                      else float(models[r].predict(coded)))
                        residuals.setdefault(r, []).append((x0, float(rec.responses[r]) - cheap_here))
        if len(ok) < len(done):
            failed = [r for r in done if r.status != "done"]
            return stop(NOT_VERIFIED, f"{len(failed)} production runs failed ({failed[0].label}: "
                        f"{failed[0].error}); rerun them with --retry-failed", **state)
        noise = production_noise(campaign, records(), production, responses, noise_prior)
        verdict = []
        for t in condition.targets:
            values = np.array([r.responses[t.response] for r in ok])
            mean = float(values.mean())
            sd, df, own = noise.get(t.response, (float("nan"), 0, 0))
            from scipy import stats

            half = float(stats.t.ppf(0.975, df) * sd / math.sqrt(len(values))) if df > 0 else float("inf")
            inside = t.sd is None or abs(mean - t.mean) <= t.sd
            narrow = t.sd is None or half < t.sd
            verdict.append((t, mean, half, inside, narrow, sd))
            where = ("" if pending is None else
                     f" at the end of the path from box {box.index} (step {pending.steps[0]}, at the parameters' "
                     f"limits)" if pending.limit is not None else
                     f" on the path from box {box.index} (step {pending.steps[0]}, its nearest to the target, read "
                     f"{pending.reading:.2f} inside the lab window)" if pending.nearest else
                     f" on the path from box {box.index} (between steps {pending.steps[0]} and "
                     f"{pending.steps[1]})")
            history.append(Step(iteration, box.index, "production", new,
                                f"{production} x{len(values)}{where}: {mean:.2f} ± {half:.2f} (95 %; "
                                + (f"seed sd {sd:.2f} pooled over the production points"
                                   + (" and the stored study's" if own < df else "")
                                   + f", df {df}" + (f" ({own} the campaign's own)" if 0 < own < df else "")
                                   if df > 0 else "seed sd not known yet: no production point has two runs")
                                + f") against {t.mean:g} ± {t.sd if t.sd is not None else float('nan'):g}",
                                predicted=predicted[t.response], simulated=mean, half_width=half,
                                discrepancy=disc[t.response].describe(), point=dict(chosen)))
        if all(v[3] and v[4] for v in verdict):
            return stop(VERIFIED, "the production mean lies inside the lab's mean ± sd and its 95 % "
                        "interval is narrower than the lab sd"
                        + (f", at {'the end of' if pending.limit is not None else 'a point on'} the path of steepest "
                           f"{'ascent' if pending.sign > 0 else 'descent'} from box {box.index}"
                           + (", where the parameters' limits stop it short of the lab mean" if pending.limit
                              is not None else
                              ", its step nearest the lab mean, which it did not cross" if pending.nearest else "")
                           + " (no design was laid around it, so there is no solution set)"
                           if pending is not None else ""), **state)
        if all(v[3] for v in verdict):
            # Inside, but not yet sure: more replicates where the noise asks for them.
            if replicates >= cfg.max_replicates:
                t, mean, half, *_ = next(v for v in verdict if not v[4])
                return stop(NOISE, f"{t.response}: the mean {mean:.2f} is inside the lab spread, but its 95 % "
                            f"interval ± {half:.2f} is not narrower than the lab sd {t.sd:g} after "
                            f"{replicates} replicates; raise [calibration] max_replicates", **state)
            need = replicates + 1
            for t, mean, half, inside, narrow, sd in verdict:
                if not narrow and t.sd:
                    df = noise.get(t.response, (float("nan"), 0, 0))[1]
                    if df < 1 or not np.isfinite(sd):  # a probe inside the band: what replicates asks for
                        need = max(need, first_replicates)
                    else:
                        need = max(need, replicates_needed(sd, df, replicates, t.sd, cfg.max_replicates))
            asked = min(cfg.max_replicates, need)
            replicates = batched(need, replicates, cfg.replicate_batch, cfg.max_replicates)
            hold = True
            continue
        t, mean, *_ = next(v for v in verdict if not v[3])
        missed = (point_key, t, mean)
        if pending is not None:
            if pending.limit is not None:  # the path's best point at the limits, measured and missed
                reason = (f"{pending.limit}; its production runs there gave {mean:.2f}, outside {t.mean:g} ± "
                          f"{t.sd:g}")
                if not all(in_window(*m) for m in misses):
                    return stop(OUT_OF_REACH, reason, **state)
            # the point on the path missed: the result no longer names that point (nor an
            # older solve's)
            for name in ("on_path", "best", "optimization"):
                state.pop(name, None)
            state.update(prod=[], specs=[])
            if pending.limit is not None:
                # the box still reaches into the window: solved at its edge after all
                turned = ("the parameters' limits stop the path from it", reason)
                pending = None
                continue
            # lay the new box's design around the crossing after all (the classic method),
            # with what the point taught in the discrepancy
            if (back := _turned_back(pending, boxes, box, t, condition, missed=not pending.nearest)) is not None:
                notes.append(back)
                turned = ("a path turned back", back)
                pending = None
                continue
            laid = _lay_box(campaign, pending.box, run, records, budget, history, iteration)
            if isinstance(laid, tuple):
                return stop(*laid, **state)
            box = laid
            boxes.append(box)
            pending = None
            continue
        iteration += 1
        if iteration >= cfg.iterations:
            return stop(ITERATIONS, f"{t.response}: the production mean {mean:.2f} still misses "
                        f"{t.mean:g} ± {t.sd:g} after {cfg.iterations} solves on the corrected surface; "
                        f"raise [calibration] iterations", **state)


def replicates_needed(sd: float, df: int, n: int, lab_sd: float, cap: int) -> int:
    """The fewest replicates ``m > n`` whose 95 % half-width, Student t with the pooled
    ``df`` grown by the new runs, falls below ``lab_sd`` at the current ``sd`` (``cap``
    if none up to it does): the whole batch at once, so the runs go in parallel instead
    of one per round. ``n`` runs already at the point: ``m - n`` more add as many degrees
    of freedom; at a new point (``n = 0``) its ``m`` runs add ``m - 1``."""
    from scipy import stats

    for m in range(n + 1, cap + 1):
        if stats.t.ppf(0.975, df + m - max(n, 1)) * sd / math.sqrt(m) < lab_sd:
            return m
    return cap


def batched(need: int, done: int, step: int, cap: int) -> int:
    """``need`` replicates at a point that has ``done``, the new runs rounded up to a
    multiple of ``step`` (``[calibration] replicate_batch``), at most ``cap``. With
    ``step`` the number of workers, a batch never leaves a worker idle: three runs on two
    workers take as long as four, and the fourth may save a later round of one run. The
    loop does not round a probe (one run where nothing is known of production - cheap),
    nor a batch whose extra seeds would pass the ``[budget] runs``."""
    return min(cap, done + -(-max(need - done, 0) // step) * step)


def first_batch(noise: dict[str, tuple], targets, first: int, least: int) -> int:
    """Replicates of the first batch at a new production point.

    ``first`` (``[calibration] replicates``) while the production noise is unknown: no
    point has two runs yet. Once ``noise`` (per response: the seed-to-seed sd pooled over
    the production points so far, and its df) is known, the fewest replicates, at least
    ``least`` (``min_replicates``) and at most ``first``, whose 95 % half-width falls
    below every target's lab sd: where production runs scatter little against the lab
    (the paper-profile incline: 0.5-1.2 deg against 2.6-3.2), one run decides a point
    instead of three. A point that lands inside the lab band with too wide an interval
    still gets more replicates (:func:`replicates_needed`)."""
    if first <= least:
        return first
    need = 0
    for t in targets:
        if t.sd is None:
            continue
        sd, df = noise.get(t.response, (float("nan"), 0))[:2]
        if df < 1 or not np.isfinite(sd):
            return first
        # the half-width only shrinks as m grows, so the fewest m >= 1, raised to least
        need = max(need, replicates_needed(sd, df, 0, t.sd, first))
    return first if need == 0 else max(need, least)  # no lab sd anywhere: nothing to size it by


def _production_specs(campaign, condition, ci, chosen, production, replicates) -> list[RunSpec]:
    from demcal.campaign.runner import point_settings

    settings = point_settings(campaign, chosen)
    return [RunSpec("verification", f"verify {condition.name} #{r + 1}", campaign.test, production, chosen,
                    settings, campaign.verification_seed + 1000 * ci + r) for r in range(replicates)]


def _spend(specs, desc, what, campaign, run, records, budget):
    """Run ``specs`` within the budget: ``(records, new, None)`` with ``new`` the runs the
    loop had not asked for before, or ``(None, 0, (status, reason))``."""
    new = _missing(specs, records())
    reason = budget.exceeded(records(), new)
    if reason:
        return None, 0, (BUDGET, reason)
    done = run(specs, desc)
    if done is None:
        return None, 0, (UNFINISHED, f"{what} are not done yet; run `demcal calibrate {campaign.path}` to finish them")
    return done, new, None


def _missing(specs, records) -> int:
    done = {r.key for r in records if r.status in ("done", "failed")}
    return len({s.key for s in specs} - done)


def _show(params: dict[str, float]) -> str:
    return ", ".join(f"{k} = {v:g}" for k, v in params.items())


def _move(campaign, condition, box, model, target, lo, hi, limits, run, records, budget, history, iteration,
          moves, cheap, cfg, production):
    """Follow the steepest path from ``box`` toward ``target``; the new box, or
    ``(status, reason)`` when the loop must stop.

    ``model`` is the corrected surface (what the production profile gives) and
    ``target`` the lab's mean, while the path points run at the cheap profile. When the
    two profiles differ, each path point's cheap response is therefore read at the
    production profile by adding the discrepancy there (the corrected surface minus the
    cheap model) before the target is looked for between them: the crossing is where
    the *production* response meets the lab, not where the cheap one does. (Before
    27 Nov 2026 the path compared the cheap responses with the lab target as they
    were: with the quick incline about 5 deg above the paper one, every move of the
    paper-profile 14.1 % calibration stopped short of the target.) When the two
    profiles are the same, the path points are production runs and count as measured."""
    k = len(campaign.factors)
    sign = 1.0 if target > hi else -1.0
    grad = sign * np.asarray(model.gradient(np.zeros(k)), float)
    coded_lo = (limits[:, 0] - box.centre) / box.half
    coded_hi = (limits[:, 1] - box.centre) / box.half
    if np.max(np.abs(grad)) < 1e-12:
        return OUT_OF_REACH, (f"the model is flat at the centre of box {box.index}, so no path leads toward "
                              f"{condition.targets[0].response} = {target:g}")
    # The projected path: a factor at its limit stops; the others go on, rescaled so the
    # fastest free factor still moves one half-width per step.
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
    # Step 1 lies in the box: the model predicts it; the rest are simulated.
    from demcal.campaign.runner import point_settings

    specs, where = [], []
    for j, x in zip(ks[1:], points[1:]):
        params = _parameters(campaign, box, x, limits)
        for r in range(cfg.path_replicates):
            seed = campaign.seed + PATH_SEED + 997 * box.index + 10 * j + r
            specs.append(RunSpec("path", f"path box {box.index} step {j}" + (f" r{r + 1}" if r else ""),
                                 campaign.test, cheap, params, point_settings(campaign, params), seed))
            where.append(j)
    response = model.response
    if not specs:
        return OUT_OF_REACH, (f"{response} = {target:g} lies beyond what the test reaches {AT_LIMITS}: they "
                              f"stop the path of steepest {'ascent' if sign > 0 else 'descent'} from box "
                              f"{box.index} at once")
    done, new, stopped = _spend(specs, f"{campaign.name} {condition.name} path", f"the path runs of box {box.index}",
                           campaign, run, records, budget)
    if stopped:
        return stopped
    by_step: dict[int, list[float]] = {}
    for j, rec in zip(where, done):
        if rec.status == "done" and response in rec.responses:
            by_step.setdefault(j, []).append(float(rec.responses[response]))
    measured = [float(np.mean(by_step[j])) if j in by_step else np.nan for j in ks[1:]]
    shift = [0.0] * len(measured)
    if production != cheap and isinstance(model, CorrectedSurface):
        shift = [float(model.predict(x)) - float(model.model.predict(x)) for x in points[1:]]
    ys = [float(model.predict(points[0]))] + [m + d for m, d in zip(measured, shift)]
    said = ", ".join(f"{y:.2f}" for y in measured)
    if any(shift):
        said += (f" at the {cheap} profile, read as " + ", ".join(f"{y:.2f}" for y in ys[1:])
                 + f" at the {production} profile (the discrepancy there added)")
    history.append(Step(iteration, box.index, "path", new,
                        f"target {target:g} outside box {box.index} ({lo:.2f} to {hi:.2f}); steepest "
                        f"{'ascent' if sign > 0 else 'descent'} gave " + said
                        + f" at steps {', '.join(map(str, ks[1:]))}",
                        point={f.parameter: significant(v, 4) for f, v in zip(campaign.factors, box.to_actual(points[-1]))}))
    cheap_ys = [float(getattr(model, "model", model).predict(points[0]))] + measured
    crossing, bracket = None, None
    for i in range(1, len(ys)):
        if np.isfinite(ys[i]) and sign * (ys[i] - target) >= 0:
            a = ys[i - 1] if np.isfinite(ys[i - 1]) else ys[0]
            frac = 1.0 if ys[i] == a else float(np.clip((target - a) / (ys[i] - a), 0.0, 1.0))
            crossing = points[i - 1] + frac * (points[i] - points[i - 1])
            if np.isfinite(ys[i - 1]):  # bracketed by two values read at the points themselves
                bracket = (i - 1, i, frac)
            break
    last = points[-1]
    at_limit = not np.any((np.abs(grad) > 1e-12) & ~(((last >= coded_hi - 1e-9) & (grad > 0))
                                                      | ((last <= coded_lo + 1e-9) & (grad < 0))))
    nearest = None  # the step to verify when the path crosses nothing (_nearest_in_window)
    peak = len(points) - 1  # the step the new box is laid around when the path crosses nothing
    crossed = crossing is not None
    if crossing is None:
        if at_limit or len(points) < cfg.path_points + 1:
            best = np.nanmax(ys) if sign > 0 else np.nanmin(ys)
            reason = (f"{response} = {target:g} lies beyond what the test reaches {AT_LIMITS}: the steepest "
                      f"path from box {box.index} ends at the limits at {best:.2f}")
            end = _end_in_reach(campaign, condition, box, model, sign, ys, measured, points, ks, limits, cfg,
                                reason)
            return (OUT_OF_REACH, reason) if end is None else end
        nearest = _nearest_in_window(condition, model.response, sign, ys, cfg)
        peak = _peak(sign, ys) if nearest is None else nearest
        if peak == 0:
            return OUT_OF_REACH, (f"{response} = {target:g}: the path of steepest "
                                  f"{'ascent' if sign > 0 else 'descent'} from box {box.index} reads "
                                  f"{'lower' if sign > 0 else 'higher'} at every step beyond the box "
                                  f"({', '.join(f'{y:.2f}' for y in ys[1:])}) than box {box.index}'s model at "
                                  f"its edge ({ys[0]:.2f}): the response peaks in box {box.index}, so no box is "
                                  f"laid beyond it and the target lies beyond what the test reaches")
        crossing = points[peak]
    point = None
    if bracket is not None and not np.all(np.abs(crossing) <= 1 + INSIDE_TOL):
        below, i, frac = bracket
        point = _parameters(campaign, box, crossing, limits)
        cheap_at = cheap_ys[below] + frac * (cheap_ys[i] - cheap_ys[below])
        steps = (ks[below], ks[i])
    if np.all(np.abs(crossing) <= 1 + INSIDE_TOL):  # no further than the box itself
        crossing = points[-1]
    centre = box.to_actual(crossing)
    half0 = np.array([0.5 * (f.high - f.low) for f in campaign.factors])
    half = np.minimum(half0, 0.5 * (limits[:, 1] - limits[:, 0]))
    centre = np.clip(centre, limits[:, 0] + half, limits[:, 1] - half)
    moved = Box(box.index + 1, tuple(_clean(centre - half, limits)), tuple(_clean(centre + half, limits)),
                reason=(f"move {moves + 1}: {response} target {target:g} outside box {box.index} "
                        f"({lo:.2f} to {hi:.2f}); the steepest path "
                        + ("crossed it near " if crossed else
                           "ran its length toward it without crossing it, ending near " if peak == len(points) - 1
                           else f"crossed nothing and read furthest toward it at step {ks[peak]}, near ")
                        + _show({f.parameter: significant(c, 3) for f, c in zip(campaign.factors, centre)})))
    if point is None:
        if nearest is not None:
            return PathEnd(moved, response, sign, _parameters(campaign, box, points[nearest], limits),
                           float(measured[nearest - 1]), (ks[nearest], ks[nearest]), reading=float(ys[nearest]),
                           nearest=True)
        return PathEnd(moved, response, sign)
    return PathEnd(moved, response, sign, point, float(cheap_at), steps)


def _peak(sign: float, ys) -> int:
    """The path step read furthest toward the target (``ys[0]``: box's model at step 1;
    the later ones simulated, unread ones skipped), the earliest of equal readings.

    A path that crosses nothing is followed, as in the classic method, only as far as
    its response keeps rising (falling, on a descent): the next design goes around the
    best step, not around a path's end that reads further from the target (Montgomery,
    *Design and Analysis of Experiments*, 8th ed., §11.2: "experiments are conducted
    along the path ... until no further increase in response is observed"). Step 0 is
    the box's own edge: a path whose every simulated step reads worse than the box's
    model there has found the response's peak inside the box. (The demo's quick
    14.1 % repose path from box 0, whose model reaches 38.25 deg, read 37.10, 34.36 and
    31.10 deg at steps 2-4; the loop laid a 29-run box around step 4, 28 Nov 2026.)"""
    best, at = -math.inf, 0
    for i, y in enumerate(ys):
        if np.isfinite(y) and sign * y > best:
            best, at = sign * y, i
    return at


def _nearest_in_window(condition, response: str, sign: float, ys, cfg) -> int | None:
    """The path step to verify when the path ran its length without crossing the lab mean,
    or None: its simulated step nearest the target in the target's direction (the
    highest reading on an ascent), when that reading lies inside the lab window.

    The verification accepts any production mean inside the window, so a path that
    reaches into it has found what the classic method's next box would be laid to find:
    the point is measured at the production profile first, and the box laid around the
    path's end only if it misses (as after a missed crossing). (The paper-profile 14.1 %
    sliding path from box 1 read 27.81, 30.39 and 28.84 at steps 2-4, inside 30.46 ±
    3.2 and 0.07 short of its mean; the loop laid a 34-run box at step 4 whose model
    then reached 27.19 at most, and stopped out of reach, 27 Nov 2026.)"""
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


def _end_in_reach(campaign, condition, box, model, sign, ys, measured, points, ks, limits, cfg, reason):
    """The path's best simulated point as a :class:`PathEnd` to verify, when the path ends
    at the parameters' limits without crossing the target but that point's production
    reading lies within its own 95 % noise of the lab window; else None.

    Such a reading may be the window's edge met within the noise (the paper-sized incline
    saturates at 27-28 deg with the 14.1 % particles, where that target's window starts
    at 27.26): whether the test reaches the window is then a question for the production
    profile, not for one cheap run, so the loop measures it there before it calls the
    target out of reach. The noise is the box model's residual sd (one cheap run's scatter
    about the surface) with the discrepancy's standard error."""
    best = _best_step(condition, model.response, sign, ys, cfg)
    if best is None:
        return None
    target, i = best
    se = 0.0
    if isinstance(model, CorrectedSurface):  # the discrepancy's sd at the point (box-0 coded)
        se = float(model.discrepancy(model.to_box0(points[i]))[1])
        se = se if np.isfinite(se) else 0.0
    noise = 1.96 * math.sqrt(max(float(getattr(model, "mse", 0.0)), 0.0) + se * se)
    edge = target.mean - sign * target.sd
    if sign * (ys[i] - edge) < -noise:
        return None
    point = _parameters(campaign, box, points[i], limits)
    return PathEnd(box, model.response, sign, point, float(measured[i - 1]), (ks[i], ks[i]),
                   limit=reason, reading=float(ys[i]))


@dataclass(frozen=True)
class PathEnd:
    """Where a path of steepest ascent (or descent) met its target: the new box around
    the crossing (its design not yet run) and, when two path points bracket the target,
    the crossing point itself, read off the path by linear interpolation between them
    (where the production reading meets the target): its parameters and the cheap
    response there. With ``limit`` set it is instead the path's best point where the
    parameters' limits stopped it short of the target (:func:`_end_in_reach`): ``box`` is
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


def _turned_back(end: PathEnd, boxes: Sequence[Box], box: Box, target, condition,
                 missed: bool = False) -> str | None:
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


def _lay_box(campaign, moved: Box, run, records, budget, history, iteration):
    """Run the design of the moved box (earlier runs inside it count); the box, or
    ``(status, reason)`` when the loop must stop."""
    from demcal.campaign.runner import plan_design

    plan = plan_design(moved.campaign(campaign, campaign.calibration.box_replicates))
    specs = [dataclasses.replace(s, label=f"box {moved.index} {s.label}") for s in plan.specs]
    done, added, stopped = _spend(specs, f"{campaign.name} box {moved.index} design",
                                  f"the design runs of box {moved.index}", campaign, run, records, budget)
    if stopped:
        return stopped
    centre = moved.centre
    history.append(Step(iteration, moved.index, "design", added,
                        f"box {moved.index}: " + _show({f.parameter: significant(c, 3) for f, c in zip(campaign.factors, centre)})
                        + f" ± half-widths; {len(specs)} design runs ({len(specs) - added} done before)"))
    return moved
