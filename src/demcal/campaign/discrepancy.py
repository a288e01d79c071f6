"""What the production profile gives that the cheap model does not: the discrepancy
``production - cheap model`` (a stored bias between the profiles until production runs
exist, then an additive bias and a Gaussian process) and the corrected surface, a box's
response surface plus that discrepancy (:mod:`demcal.campaign.loop`)."""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from demcal.campaign.box import Box
from demcal.campaign.config import Campaign, Condition


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
