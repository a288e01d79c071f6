"""What the calibration loop recorded, as a user reads it: short sentences with labels
and units, numbers rounded to the precision the noise supports.

The loop keeps its precise record: the notes and stop reasons of each condition
(:class:`~demcal.campaign.outcome.LoopResult`, calibration.json) name responses by their
keys and give every number to two decimals, and a replay compares them to the bit. This
module renders that record for the terminal's summary
(:func:`demcal.campaign.calibration.describe`) and the report; nothing here changes
what is recorded.

* A response key becomes its label (``[[responses]] label, unit``, else read from the
  key: ``repose_angle_deg`` -> "repose angle", unit °).
* A response value is rounded to the precision of the condition's lab sd, a mean with its
  sd or interval by the GUM's rule (:mod:`demcal.rounding`), each with its unit.
* Each kind of sentence the loop writes is read against its template (:data:`PHRASES`)
  and said again, shorter; a text that matches none keeps its words, with labels for
  response keys and ``mean ± sd`` pairs rounded (:meth:`Words.plain`).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Callable

from demcal.rounding import measured, rounded

#: Unit suffixes of response names (``repose_angle_deg``) and the unit they stand for.
UNIT_SUFFIXES = {"deg": "°", "rad": "rad", "percent": "%", "pct": "%", "m": "m", "mm": "mm",
                 "s": "s", "pa": "Pa", "kg": "kg", "n": "N", "j": "J", "kgm3": "kg/m³"}

#: A number as the loop writes one (``{x:.2f}``, ``{x:g}``), and a response key.
NUMBER = r"-?\d+(?:\.\d+)?(?:e[+-]?\d+)?|nan|-?inf"
KEY = r"[A-Za-z_][\w.]*"
#: What a ``{name}`` of a template (:func:`_template`) stands for, besides a number
#: (any other name) and a response key (``r``, ``r1``, ...); a trailing digit names a
#: second group of the same kind.
GROUPS = {"i": r"\d+", "j": r"\d+", "k": r"\d+", "n": r"\d+", "ks": r"[\d, ]+", "way": "ascent|descent",
          "dir": "higher|lower", "why": ".+?", "where": ".*?", "ys": ".*?", "noise": ".*", "far": ".*",
          "said": ".*", "reason": ".*", "rest": ".*", "status": r"[^)]+", "p": r"\S+", "cheap": r"\S+", "prod": r"\S+"}


def response_words(name: str, label: str | None = None, unit: str | None = None) -> tuple[str, str | None]:
    """``(label, unit)`` of a response: the campaign's, else read from its name
    (``repose_angle_deg`` -> ``("Repose angle", "°")``)."""
    if label is None or label == name:
        words = str(name).split("_")
        if unit is None and len(words) > 1 and words[-1].lower() in UNIT_SUFFIXES:
            unit = UNIT_SUFFIXES[words.pop().lower()]
        label = " ".join(words)
        label = label[:1].upper() + label[1:]
    return label, unit


def clause(text: str) -> str:
    """``text`` to follow a colon: its first letter lower case (not an acronym's)."""
    return text[:1].lower() + text[1:] if text[1:2].islower() or text[1:2] == " " else text


def sentence(text: str) -> str:
    """``text`` as a sentence: a capital first letter and a full stop."""
    text = text.strip()
    if not text:
        return text
    text = text[:1].upper() + text[1:]
    return text if text.endswith((".", "!", "?")) else text + "."


@dataclass(frozen=True)
class Words:
    """How one campaign's responses read (one condition's, for the lab sds)."""

    campaign: Any  #: :class:`~demcal.campaign.config.Campaign`
    condition: Any = None  #: :class:`~demcal.campaign.config.Condition`, for its lab sds

    def label(self, response: str) -> str:
        """The response's label within a sentence: ``angle of repose β``."""
        return clause(self.title(response))

    def title(self, response: str) -> str:
        """The response's label as it begins a sentence or heads a column: ``Angle of repose β``."""
        return self._words(response)[0]

    def unit(self, response: str) -> str | None:
        return self._words(response)[1]

    def _words(self, response: str) -> tuple[str, str | None]:
        found = next((r for r in self.campaign.responses if r.name == response), None)
        return response_words(response, found.label or None if found else None,
                              found.unit or None if found else None)

    def lab_sd(self, response: str) -> float:
        """The condition's lab sd of ``response`` (of the first condition that has one
        when no condition is given); NaN if none."""
        conditions = [self.condition] if self.condition is not None else list(self.campaign.conditions)
        for condition in conditions:
            for t in condition.targets:
                if t.response == response and t.sd is not None:
                    return float(t.sd)
        return float("nan")

    def value(self, x, response: str, uncertainty: float | None = None) -> str:
        """A value of ``response`` with its unit, to the precision of ``uncertainty``
        (default: the lab sd)."""
        return rounded(float(x), self.lab_sd(response) if uncertainty is None else uncertainty, self.unit(response))

    def window(self, mean, sd, response: str) -> str:
        """``31.1 ± 2.1°``: a mean with its sd (or interval half-width)."""
        return measured(float(mean), float("nan") if sd is None else float(sd), self.unit(response))

    @property
    def responses(self) -> list[str]:
        return [r.name for r in self.campaign.responses]

    def only_unit(self) -> str | None:
        """The unit every response of the campaign shares, else None."""
        units = {self.unit(r) for r in self.responses}
        return units.pop() if len(units) == 1 else None

    def plain(self, text: str, **exact: float) -> str:
        """A recorded text as a user reads it, one sentence: its template's short
        sentence (:data:`PHRASES`), else its own words with response keys as labels and
        ``mean ± sd`` pairs rounded; without the condition's name it may begin with.
        ``exact`` gives a template's fields their unrounded values (the text's carry two
        decimals, and a number rounded twice may end elsewhere)."""
        text = str(text).strip().rstrip(".")
        if self.condition is not None and text.startswith(f"{self.condition.name}: "):
            text = text[len(self.condition.name) + 2:]  # the reader knows whose it is
        for pattern, say in PHRASES:
            match = pattern.fullmatch(text)
            if match and all(r in self.responses for r in _responses(match)):
                return sentence(say(self, _With(match, **exact) if exact else match))
        return sentence(self.keys(text))

    def keys(self, text: str) -> str:
        """Response keys as labels (``key = 20`` as ``label 20°``), ``a ± b`` rounded."""
        for r in sorted(self.responses, key=len, reverse=True):
            text = re.sub(rf"\b{re.escape(r)} = ({NUMBER})", lambda m, r=r: f"{self.label(r)} {self.value(m[1], r)}",
                          text)
            text = re.sub(rf"\b{re.escape(r)}\b", self.label(r), text)
        unit = self.only_unit()
        return re.sub(f"({NUMBER}) ± ({NUMBER})", lambda m: measured(float(m[1]), float(m[2]), unit), text)


def _template(text: str) -> re.Pattern:
    """A template as the loop's f-string reads, ``{name}`` for each field
    (:data:`GROUPS`), compiled to match a whole recorded text."""
    parts = re.split(r"\{(\w+)\}", text)
    out = []
    for i, part in enumerate(parts):
        if i % 2 == 0:
            out.append(re.escape(part))
            continue
        kind = part.rstrip("0123456789") or part
        pattern = KEY if kind == "r" else GROUPS.get(part, GROUPS.get(kind, NUMBER))
        out.append(f"(?P<{part}>{pattern})")
    return re.compile("".join(out))


def _responses(match: re.Match) -> list[str]:
    return [v for k, v in match.groupdict().items() if re.fullmatch(r"r\d*", k)]


def _reach(w: Words, r: str, lo, hi, t) -> str:
    """What a box reaches toward the target: ``at most 38.3°``."""
    lo, hi, t = float(lo), float(hi), float(t)
    return (f"at most {w.value(hi, r)}" if t > hi else f"at least {w.value(lo, r)}" if t < lo
            else f"{w.value(lo, r)} to {w.value(hi, r)}")


#: Why a box is the last one, as the loop records it, and as a user reads it.
_LAST_BOX = {"no path leads on from it": "no path leads further",
             "the parameters' limits stop the path from it": "the parameters' limits stop any path beyond it",
             "a path turned back": "the path beyond it turned back"}


def _edge(w: Words, m: re.Match) -> str:
    r = m["r"]
    return (f"box {m['i']} reaches {_reach(w, r, m['lo'], m['hi'], m['t'])} ({w.label(r)}), inside the lab's "
            f"{w.window(m['t'], m['sd'], r)} but not its middle half; {_LAST_BOX.get(m['why'], m['why'])}, so the "
            "parameters are solved at the box's edge")


def _turned(how: str) -> Callable[[Words, re.Match], str]:
    def say(w: Words, m: re.Match) -> str:
        return (f"the path from box {m['i']} turns back into box {m['j']} {how} {_lab(w, m)}: the response peaks "
                f"between them, so box {m['i']} is the last and the target lies beyond what the test reaches")
    return say


def _misses(w: Words, m: re.Match) -> str:
    r, why = m["r"], m["why"]
    model = _template("the model predicted {p} but the simulations gave {m} (model error plus run-to-run noise"
                      "{rest})").fullmatch(why)
    if model:
        sd = re.fullmatch(f", replicate sd ({NUMBER})", model["rest"])
        why = (f"the model predicted {w.value(model['p'], r)}: model error plus seed noise"
               + (f" (sd {w.value(sd[1], r, float(sd[1]))} between runs)" if sd else ""))
    return (f"{w.title(r)}: the simulated mean {w.value(m['m'], r)} misses the lab's {w.window(m['t'], m['sd'], r)} "
            f"by {w.value(m['d'], r)}; {why}")


def _production(w: Words, m: re.Match) -> str:
    r = w.responses[0]
    noise = m["noise"]
    pooled = re.match(f"seed sd ({NUMBER}) pooled over the production points( and the stored study's)?, df (\\d+)",
                      noise)
    if pooled:
        noise = (f"seed sd {w.value(pooled[1], r, float(pooled[1]))} over {pooled[3]} df"
                 + (" with the stored study's" if pooled[2] else ""))
    where = re.sub(f"read ({NUMBER})", lambda x: f"read {w.value(x[1], r)}", m["where"])
    n = int(m["n"])
    return (f"{n} run{'s' if n != 1 else ''} at {m['p']}{where}: {w.window(m['m'], m['h'], r)} (95 %; {noise}), "
            f"against the lab's {w.window(m['t'], m['sd'], r)}")


def _lab(w: Words, m, key: str = "t") -> str:
    """``the lab's 39.9° (angle of repose β)``: the target a sentence is about."""
    return f"the lab's {w.value(m[key], m['r'])} ({w.label(m['r'])})"


def _span(w: Words, m) -> str:
    """``16.0° to 38.2°``: what a box or model reaches."""
    return f"{w.value(m['lo'], m['r'])} to {w.value(m['hi'], m['r'])}"


def _numbers(w: Words, r: str, text: str) -> str:
    """Each number of ``text`` as a value of ``r``."""
    return re.sub(NUMBER, lambda x: w.value(x[0], r), text)


def _limits(w: Words, m: re.Match) -> str:
    r = m["r"]
    text = f"{_lab(w, m)} lies beyond what the test reaches within the parameters' physical limits"
    groups = m.groupdict()
    if "best" not in groups:
        return text + f", which stop any path from box {m['i']}"
    text += f": the path from box {m['i']} ends at {w.value(m['best'], r)}"
    if "m" in groups:
        text += f"; its production runs there gave {w.value(m['m'], r)}, outside {w.window(m['t2'], m['sd'], r)}"
    return text


#: The sentences the loop writes (:mod:`demcal.campaign.states`, :mod:`~demcal.campaign.ascent`,
#: :mod:`~demcal.campaign.solve`, :mod:`~demcal.campaign.calibrate`), as their f-strings
#: read, each without the condition's name before it and the full stop after it, with
#: the short sentence a user reads instead.
PHRASES: list[tuple[re.Pattern, Callable[[Words, re.Match], str]]] = [(_template(text), say) for text, say in [
    ("{why}, so box {i} reaches {r} {lo} to {hi} with the discrepancy, into the lab window {t} ± {sd} but not its "
     "middle half: solved at the box's edge", _edge),
    ("the {k} box moves allowed are spent and box {i} reaches {r} {lo} to {hi} with the discrepancy, into the lab "
     "window {t} ± {sd} but not its middle half: solved at the box's edge",
     lambda w, m: _edge(w, _With(m, why=f"the {m['k']} box moves allowed are spent"))),
    ("the path of steepest {way} from box {i} turns back into box {j} crossing {r} = {t} where the production runs "
     "missed it (its new box would lie inside box {j2}): the response peaks between them, so no further move is "
     "made and box {i2} is the last; the target lies beyond what the test reaches along the paths",
     _turned("where the production runs missed")),
    ("the path of steepest {way} from box {i} turns back into box {j} without crossing {r} = {t} (its new box would "
     "lie inside box {j2}): the response peaks between them, so no further move is made and box {i2} is the last; "
     "the target lies beyond what the test reaches along the paths", _turned("without reaching")),
    ("the first production point lies outside the points the stored {cheap} → {prod} bias of {r} was measured at "
     "({far}): its run tests an extrapolation of that bias, and the loop learns the bias from it",
     lambda w, m: (f"the first production point lies outside the settings where the stored {m['cheap']} → "
                   f"{m['prod']} correction of the {w.label(m['r'])} was measured ({m['far']}); its runs test that "
                   "correction, and the loop learns it from them")),
    ("the target {r} = {t} lies outside what the model reaches inside the design box ({lo} to {hi}); the "
     "parameters simulated are the box's nearest point ({edge}), so the target cannot be met without wider factor "
     "levels",
     lambda w, m: (f"{_lab(w, m)} lies outside what the model reaches in the design box ({_span(w, m)}); the box's "
                   f"nearest point ({w.value(m['edge'], m['r'])}) is simulated instead: widen the factor levels to "
                   "meet it")),
    ("{k} of {n} design runs of {r} have no result (failed or not run) and are left out of the fit",
     lambda w, m: (f"{m['k']} of {m['n']} design runs have no {w.label(m['r'])} (failed or not run) and are left "
                   "out of the fit")),
    ("the loop stopped ({status}): {reason}",
     lambda w, m: f"the loop stopped ({m['status']}): {clause(w.plain(m['reason']).rstrip('.'))}"),
    ("{r}: no verification run is done yet", lambda w, m: f"{w.title(m['r'])}: no verification run is done yet"),
    ("{r}: simulated {m} misses the lab's {t} ± {sd} by {d}; {why}", _misses),
    ("the production mean lies inside the lab's mean ± sd and its 95 % interval is narrower than the lab sd{where}",
     lambda w, m: ("the production mean lies inside the lab's mean ± sd, with a 95 % interval narrower than the "
                   "lab sd" + m["where"])),
    ("the target {r} = {t} lies outside what box {i} reaches ({lo} to {hi} with the discrepancy) and the {k} box "
     "moves allowed are spent; raise [calibration] box_moves or widen the factor levels",
     lambda w, m: (f"{_lab(w, m)} lies outside what box {m['i']} reaches ({_span(w, m)}) and the {m['k']} box "
                   "moves allowed are spent: raise [calibration] box_moves or widen the factor levels")),
    ("{r}: the best point of box {i} on the corrected surface is the one whose production mean {m} already misses "
     "{t} ± {sd}, and what its runs taught does not move it: the target lies at the edge of what the test reaches "
     "here; widen the factor limits or raise [calibration] box_moves",
     lambda w, m: (f"the best point of box {m['i']} gives {w.value(m['m'], m['r'])} ({w.label(m['r'])}), outside "
                   f"the lab's {w.window(m['t'], m['sd'], m['r'])}, and its runs do not move it: the target lies at "
                   "the edge of what the test reaches; widen the factor limits or raise [calibration] box_moves")),
    ("{r}: the production mean {m} still misses {t} ± {sd} after {k} solves on the corrected surface; raise "
     "[calibration] iterations",
     lambda w, m: (f"the production mean {w.value(m['m'], m['r'])} ({w.label(m['r'])}) still misses the lab's "
                   f"{w.window(m['t'], m['sd'], m['r'])} after {m['k']} solves: raise [calibration] iterations")),
    ("{r}: the mean {m} is inside the lab spread, but its 95 % interval ± {h} is not narrower than the lab sd {sd} "
     "after {k} replicates; raise [calibration] max_replicates",
     lambda w, m: (f"the mean {w.window(m['m'], m['h'], m['r'])} (95 %, {w.label(m['r'])}) lies inside the lab's "
                   f"spread, but its interval is not narrower than the lab sd {w.value(m['sd'], m['r'])} after "
                   f"{m['k']} runs: raise [calibration] max_replicates")),
    ("the model is flat at the centre of box {i}, so no path leads toward {r} = {t}",
     lambda w, m: f"the model is flat at the centre of box {m['i']}, so no path leads toward {_lab(w, m)}"),
    ("{r} = {t} lies beyond what the test reaches within the parameters' physical limits: they stop the path of "
     "steepest {way} from box {i} at once", _limits),
    ("{r} = {t} lies beyond what the test reaches within the parameters' physical limits: the steepest path from "
     "box {i} ends at the limits at {best}", _limits),
    ("{r} = {t} lies beyond what the test reaches within the parameters' physical limits: the steepest path from "
     "box {i} ends at the limits at {best}; its production runs there gave {m}, outside {t2} ± {sd}", _limits),
    ("{r} = {t}: the path of steepest {way} from box {i} reads {ys} beyond the box, no {dir} than box {i2} reaches "
     "itself ({edge}): the response peaks in box {i3}, so no box is laid beyond it and the target lies beyond what "
     "the test reaches",
     lambda w, m: (f"the path from box {m['i']} reads {_numbers(w, m['r'], m['ys']) or 'nothing'} beyond the box, "
                   f"no {m['dir']} than the box reaches itself ({w.value(m['edge'], m['r'])}): the "
                   f"{w.label(m['r'])} peaks in box {m['i']}, and the lab's {w.value(m['t'], m['r'])} lies beyond "
                   "what the test reaches")),
    # the lines of a loop's history (:class:`~demcal.campaign.outcome.Step`)
    ("{p} x{n}{where}: {m} ± {h} (95 %; {noise}) against {t} ± {sd}", _production),
    ("target {t} outside box {i} ({lo} to {hi}); steepest {way} gave {said} at steps {ks}",
     lambda w, m: (f"the lab's {w.value(m['t'], w.responses[0])} lies outside box {m['i']} "
                   f"({w.value(m['lo'], w.responses[0])} to {w.value(m['hi'], w.responses[0])}); the path of "
                   f"steepest {m['way']} gave {_numbers(w, w.responses[0], m['said'])} at steps {m['ks']}")),
]]


class _With:
    """A match with some of its groups replaced (two templates, one rendering)."""

    def __init__(self, match: re.Match, **groups):
        self.match, self.groups = match, groups

    def __getitem__(self, key):
        return self.groups[key] if key in self.groups else self.match[key]

    def groupdict(self) -> dict:
        return {**self.match.groupdict(), **self.groups}


def half_width(result, verdict) -> float:
    """Half-width of the 95 % interval of the simulated mean: the loop's (its seed sd
    pooled over the production points) when a loop verified it, else the replicates' own
    t interval (NaN with fewer than two)."""
    import numpy as np
    from scipy import stats

    if result.loop is not None and verdict.simulated:
        for step in reversed(result.loop.history):
            if (step.stage == "production" and step.half_width is not None and step.simulated is not None
                    and np.isclose(step.simulated, verdict.simulated_mean)):
                return float(step.half_width)
    n = len(verdict.simulated)
    if n < 2:
        return float("nan")
    return float(stats.t.ppf(0.975, n - 1) * verdict.simulated_sd / math.sqrt(n))


def stop(campaign, result) -> str:
    """How a condition's loop ended, in one sentence: a verified one from its numbers (the
    mean of n runs with its 95 % interval, inside the lab's mean ± sd), any other from its
    status and its recorded reason (:meth:`Words.plain`)."""
    loop = result.loop
    w = Words(campaign, result.condition)
    if loop is None:
        return ""
    if loop.status == "verified" and all(v.simulated for v in result.verdicts):
        parts = []
        for v in result.verdicts:
            n = len(v.simulated)
            parts.append(f"the mean {w.label(v.response)} of {n} run{'s' if n != 1 else ''}, "
                         f"{w.window(v.simulated_mean, half_width(result, v), v.response)} (95 %), lies inside the "
                         f"lab's {w.window(v.target, v.lab_sd, v.response)}")
        where = ""
        if loop.on_path:
            on = loop.on_path
            where = (f", at {'the end of' if on.get('limit') else 'a point on'} the path from box {on['box']}: "
                     "one point, with no solution set around it")
        return sentence("verified: " + "; ".join(parts) + where)
    return sentence(f"{loop.status}: {clause(w.plain(loop.reason).rstrip('.'))}")


def step(campaign, condition, line) -> str:
    """One line of a loop's history (:class:`~demcal.campaign.outcome.Step`) as a user
    reads it; a production line's mean and half-width are its own, unrounded."""
    exact = {}
    if line.stage == "production" and line.simulated is not None and line.half_width is not None:
        exact = {"m": line.simulated, "h": line.half_width}
    return Words(campaign, condition).plain(line.text, **exact)


def notes(campaign, result) -> list[str]:
    """A condition's notes as a user reads them (:meth:`Words.plain`), each once, without
    the one that repeats why the loop stopped (:func:`stop` says it)."""
    w = Words(campaign, result.condition)
    out = []
    for note in result.notes:
        if note.startswith("the loop stopped (") and result.loop is not None:
            continue
        text = w.plain(note)
        if text not in out:
            out.append(text)
    return out
