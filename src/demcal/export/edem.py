"""The material card as the tables a user types into EDEM Creator.

One block per condition: the physics (contact model and rolling friction model by
their EDEM names, for particle-to-particle and particle-to-geometry), the material
table (Poisson's ratio, solid density, shear modulus; yield strength for the
Hysteretic Spring), the interaction table (coefficients of restitution, static and
rolling friction; damping and stiffness factors for the Hysteretic Spring; rolling
viscous damping for Type C; surface energy for JKR cohesion), the particle (its spheres and the size distribution of
the factory), then the lab record and the verification figures. Tables are CSV with
EDEM's field names and units in the header, so they can also be read by a script. The
solution set (:mod:`demcal.export.solution`) is given twice: each calibrated value with
its range in the comment lines at the top, and a ``low`` and a ``high`` column beside
each column of the material and interaction tables that holds a calibrated value (empty
in the rows whose value was not calibrated).
"""

from __future__ import annotations

import csv
import io
from typing import Any, Mapping

from demcal.export.text import (calibrated_line, lab_line, number, solution_lines, verification_lines,
                                 warning_head, wrap)

#: A material of the card -> the prefix of its parameter keys (steel's bulk values are
#: demcal's, not parameters); the other material of an interaction -> the prefix of the
#: pair's keys.
MATERIAL_PREFIX = {"particle": "particle", "film": "film"}
PAIR_PREFIX = {"particle": "particle", "steel": "wall", "film": "film"}


def to_edem(card: Mapping[str, Any]) -> str:
    """Every condition of ``card`` as an EDEM block, one after the other, under the card's
    warnings (comment lines)."""
    return warning_head(card, "edem") + "\n".join(condition_block(card, condition) for condition in card["conditions"])


