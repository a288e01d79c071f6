"""Multi-start desirability search and the solution set it reveals.

The search maximises the overall desirability D inside the coded design box with
Nelder-Mead from many random starts (Design-Expert also restarts a simplex search from
random points). Because one measured angle cannot pin down several contact parameters,
many settings reach D = 1: the result therefore also reports the *solution set*, the
range of every factor over all settings with D >= ``threshold``. Those ranges are found
in two stages. First each factor is minimised and maximised subject to D >= threshold
(SLSQP), started from the most extreme of the solutions and of random samples of the set.
SLSQP only climbs to the nearest extreme of a set that may be curved, thin or in pieces,
so then each factor's range is widened by slices: from the bound of the box inward, in
steps of 0.02 coded, the first value of the factor at which the other factors can still
reach D >= threshold (found exactly for one goal, by the intermediate value theorem on
the slice's lowest and highest response; by a local search for several goals), refined
by bisection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import optimize as sopt

from demcal.errors import ConfigError, DataError
from demcal.optimize.desirability import Goal, overall_desirability


#: The most random starts :func:`optimize` takes. Each start is one local search (about
#: 10 to 30 ms for a quadratic in four factors), so 10,000 take minutes; the solution
#: set's ranges come from the set search that follows the starts, not from more of them,
#: and a million would run for hours before the result says anything new.
MAX_STARTS = 10_000


@dataclass
class Optimization:
    """Result of :func:`optimize`.

    Attributes
    ----------
    solutions : pandas.DataFrame
        Distinct solutions, best first (those with D >= threshold, or within 1 % of the
        best D when none reaches it): coded factor columns (``coded:A``), actual
        columns (``actual:A``), predicted responses (``predicted:y``) and ``desirability``.
    factor_ranges : dict
        ``{factor: (low, high)}`` in actual units over the solution set (D >= threshold).
    factor_ranges_coded : dict
        The same in coded units.
    set_points : numpy.ndarray
        Coded points of the solution set (solutions, range extremes and samples), for plots.
    goals : list of Goal
        Goals with their limits filled in.
    reachable : dict
        ``{response: (min, max)}`` the model reaches inside the box.
    threshold : float
    """

    solutions: pd.DataFrame
    factor_ranges: dict
    factor_ranges_coded: dict
    set_points: np.ndarray
    goals: list
    factors: tuple
    reachable: dict
    threshold: float
    bounds: np.ndarray = field(default=None)

    @property
    def best(self) -> pd.Series:
        return self.solutions.iloc[0]

    def to_dict(self, max_solutions: int | None = None) -> dict:
        """The ``demcal optimize --json`` object: solutions and factor_ranges."""
        names = [f.name for f in self.factors]
        sols = []
        rows = self.solutions if max_solutions is None else self.solutions.head(max_solutions)
        for _, r in rows.iterrows():
            sols.append({
                "coded": {n: float(r[f"coded:{n}"]) for n in names},
                "actual": {n: float(r[f"actual:{n}"]) for n in names},
                "predicted": {g.response: float(r[f"predicted:{g.response}"]) for g in self.goals},
                "desirability": float(r["desirability"]),
            })
        return {"solutions": sols,
                "factor_ranges": {n: [float(a), float(b)] for n, (a, b) in self.factor_ranges.items()}}


class _Problem:
    """Vectorised evaluation of predictions and desirability at coded points."""

    def __init__(self, models: dict, goals: list[Goal]):
        self.models = models
        self.goals = goals
        self.importance = np.array([g.importance for g in goals], dtype=float)

    def predict(self, X) -> np.ndarray:
        X = np.atleast_2d(X)
        return np.vstack([self.models[g.response].predict(X) for g in self.goals])

    def D(self, X) -> np.ndarray:
        Y = self.predict(X)
        ds = np.vstack([g.desirability(y) for g, y in zip(self.goals, Y)])
        return overall_desirability(ds, self.importance)

    def loss_and_grad(self, x):
        """-D and its gradient where D > 0; else 1 + total violation (leads into [L, U])."""
        x = np.asarray(x, dtype=float)
        ys, grads, ds, dds = [], [], [], []
        for g in self.goals:
            m = self.models[g.response]
            y = float(m.predict(x))
            d, dd = g.scalar(y)
            ys.append(y)
            grads.append(m.gradient(x))
            ds.append(d)
            dds.append(dd)
        if min(ds) > 0:
            R = float(self.importance.sum())
            logD = sum(r * math.log(d) for r, d in zip(self.importance, ds)) / R
            D = math.exp(logD)
            gD = np.zeros_like(x)
            for d, dd, r, gy in zip(ds, dds, self.importance, grads):
                gD += (r / R * dd / d) * gy
            return -D, -D * gD
        val, grad = 1.0, np.zeros_like(x)
        for g, y, gy in zip(self.goals, ys, grads):
            span = max(g.high - g.low, 1e-12)
            if y < g.low:
                val += (g.low - y) / span
                grad -= gy / span
            elif y > g.high:
                val += (y - g.high) / span
                grad += gy / span
        return val, grad

    def loss(self, x) -> float:
        return self.loss_and_grad(x)[0]

    def D_grad(self, x):
        """(D, dD/dx) at one point (gradient 0 where D = 0)."""
        v, g = self.loss_and_grad(x)
        return (-v, -g) if v <= 0 else (0.0, np.zeros_like(g))


def _extreme(model, bounds, sign, rng, starts=6) -> float:
    """min (sign=+1) or -max (sign=-1) of a model's prediction inside the box."""
    k = bounds.shape[0]
    pts = np.vstack([rng.uniform(bounds[:, 0], bounds[:, 1], (starts, k)), np.zeros(k)])
    best = float(np.min(sign * model.predict(pts)))
    for x0 in pts:
        r = sopt.minimize(lambda x: (sign * float(model.predict(x)), sign * model.gradient(x)),
                          x0, jac=True, method="L-BFGS-B", bounds=bounds)
        best = min(best, float(r.fun))
    return best


