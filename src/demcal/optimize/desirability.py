"""Derringer-Suich desirability functions.

Derringer, G. & Suich, R. (1980). Simultaneous optimization of several response
variables. *J. Quality Technology* 12(4), 214-219; with Design-Expert's weights
(shape exponents) and importance (1..5) for combining responses:

* maximise:  d = ((y - L) / (U - L))^w, 0 below L, 1 above U;
* minimise:  d = ((U - y) / (U - L))^w, 1 below L, 0 above U;
* target T:  d = ((y - L) / (T - L))^w1 for L <= y <= T,
             d = ((U - y) / (U - T))^w2 for T <= y <= U, 0 outside [L, U];
* in range:  d = 1 inside [L, U], 0 outside;
* overall:   D = (prod d_i^r_i)^(1 / sum r_i), r_i the importance.

L and U are the goal's lower and upper limits; Design-Expert's default limits are the
observed range of the response.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from demcal._checks import and_list
from demcal.errors import ConfigError

KINDS = ("target", "maximize", "minimize", "in_range")
_KIND_ALIASES = {"max": "maximize", "maximise": "maximize", "min": "minimize",
                 "minimise": "minimize", "range": "in_range", "in-range": "in_range",
                 "inrange": "in_range", "target": "target"}


@dataclass(frozen=True)
class Goal:
    """Goal for one response.

    Parameters
    ----------
    response : str
        Response name (the model's response).
    kind : {"target", "maximize", "minimize", "in_range"}
    target : float, optional
        Target value (``kind="target"``) [response units].
    low, high : float, optional
        Lower and upper limits L and U; filled from the data when omitted.
    weight_low, weight_high : float
        Shape exponents (Design-Expert "lower/upper weight", 0.1 .. 10); maximise and
        minimise use ``weight_low``.
    importance : int
        1 .. 5, how much this response counts in the overall desirability.
    """

    response: str
    kind: str = "target"
    target: float | None = None
    low: float | None = None
    high: float | None = None
    weight_low: float = 1.0
    weight_high: float = 1.0
    importance: int = 3

    def __post_init__(self):
        kind = _KIND_ALIASES.get(str(self.kind).lower(), str(self.kind).lower())
        if kind not in KINDS:
            raise ConfigError(f"unknown goal {self.kind!r} for {self.response}; use target, max, min or range.")
        object.__setattr__(self, "kind", kind)
        if kind == "target" and self.target is None:
            raise ConfigError(f"the target goal for {self.response} needs a target value.")
        for name in ("target", "low", "high"):
            value = getattr(self, name)
            if value is not None and not np.isfinite(value):
                raise ConfigError(f"the {name} of {self.response} must be a finite number, not {value}.")
        if not 1 <= int(self.importance) <= 5:
            raise ConfigError(f"importance of {self.response} must be 1 to 5, not {self.importance}.")
        for w in (self.weight_low, self.weight_high):
            if not 0.1 <= w <= 10:
                raise ConfigError(f"weights of {self.response} must lie between 0.1 and 10, not {w}.")
        if self.low is not None and self.high is not None and self.high < self.low:
            raise ConfigError(f"the upper limit of {self.response} is below its lower limit.")

    def with_limits(self, low: float, high: float) -> "Goal":
        """The goal with missing limits filled in (given limits are kept)."""
        lo = self.low if self.low is not None else low
        hi = self.high if self.high is not None else high
        if self.kind == "target":
            lo, hi = min(lo, self.target), max(hi, self.target)
        return replace(self, low=float(lo), high=float(hi))

    def desirability(self, y) -> np.ndarray:
        """Individual desirability d(y) in [0, 1] (limits must be set)."""
        y = np.asarray(y, dtype=float)
        L, U = self.low, self.high
        if L is None or U is None:
            raise ValueError("limits not set; call with_limits first")
        span = max(U - L, 1e-300)
        if self.kind == "maximize":
            return np.clip((y - L) / span, 0.0, 1.0) ** self.weight_low
        if self.kind == "minimize":
            return np.clip((U - y) / span, 0.0, 1.0) ** self.weight_low
        if self.kind == "in_range":
            return ((y >= L) & (y <= U)).astype(float)
        T = self.target
        below = np.where(T > L, np.clip((y - L) / max(T - L, 1e-300), 0, 1), (y >= T).astype(float))
        above = np.where(U > T, np.clip((U - y) / max(U - T, 1e-300), 0, 1), (y <= T).astype(float))
        d = np.where(y <= T, below ** self.weight_low, above ** self.weight_high)
        return np.where((y < L) | (y > U), 0.0, d)

    def derivative(self, y) -> np.ndarray:
        """dd/dy (0 where d is flat, outside [L, U] and exactly at a target)."""
        y = np.asarray(y, dtype=float)
        L, U = self.low, self.high
        inside = (y > L) & (y < U)
        if self.kind == "in_range":
            return np.zeros_like(y)
        if self.kind in ("maximize", "minimize"):
            span = max(U - L, 1e-300)
            u = np.clip((y - L) / span if self.kind == "maximize" else (U - y) / span, 1e-12, 1)
            sign = 1.0 if self.kind == "maximize" else -1.0
            return np.where(inside, sign * self.weight_low / span * u ** (self.weight_low - 1), 0.0)
        T = self.target
        lo_span, hi_span = max(T - L, 1e-300), max(U - T, 1e-300)
        ub = np.clip((y - L) / lo_span, 1e-12, 1)
        ua = np.clip((U - y) / hi_span, 1e-12, 1)
        below = self.weight_low / lo_span * ub ** (self.weight_low - 1)
        above = -self.weight_high / hi_span * ua ** (self.weight_high - 1)
        return np.where(inside & (y < T), below, np.where(inside & (y > T), above, 0.0))

    def scalar(self, y: float) -> tuple[float, float]:
        """(d, dd/dy) at one value, in plain floats (the search's inner loop)."""
        L, U = self.low, self.high
        if y < L or y > U:
            return 0.0, 0.0
        if self.kind == "in_range":
            return 1.0, 0.0
        if self.kind in ("maximize", "minimize"):
            span = max(U - L, 1e-300)
            u = (y - L) / span if self.kind == "maximize" else (U - y) / span
            w = self.weight_low
            sign = 1.0 if self.kind == "maximize" else -1.0
            return u**w, (sign * w / span * max(u, 1e-12) ** (w - 1) if L < y < U else 0.0)
        T = self.target
        if y < T:
            if T <= L:
                return 1.0, 0.0
            u, w = (y - L) / (T - L), self.weight_low
            return u**w, w / (T - L) * max(u, 1e-12) ** (w - 1) if y > L else 0.0
        if y > T:
            if U <= T:
                return 1.0, 0.0
            u, w = (U - y) / (U - T), self.weight_high
            return u**w, -w / (U - T) * max(u, 1e-12) ** (w - 1) if y < U else 0.0
        return 1.0, 0.0

    def violation(self, y) -> np.ndarray:
        """Distance outside [L, U] relative to U - L (0 inside); guides the search."""
        y = np.asarray(y, dtype=float)
        span = max(self.high - self.low, 1e-12)
        return (np.maximum(self.low - y, 0) + np.maximum(y - self.high, 0)) / span

    def band(self, threshold: float) -> tuple[float, float]:
        """Response interval where d >= ``threshold`` (for reporting the solution set)."""
        L, U = self.low, self.high
        if self.kind == "in_range":
            return L, U
        if self.kind == "maximize":
            return L + (U - L) * threshold ** (1 / self.weight_low), np.inf
        if self.kind == "minimize":
            return -np.inf, U - (U - L) * threshold ** (1 / self.weight_low)
        T = self.target
        return (T - (T - L) * (1 - threshold ** (1 / self.weight_low)),
                T + (U - T) * (1 - threshold ** (1 / self.weight_high)))

    def describe(self) -> str:
        if self.kind == "target":
            what = f"target {self.target:g}"
        elif self.kind == "in_range":
            what = "in range"
        else:
            what = self.kind
        lim = "" if self.low is None else f" (limits {self.low:.4g} .. {self.high:.4g})"
        return f"{self.response}: {what}{lim}, importance {self.importance}"


def overall_desirability(ds, importances) -> np.ndarray:
    """D = (prod d_i^r_i)^(1/sum r_i) for arrays ``ds`` (one per goal)."""
    r = np.asarray(importances, dtype=float)
    ds = np.asarray(ds, dtype=float)
    with np.errstate(divide="ignore"):
        logd = np.where(ds > 0, np.log(np.maximum(ds, 1e-300)), -np.inf)
    out = np.exp(np.tensordot(r, logd, axes=(0, 0)) / r.sum())
    return np.where(np.all(ds > 0, axis=0), out, 0.0)


_GOAL = re.compile(r"^\s*(?P<resp>[^=]+?)\s*=\s*(?P<rest>.*)$")

#: ``key=value`` options of a goal, per goal kind (a key a kind would ignore is refused).
_GOAL_KEYS = {
    "target": ("low", "high", "importance", "weight", "weight_low", "weight_high"),
    "maximize": ("low", "high", "importance", "weight", "weight_low"),
    "minimize": ("low", "high", "importance", "weight", "weight_low"),
    "in_range": ("low", "high", "importance"),
}
_ALL_GOAL_KEYS = _GOAL_KEYS["target"]
_COUNT_WORDS = ("no numbers", "one number", "two numbers", "three numbers")


def _count(n: int) -> str:
    return _COUNT_WORDS[n] if n < len(_COUNT_WORDS) else f"{n} numbers"


def parse_goal(spec: str) -> Goal:
    """Parse ``RESP=KIND[:numbers][:key=value...]``.

    Examples: ``beta=target:31.07``, ``y=max``, ``y=range:10:20``,
    ``y=target:31.07:low=30:high=33:importance=5:weight=2``.

    * ``target:T`` takes exactly one number, the target;
    * ``max`` and ``min`` take no numbers (limits as ``low=`` and ``high=``);
    * ``range`` takes none (the data's range) or two, ``range:LOW:HIGH``;
    * keys: ``low``, ``high``, ``importance`` (whole number 1..5), and for target, max
      and min goals ``weight`` and ``weight_low`` (target goals also ``weight_high``).

    Anything else (an unknown key, a key given twice or one the kind would ignore, a
    wrong count of numbers) is a :class:`ConfigError` naming the expected syntax.
    """
    m = _GOAL.match(spec)
    if not m or not m["resp"].strip():
        raise ConfigError(f"cannot read goal {spec!r}; name a response and its goal, like "
                          "beta=target:31.07 or y=max.")
    resp = m["resp"].strip()
    parts = [p.strip() for p in m["rest"].split(":") if p.strip()]
    examples = f"{resp}=max, {resp}=min, {resp}=range:LOW:HIGH or {resp}=target:T"
    if not parts:
        raise ConfigError(f"goal {spec!r} says nothing for {resp} to do; write it like {examples}.")
    typed = parts[0]
    kind = _KIND_ALIASES.get(typed.lower(), typed.lower())
    if kind not in KINDS:
        raise ConfigError(f"unknown goal {typed!r} in {spec!r}; write it like {examples}.")
    nums, opts = [], {}
    for p in parts[1:]:
        if "=" in p:
            key, value = (t.strip() for t in p.split("=", 1))
            key = key.lower().replace("-", "_")
            if key not in _GOAL_KEYS[kind]:
                if key in _ALL_GOAL_KEYS:
                    takers = ("target goals" if key == "weight_high"
                              else "target, max and min goals")
                    raise ConfigError(
                        f"goal {spec!r} sets {key!r}, which a {typed} goal does not use; only "
                        f"{takers} take it, and a {typed} goal takes {and_list(_GOAL_KEYS[kind])}."
                    )
                import difflib

                near = difflib.get_close_matches(key, _ALL_GOAL_KEYS, n=1, cutoff=0.6)
                hint = f" (did you mean {near[0]!r}?)" if near else ""
                raise ConfigError(
                    f"goal {spec!r} has an unknown key {key!r}{hint}; the keys of a {typed} goal "
                    f"are {and_list(_GOAL_KEYS[kind])}."
                )
            if key in opts:
                raise ConfigError(f"goal {spec!r} gives {key!r} twice; give it once.")
            opts[key] = _goal_number(value, spec, f"{key}=")
        elif p.lower().replace("-", "_") in _ALL_GOAL_KEYS:
            raise ConfigError(f"key {p!r} in goal {spec!r} needs a value, e.g. {p}=5.")
        else:
            nums.append(_goal_number(p, spec, ""))
    kw = {}
    if kind == "target":
        if len(nums) != 1:
            raise ConfigError(
                f"goal {spec!r} gives {_count(len(nums))}, but a target goal takes exactly one, "
                f"the target: {resp}={typed}:T (limits as low= and high=)."
            )
        kw["target"] = nums[0]
    elif kind == "in_range":
        if len(nums) not in (0, 2):
            raise ConfigError(
                f"goal {spec!r} gives {_count(len(nums))}, but a range goal takes two numbers, "
                f"{resp}={typed}:LOW:HIGH, or none for the data's range."
            )
        if nums:
            clash = [k for k in ("low", "high") if k in opts]
            if clash:
                raise ConfigError(
                    f"goal {spec!r} gives the limits twice (as numbers and as {clash[0]}=); "
                    f"write {resp}={typed}:LOW:HIGH or {resp}={typed}:low=LOW:high=HIGH."
                )
            kw["low"], kw["high"] = nums
    elif nums:
        raise ConfigError(
            f"goal {spec!r} gives {_count(len(nums))}, but a {typed} goal takes none: write "
            f"{resp}={typed}, with limits as low= and high=, e.g. {resp}={typed}:low=10:high=20."
        )
    importance = opts.get("importance", 3)
    if importance != int(importance):
        raise ConfigError(f"importance in goal {spec!r} must be a whole number from 1 to 5, "
                          f"not {importance:g}.")
    w = opts.get("weight", 1.0)
    return Goal(
        resp, kind, low=opts.get("low", kw.get("low")), high=opts.get("high", kw.get("high")),
        target=kw.get("target"), weight_low=opts.get("weight_low", w),
        weight_high=opts.get("weight_high", w), importance=int(importance),
    )


def _goal_number(text: str, spec: str, key: str) -> float:
    """``text`` of goal ``spec`` as a finite float (``key`` like ``"low="`` for messages)."""
    try:
        value = float(text)
    except ValueError:
        what = f"the {key[:-1]} value {text!r}" if key else repr(text)
        raise ConfigError(f"cannot read {what} in goal {spec!r} as a number.") from None
    if not np.isfinite(value):
        raise ConfigError(f"goal {spec!r} holds {key}{text}, which is not a finite number.")
    return value
