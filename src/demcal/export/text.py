"""Wording shared by the text formats of the material card (LIGGGHTS, EDEM)."""

from __future__ import annotations

import textwrap
from typing import Any, Mapping

from demcal.export.solution import THRESHOLD

#: Code key of the card -> its name in a sentence.
CODE_NAMES = {"edem": "EDEM", "liggghts": "LIGGGHTS 3.8"}


def number(x, digits: int = 6) -> str:
    """A number with up to ``digits`` significant digits, as LIGGGHTS and EDEM read it."""
    try:
        return f"{float(x):.{digits}g}"
    except (TypeError, ValueError):
        return str(x)


def or_list(words) -> str:
    """``a``, ``a or b``, ``a, b or c``: the choices of a message."""
    words = [str(w) for w in words]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " or " + words[-1]


def wrap(text: str, prefix: str, width: int = 88) -> list[str]:
    """``text`` as comment lines of at most ``width`` characters starting with ``prefix``."""
    return textwrap.wrap(text, width=width, initial_indent=prefix, subsequent_indent=prefix + "  ",
                         break_on_hyphens=False)


def lab_line(lab: Mapping[str, Any]) -> str:
    """The lab record of a card condition in one line: sample, moisture, bulk density, targets."""
    parts = []
    sample = lab.get("sample")
    if sample:
        text = f"sample {sample['name']}"
        if "moisture_percent" in sample:
            sd = sample.get("moisture_sd_percent")
            text += f", moisture {number(sample['moisture_percent'])}" + (f" ± {number(sd)}" if sd is not None else "") + " %"
        if "bulk_density" in sample:
            text += f", bulk density {number(sample['bulk_density'])} kg/m3"
        parts.append(text)
    for t in lab["targets"]:
        sd = f" ± {number(t['sd'])}" if t.get("sd") is not None else ""
        parts.append(f"lab {t['response']} {number(t['mean'])}{sd}")
    return "; ".join(parts)


def verification_lines(verification) -> list[str]:
    """One line per verified response: target, prediction, simulated mean ± sd (n), error
    and whether it lies inside the lab's sd."""
    if not verification:
        return ["verification: none yet"]
    out = []
    for v in verification:
        if not isinstance(v, Mapping):
            continue
        sd = f" ± {number(v['lab_sd'])}" if v.get("lab_sd") is not None else ""
        simulated = v.get("simulated") or []
        if simulated and v.get("simulated_mean") is not None:
            spread = f" ± {number(v['simulated_sd'], 3)}" if v.get("simulated_sd") is not None else ""
            inside = {True: "inside", False: "outside"}.get(v.get("within_lab_sd"), "no lab sd for")
            err = v.get("relative_error_percent")
            result = (f"simulated {number(v['simulated_mean'], 4)}{spread} (n = {len(simulated)})"
                      + (f", error {number(err, 3)} %" if err is not None else "") + f", {inside} the lab sd")
        else:
            result = "not simulated yet"
        predicted = f", predicted {number(v['predicted'], 4)}" if v.get("predicted") is not None else ""
        out.append(f"verification: {v.get('response')} target {number(v.get('target'))}{sd}{predicted}, {result}")
    return out


def calibrated_line(condition: Mapping[str, Any]) -> str:
    """Which values of a card condition were calibrated, and where the others come from."""
    params = condition["parameters"]
    calibrated = [f"{k} = {number(v['value'])}" for k, v in params.items() if v["source"] == "calibrated"]
    fixed = [k for k, v in params.items() if v["source"] == "fixed"]
    text = f"calibrated: {', '.join(calibrated) or 'none'}"
    if fixed:
        text += f"; fixed by the campaign file: {', '.join(fixed)}"
    taken: dict[str, list[str]] = {}  # source -> values another campaign calibrated (from_campaign)
    for k, v in params.items():
        if v["source"] not in ("calibrated", "fixed", "default", "demcal default"):
            taken.setdefault(v["source"], []).append(f"{k} = {number(v['value'])}")
    for source, values in taken.items():
        text += f"; {source}: {', '.join(values)}"
    return text + "; every other value is a default (the JSON card gives each value's source)."


def solution_lines(condition: Mapping[str, Any]) -> list[str]:
    """The condition's solution set as comment text: one line saying what it is, then each
    calibrated value beside its range (:mod:`demcal.export.solution`), rounded as a reader
    reads them (:func:`demcal.rounding.ranged`: to two significant digits of the range's
    width); one line when there is none (the card's warnings say why)."""
    from demcal.rounding import ranged

    ranges = condition.get("solution_set")
    if not ranges:
        return ["solution set: none, so the calibrated values are one point with no ranges (a warning "
                "above says why)."]
    params = condition["parameters"]
    out = ["solution set: each calibrated value with its range over the settings whose fitted surface "
           f"meets every lab mean (desirability >= {THRESHOLD:g}); not widened for the lab sd, the model's "
           "prediction interval or the seed noise (the JSON card's solution_set.meaning says more):"]
    for key, r in ranges.items():
        if key == "meaning":
            continue
        value, low, high = ranged(params[key]["value"], r["low"], r["high"], r["unit"])
        out.append(f"  {key} = {value}, range {low} to {high}")
    return out


def not_transferable(code: str, wrong: list[str], choose: list[str]) -> str:
    """The card's warning that values calibrated with the ``wrong`` models do not carry
    over to ``code`` ("edem", "liggghts"), with the models to ``choose`` instead."""
    return (f"{_transfer_lead(code)} whose models differ from demcal's {' and '.join(wrong)}; choose "
            f"{' and '.join(choose)} in [experiment.settings] before the design, and calibrate again.")


def _transfer_lead(code: str) -> str:
    return f"the values do not carry over to {CODE_NAMES[code]},"


def warning_head(card: Mapping[str, Any], code: str) -> str:
    """The card's warnings as comment lines for the top of ``code``'s text, then a blank
    line ("" without warnings); the one on the models is left to the blocks, which say it
    in full (NOT TRANSFERABLE)."""
    shown = [w for w in card.get("warnings", []) if not w.startswith(_transfer_lead(code))]
    if not shown:
        return ""
    lines = [f"# demcal material card: {len(shown)} warning{'s' if len(shown) > 1 else ''}; read "
             f"{'them' if len(shown) > 1 else 'it'} before using the values."]
    for warning in shown:
        lines += wrap(f"WARNING: {warning}", "# ")
    return "".join(f"{line}\n" for line in lines) + "\n"