def reachable_range(model, bounds=None, seed: int = 0) -> tuple[float, float]:
    """(min, max) of a response surface over the coded box."""
    k = len(model.factors)
    bounds = np.tile([-1.0, 1.0], (k, 1)) if bounds is None else np.asarray(bounds, dtype=float)
    rng = np.random.default_rng(seed)
    return _extreme(model, bounds, 1.0, rng), -_extreme(model, bounds, -1.0, rng)


def _polish_target(problem: _Problem, x, bounds):
    """Newton steps along the gradient to hit a single target exactly (stays in the box)."""
    g = problem.goals[0]
    model = problem.models[g.response]
    for _ in range(30):
        err = g.target - float(model.predict(x))
        if abs(err) < 1e-12:
            break
        grad = model.gradient(x)
        free = ~(((x <= bounds[:, 0]) & (grad * err < 0)) | ((x >= bounds[:, 1]) & (grad * err > 0)))
        gg = grad * free
        nrm = gg @ gg
        if nrm < 1e-20:
            break
        x = np.clip(x + err * gg / nrm, bounds[:, 0], bounds[:, 1])
    return x


def check_search(n_starts: int, threshold: float, names=("n_starts", "threshold")) -> None:
    """Refuse a count of starts outside 1 .. :data:`MAX_STARTS` or a desirability
    threshold outside (0, 1]; ``names`` are what the sentences call them (the command's
    options)."""
    if isinstance(n_starts, bool) or not isinstance(n_starts, (int, np.integer)) or not 1 <= n_starts <= MAX_STARTS:
        raise ConfigError(f"{names[0]} must be a whole number from 1 to {MAX_STARTS:,} (each start is one local "
                          f"search; more find nothing new), got {n_starts}.")
    if not 0 < threshold <= 1:
        raise ConfigError(f"{names[1]} must lie in (0, 1], not {threshold}.")


