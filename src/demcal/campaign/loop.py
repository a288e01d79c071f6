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
   restitution in (0, 0.95] unless ``hard_high`` says more, and the factor's ``hard_low`` /
   ``hard_high``); a factor at
   its limit stops moving and the others go on (the projected path). Points beyond the
   box edge are simulated at the cheap profile; where the simulated response, read at
   the production profile (the discrepancy at each point added), crosses the target,
   a new design of the campaign's kind is laid around that point (the original
   half-widths), and every earlier cheap design or path run inside the new box is
   fitted with it. Where two path points bracket the target, the crossing is
   verified first (``verify_on_path``) and the box is laid only if it misses. A path
   that crosses nothing lays its box around its end, and none where no step reads
   further toward the target than the box itself reaches
   (:func:`demcal.campaign.ascent._gains_nothing`). When the path ends at the limits without crossing, the
   condition stops: the target is out of the test's reach, unless the lab window lies
   within the noise of the path's best point, which is then measured at the production
   profile first (verified there, or out of reach with that figure:
   :func:`demcal.campaign.ascent.end_in_reach`); when it turns back into an earlier box
   (the response peaks between them), no further move is made
   (:func:`demcal.campaign.ascent.turned_back`).
3. **Production runs** at the solution nearest the box centre, with replicates (their
   seed-to-seed sd, pooled over every production point, is the noise, with the stored
   profile studies' replicated production runs pooled in where they measured this
   test's production profile: :func:`stored_noise`; once it is known, a new point's
   first batch is the fewest replicates it says are enough, between
   ``min_replicates`` and ``replicates``:
   :func:`demcal.campaign.replicates.first_batch`). While nothing is known of the
   discrepancy (the first point of a campaign whose production profile is not its
   cheap one) a single run probes it first: if it lands outside the lab band, the loop
   re-solves with what it taught instead of replicating a point it will leave. The
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

The steps are named states (:mod:`demcal.campaign.states`, whose ``TRANSITIONS``
table docs/calibration.md shows): ``fit`` (step 1 and the reach), ``path`` and
``crossing`` (step 2: the path's runs, then where it meets the target), ``design`` and
``box`` (a moved box's design, then the box), ``solve``, ``production`` and ``verdict``
(steps 3 and 4). Each is a small function of what the loop has found so far that
returns the next state with the runs it needs; one driver runs those. Every decision is
a deterministic function of the runs in the store (fits, seeded searches, seeds derived
from the point and replicate), so a loop that is interrupted replays to where it was
and runs only what is missing, and ``demcal report`` replays it without running
anything: a replay is a fold of the states over the stored runs.

The parts live in their own modules: :mod:`demcal.campaign.box` (boxes, limits, the fit),
:mod:`demcal.campaign.discrepancy` (the discrepancy and the corrected surface),
:mod:`demcal.campaign.ascent` (the path of steepest ascent), :mod:`demcal.campaign.replicates`
(how many production runs), :mod:`demcal.campaign.outcome` (statuses, history, result);
their public names are importable from here too.
"""

from __future__ import annotations

from typing import Callable

import pandas as pd

# (re-exported: demcal.report.benchmark imports campaign_runs and pooled_sd from here)
from demcal.campaign.box import (INSIDE_TOL, Box, campaign_runs, fit_box, in_window,  # noqa: F401
                                 out_of_box, physical_limits)
from demcal.campaign.config import Campaign, Condition
from demcal.campaign.discrepancy import (CorrectedSurface, Discrepancy, StoredPrior, prior_on_box,  # noqa: F401
                                         stored_priors)
from demcal.campaign.noise import pooled_sd, production_noise, stored_noise  # noqa: F401
from demcal.campaign.outcome import (BUDGET, ITERATIONS, NOISE, NOT_VERIFIED, OUT_OF_REACH,  # noqa: F401
                                     UNFINISHED, VERIFIED, LoopResult, Step)
from demcal.campaign.ascent import AT_LIMITS, PathEnd  # noqa: F401
from demcal.campaign.replicates import batched, first_batch, replicates_needed  # noqa: F401
from demcal.campaign.replicates import production_specs as _production_specs  # noqa: F401
from demcal.campaign.states import TRANSITIONS, Budget, Loop, LoopState, Runner, drive  # noqa: F401
from demcal.campaign.store import RunRecord


def run_condition(campaign: Campaign, condition: Condition, ci: int, *, cheap: str, production: str,
                  design_table: pd.DataFrame, run: Runner, records: Callable[[], list[RunRecord]],
                  residuals: dict[str, list] | None = None, seed: int = 0) -> LoopResult:
    """The loop for one condition (module docstring): its states driven from ``fit`` until
    one stops. ``residuals`` (response -> [(box-0 coded point, production - cheap model)])
    is shared by the conditions: each learns from the production runs of those before."""
    cfg = campaign.calibration
    box0 = Box(0, tuple(f.low for f in campaign.factors), tuple(f.high for f in campaign.factors))
    responses = [t.response for t in condition.targets]
    priors = stored_priors(campaign, cheap, production)
    first_replicates = cfg.replicates or campaign.verification_replicates
    loop = Loop(campaign=campaign, condition=condition, ci=ci, cheap=cheap, production=production,
                design_table=design_table, run=run, records=records, seed=seed,
                limits=physical_limits(campaign, cheap), budget=Budget(campaign), responses=responses,
                noise_prior=stored_noise(campaign, production, responses), first_replicates=first_replicates,
                box0=box0, on_box={r: prior_on_box(b, campaign, condition, box0, cheap) for r, b in priors.items()},
                residuals={} if residuals is None else residuals)
    return drive(loop, LoopState(box=box0, boxes=[box0], replicates=first_replicates, asked=first_replicates))