def condition_block(card: Mapping[str, Any], condition: Mapping[str, Any]) -> str:
    code = card["codes"]["edem"]
    camp = card["campaign"]
    models = card["models"]
    hysteretic = code["contact_model"] == "Hysteretic Spring"
    type_c = code["rolling_model"] == "Type C Rolling Friction"
    jkr = code["contact_model"] == "Hertz-Mindlin with JKR Cohesion"
    lines = [f"# demcal material card for EDEM: campaign '{camp['name']}', condition '{condition['name']}'",
             f"# campaign hash {camp['hash']}",
             f"# demcal {card['demcal_version']}; virtual test {camp['test']}, profile {camp['profile']}"]
    if not code["transferable"]:
        lines.append(f"# NOT TRANSFERABLE: calibrated with demcal's contact.model = {models['contact']}, "
                     f"rolling.model = {models['rolling']}.")
        for reason in code["reasons"]:
            lines += wrap(f"{reason}.", "# ")
    for note in code.get("notes", []):
        lines += wrap(f"note: {note}.", "# ")
    lines += wrap(f"lab: {lab_line(condition['lab'])}", "# ")
    lines += wrap(calibrated_line(condition), "# ")
    for line in solution_lines(condition):
        lines += wrap(line, "# ")
    for line in verification_lines(condition.get("verification", [])):
        lines += wrap(line, "# ")
    lines += ["", "[Physics]",
              f"Particle to Particle: base model {code['contact_model']}; rolling friction {code['rolling_model']}",
              f"Particle to Geometry: base model {code['contact_model']}; rolling friction {code['rolling_model']}",
              "", "[Materials]"]
    ranges = condition.get("solution_set")
    columns = [("Poisson's Ratio", "poisson_ratio"), ("Solid Density (kg/m3)", "density"),
               ("Shear Modulus (Pa)", "shear_modulus")]
    if hysteretic:
        columns.append(("Yield Strength (Pa)", "yield_strength"))
    lines += _table(["Material"], columns, [([name], m, MATERIAL_PREFIX.get(name))
                                            for name, m in condition["materials"].items()], ranges)
    lines += ["", "[Interactions]"]
    columns = [("Coefficient of Restitution", "restitution"), ("Coefficient of Static Friction", "static_friction"),
               ("Coefficient of Rolling Friction", "rolling_friction")]
    if hysteretic:
        columns += [("Damping Factor", "damping_factor"), ("Stiffness Factor", "stiffness_factor")]
    if type_c:
        columns.append(("Rolling Viscous Damping Ratio", "rolling_damping"))
    if jkr:
        columns.append(("Surface Energy (J/m2)", "surface_energy"))
    lines += _table(["Material 1", "Material 2"], columns,
                    [(r["materials"], r, PAIR_PREFIX.get(r["materials"][1]))
                     for r in condition["interactions"]], ranges)
    part = card["particle"]
    size = part["size_distribution"]
    lines += ["", f"[Particle: {part['shape']}]",
              "# sphere positions relative to the centre of mass, principal axes"]
    lines.append(_csv(["Sphere", "Radius (mm)", "X (mm)", "Y (mm)", "Z (mm)"],
                      [[str(i + 1), number(s["radius"] * 1e3), *(number(x * 1e3) for x in s["centre"])]
                       for i, s in enumerate(part["spheres"])]))
    if "centre_distance" in part:
        lines.append(f"# distance between the sphere centres: {number(part['centre_distance'] * 1e3)} mm")
    lines += ["", "[Size distribution]"]
    if size["kind"] == "sieve":
        lines += [f"# sieve table coarse-grained x{number(size['coarse_grain'])}: lab sizes "
                  f"{number(size['lab_window_mm'][0])}-{number(size['lab_window_mm'][1])} mm "
                  f"({number(size['left_out_percent'])} % of the lab mass outside them left out); "
                  "Factory size: User Defined, by mass, the scale factors below on the particle above",
                  _csv(["Scale min", "Scale max", "Mass (%)"],
                       [[number(c["scale_min"]), number(c["scale_max"]), number(100 * c["mass_fraction"])]
                        for c in size["classes"]]), ""]
    else:
        lines += [f"Factory size: Random (uniform scale), Min {number(size['scale_min'])}, Max "
                  f"{number(size['scale_max'])} (scale factor on the particle above, by number)", ""]
    return "\n".join(lines)


def _table(lead: list[str], columns: list[tuple[str, str]], entries, ranges) -> list[str]:
    """A CSV table: the ``lead`` columns, then a column (title, property) of ``columns``
    each, with a low and a high column beside one that a row holds a calibrated value of
    with a range in ``ranges`` (the card's solution set; empty in the other rows).
    ``entries`` are (lead cells, values by property, the prefix of that row's parameter
    keys, or None)."""
    ranges = ranges or {}
    ranged = [any(prefix and f"{prefix}.{prop}" in ranges for _, _, prefix in entries) for _, prop in columns]
    header = list(lead)
    for (title, _), beside in zip(columns, ranged):
        header += [title, _titled(title, "low"), _titled(title, "high")] if beside else [title]
    rows = []
    for cells, values, prefix in entries:
        row = list(cells)
        for (_, prop), beside in zip(columns, ranged):
            row.append(number(values[prop]))
            ends = ranges.get(f"{prefix}.{prop}") if beside and prefix else None
            row += [number(ends["low"]), number(ends["high"])] if ends else [""] * (2 if beside else 0)
        rows.append(row)
    said = (["# low, high: the range of a calibrated value over its solution set (the comment at the top)"]
            if any(ranged) else [])
    return said + [_csv(header, rows)]


def _titled(title: str, end: str) -> str:
    """``Shear Modulus (Pa)`` -> ``Shear Modulus low (Pa)``; ``Damping Factor`` -> ``Damping Factor low``."""
    name, bracket, unit = title.partition(" (")
    return f"{name} {end}{bracket}{unit}"


def _csv(header: list[str], rows: list[list[str]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue().rstrip("\n")