def optimize(
    models: dict,
    goals: list[Goal],
    n_starts: int = 30,
    seed: int = 0,
    threshold: float = 0.99,
    bounds=None,
    min_distance: float = 0.02,
) -> Optimization:
    """Maximise the overall desirability of ``goals`` over the coded design box.

    Parameters
    ----------
    models : dict
        ``{response name: ResponseSurface}``; all must share the same factors.
    goals : list of Goal
        One per response to optimise; missing limits default to the observed range of
        the response, widened to what the model reaches if a target lies outside it.
    n_starts : int
        Random starting points of the simplex search, 1 to :data:`MAX_STARTS`.
    seed : int
        Seed of the starting points (the result is reproducible).
    threshold : float
        Desirability defining the solution set (0.99: Design-Expert's "most desirable").
    bounds : array_like, optional
        ``(k, 2)`` coded bounds; default -1 .. +1 for every factor.
    min_distance : float
        Solutions closer than this (coded, Euclidean) count as one.

    Raises
    ------
    ConfigError
        ``n_starts`` outside 1 .. :data:`MAX_STARTS`, ``threshold`` outside (0, 1].
    DataError
        A target outside what the model can reach in the box, or no setting with D > 0.
    """
    check_search(n_starts, threshold)
    if not goals:
        raise ConfigError("give at least one goal (e.g. --target 31.07).")
    factors = None
    for g in goals:
        if g.response not in models:
            raise ConfigError(f"there is no model for response {g.response!r}.")
        names = tuple(f.name for f in models[g.response].factors)
        if factors is None:
            factors = models[g.response].factors
        elif names != tuple(f.name for f in factors):
            raise ConfigError("all responses must be modelled on the same factors.")
    k = len(factors)
    bounds = np.tile([-1.0, 1.0], (k, 1)) if bounds is None else np.asarray(bounds, dtype=float)
    rng = np.random.default_rng(seed)

    filled, reach = [], {}
    for g in goals:
        m = models[g.response]
        lo, hi = reachable_range(m, bounds, seed)
        reach[g.response] = (lo, hi)
        tol = 1e-9 * max(1.0, abs(hi - lo))
        if g.kind == "target" and not lo - tol <= g.target <= hi + tol:
            raise DataError(
                f"the target {g.target:g} for {g.response} is outside what the model can reach "
                f"inside the design box ({lo:.4g} to {hi:.4g}); choose a target in that range "
                "or widen the factor levels."
            )
        if g.kind == "in_range" and g.low is not None and g.high is not None and (g.high < lo or g.low > hi):
            raise DataError(
                f"the range {g.low:g}..{g.high:g} for {g.response} does not meet what the model "
                f"can reach inside the design box ({lo:.4g} to {hi:.4g})."
            )
        obs_lo, obs_hi = float(np.min(m.y)), float(np.max(m.y))
        if g.kind == "target":
            # the target strictly inside its limits: d has no lower (upper) branch when
            # it sits on the low (high) limit, and a point a hair past it scores 0 (a
            # target on the edge of what the box reaches is what calibration aims at
            # when the measured one is out of reach)
            margin = 1e-3 * max(hi - lo, obs_hi - obs_lo, 1e-12)
            if g.target - margin < obs_lo:
                obs_lo = min(obs_lo, lo, g.target) - margin
            if g.target + margin > obs_hi:
                obs_hi = max(obs_hi, hi, g.target) + margin
        filled.append(g.with_limits(obs_lo, obs_hi))
    problem = _Problem(models, filled)

    starts = np.vstack([rng.uniform(bounds[:, 0], bounds[:, 1], (n_starts, k)), np.zeros(k)])
    single_target = len(filled) == 1 and filled[0].kind == "target"
    found = []
    for x0 in starts:
        r = sopt.minimize(problem.loss_and_grad, x0, jac=True, method="L-BFGS-B", bounds=bounds,
                          options={"maxiter": 200})
        found.append(np.clip(r.x, bounds[:, 0], bounds[:, 1]))
    if single_target:
        polished = [_polish_target(problem, x, bounds) for x in found]
    else:  # a short simplex search from the best points handles the kinks of D at targets
        D0 = problem.D(np.array(found))
        polished = list(found)
        for i in np.argsort(-D0)[: max(5, n_starts // 4)]:
            r = sopt.minimize(problem.loss, found[i], method="Nelder-Mead", bounds=bounds,
                              options={"xatol": 1e-9, "fatol": 1e-13, "maxiter": 200 * k})
            polished[i] = np.clip(r.x, bounds[:, 0], bounds[:, 1])
    for i, x in enumerate(polished):
        if problem.D(x)[0] >= problem.D(found[i])[0]:
            found[i] = x
    found = np.array(found)
    # snap round-off next to the bounds onto them (a solver stops at 1e-9, not at 0)
    for j in range(k):
        for b in bounds[j]:
            found[np.abs(found[:, j] - b) < 1e-7, j] = b
    D = problem.D(found)
    if D.max() <= 0:
        raise DataError(
            "no factor setting inside the design box gives every response a non-zero "
            "desirability; relax the goals or their limits."
        )
    order = np.argsort(-D, kind="stable")
    floor = min(threshold, 0.99 * D.max())  # settings far below the best are not solutions
    distinct = []
    for i in order:
        if D[i] < floor:
            continue
        if all(np.linalg.norm(found[i] - found[j]) >= min_distance for j in distinct):
            distinct.append(i)
    X = found[distinct]
    Dd = D[distinct]
    Y = problem.predict(X)
    cols = {}
    for j, f in enumerate(factors):
        cols[f"coded:{f.name}"] = X[:, j]
    for j, f in enumerate(factors):
        cols[f"actual:{f.name}"] = f.to_actual(X[:, j])
    for g, y in zip(filled, Y):
        cols[f"predicted:{g.response}"] = y
    cols["desirability"] = Dd
    solutions = pd.DataFrame(cols)

    set_pts = [X[Dd >= threshold]]
    ranges_coded = {}
    good = X[Dd >= threshold]
    if len(good):
        samples = _sample_set(problem, good, bounds, threshold, rng)
        extra = _solution_set_extremes(problem, np.vstack([good, samples]), bounds,
                                       threshold)
        set_pts += [extra, samples]
        set_pts.append(_widen_ranges(problem, np.vstack([p for p in set_pts if len(p)]),
                                     bounds, threshold, rng))
        allp = np.vstack([p for p in set_pts if len(p)])
        for j, f in enumerate(factors):
            ranges_coded[f.name] = (float(allp[:, j].min()), float(allp[:, j].max()))
    else:
        allp = np.empty((0, k))
    ranges = {f.name: tuple(sorted((float(f.to_actual(a)), float(f.to_actual(b)))))
              for f, (a, b) in zip(factors, ranges_coded.values())} if ranges_coded else {}
    return Optimization(solutions, ranges, ranges_coded, allp, filled, tuple(factors), reach,
                        threshold, bounds)


def _solution_set_extremes(problem: _Problem, good, bounds, threshold, per_direction: int = 2):
    """Points of the solution set that minimise / maximise each factor (SLSQP)."""
    k = bounds.shape[0]
    cons = [{"type": "ineq", "fun": lambda x: problem.D_grad(x)[0] - threshold,
             "jac": lambda x: problem.D_grad(x)[1]}]
    pts = []
    for j in range(k):
        unit = np.eye(k)[j]
        for sign in (1.0, -1.0):
            # start from the solutions already most extreme in this direction
            for x0 in good[np.argsort(sign * good[:, j])[:per_direction]]:
                if (sign > 0 and x0[j] <= bounds[j, 0]) or (sign < 0 and x0[j] >= bounds[j, 1]):
                    pts.append(x0)
                    continue
                r = sopt.minimize(lambda x: (sign * x[j], sign * unit), x0, jac=True,
                                  method="SLSQP", bounds=bounds, constraints=cons,
                                  options={"maxiter": 100, "ftol": 1e-10})
                x = np.clip(r.x, bounds[:, 0], bounds[:, 1])
                if problem.D(x)[0] >= threshold - 1e-9:
                    pts.append(x)
    return np.array(pts) if pts else np.empty((0, k))


def _sample_set(problem: _Problem, good, bounds, threshold, rng, n: int = 4000):
    """Random points of the solution set: uniform samples plus jitter around solutions."""
    k = bounds.shape[0]
    uni = rng.uniform(bounds[:, 0], bounds[:, 1], (n, k))
    jit = np.clip(good[rng.integers(0, len(good), n)] + rng.normal(0, 0.05, (n, k)),
                  bounds[:, 0], bounds[:, 1])
    cand = np.vstack([uni, jit])
    return cand[problem.D(cand) >= threshold]


#: coded step of the slice scan in :func:`_widen_ranges` and points tried per slice
SLICE_STEP = 0.02
SLICE_POINTS = 256


def _slice_point(problem: _Problem, j, v, bounds, threshold, others):
    """A point of the solution set whose factor j is ``v``, or None if the slice holds none.

    ``others`` are random points of the box; their factor j is set to v. For one goal,
    the slice (a box, so connected) holds such a point exactly when the interval between
    the response's lowest and highest value on it meets the goal's band (intermediate
    value theorem); both are found by L-BFGS-B from the best of the points, and the point
    by bisection on the segment between them. For several goals D is maximised on the
    slice from the best of the points.
    """
    k = bounds.shape[0]
    free = np.array([i for i in range(k) if i != j], dtype=int)
    X = np.array(others, dtype=float)
    X[:, j] = v

    def embed(z):
        x = np.empty(k)
        x[free] = z
        x[j] = v
        return x

    def settle(x):
        return x if problem.D(x)[0] >= threshold - 1e-9 else None

    if len(problem.goals) == 1:
        g = problem.goals[0]
        model = problem.models[g.response]
        lo_b, hi_b = g.band(threshold)
        y = model.predict(X)
        inside = (y >= lo_b) & (y <= hi_b)
        if inside.any():
            return X[np.flatnonzero(inside)[0]]
        ends = []
        for sign, i0 in ((1.0, int(np.argmin(y))), (-1.0, int(np.argmax(y)))):
            r = sopt.minimize(
                lambda z: (sign * float(model.predict(embed(z))),
                           sign * model.gradient(embed(z))[free]),
                X[i0, free], jac=True, method="L-BFGS-B", bounds=bounds[free])
            ends.append(embed(np.clip(r.x, bounds[free, 0], bounds[free, 1])))
        xa, xb = ends
        ya, yb = float(model.predict(xa)), float(model.predict(xb))
        if ya > hi_b or yb < lo_b:
            return None
        aim = g.target if g.kind == "target" else (lo_b if np.isinf(hi_b) else
                                                   hi_b if np.isinf(lo_b) else
                                                   0.5 * (lo_b + hi_b))
        aim = min(max(aim, ya), yb)
        t0, t1 = 0.0, 1.0
        for _ in range(60):
            t = 0.5 * (t0 + t1)
            if float(model.predict(xa + t * (xb - xa))) < aim:
                t0 = t
            else:
                t1 = t
        for t in (t0, t1):
            x = settle(xa + t * (xb - xa))
            if x is not None:
                return x
        return None
    D = problem.D(X)
    i0 = int(np.argmax(D))
    if D[i0] >= threshold:
        return X[i0]
    r = sopt.minimize(lambda z: (lambda f, gr: (f, gr[free]))(*problem.loss_and_grad(embed(z))),
                      X[i0, free], jac=True, method="L-BFGS-B", bounds=bounds[free])
    return settle(embed(np.clip(r.x, bounds[free, 0], bounds[free, 1])))


def _widen_ranges(problem: _Problem, pts, bounds, threshold, rng):
    """Points of the solution set beyond the factor ranges of ``pts``: for each factor and
    side, the outermost slice (scanned from the bound inward, refined by bisection) that
    holds one (see :func:`_slice_point`)."""
    k = bounds.shape[0]
    others = rng.uniform(bounds[:, 0], bounds[:, 1], (SLICE_POINTS, k))
    found = []
    for j in range(k):
        for end, inner in ((bounds[j, 1], pts[:, j].max()), (bounds[j, 0], pts[:, j].min())):
            inward = 1.0 if inner > end else -1.0
            n = int(math.floor(abs(inner - end) / SLICE_STEP))
            outside = None  # the last value tried that holds no point (towards the bound)
            for v in [end + inward * SLICE_STEP * i for i in range(n + 1)]:
                x = _slice_point(problem, j, v, bounds, threshold, others)
                if x is None:
                    outside = v
                    continue
                if outside is not None:  # the set's edge lies between outside and v
                    a, b = outside, v
                    for _ in range(12):
                        mid = 0.5 * (a + b)
                        xm = _slice_point(problem, j, mid, bounds, threshold, others)
                        if xm is None:
                            a = mid
                        else:
                            b, x = mid, xm
                found.append(x)
                break
    return np.array(found) if found else np.empty((0, k))
