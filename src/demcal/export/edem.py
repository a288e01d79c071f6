"""The material card as the tables a user types into EDEM Creator.

One block per condition: the physics (contact model and rolling friction model by
their EDEM names, for particle-to-particle and particle-to-geometry), the material
table (Poisson's ratio, solid density, shear modulus; yield strength for the
Hysteretic Spring), the interaction table (coefficients of restitution, static and
rolling friction; damping and stiffness factors for the Hysteretic Spring; rolling
viscous damping for Type C; surface energy for JKR cohesion), the particle (its spheres and the size distribution of
the factory), then the lab record and the verification figures. Tables are CSV with
EDEM's field names and units in the header, so they can also be read by a script.
"""

from __future__ import annotations

import csv
import io
from typing import Any, Mapping

from demcal.export.text import calibrated_line, lab_line, number, verification_lines, warning_head, wrap


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
    for line in verification_lines(condition.get("verification", [])):
        lines += wrap(line, "# ")
    lines += ["", "[Physics]",
              f"Particle to Particle: base model {code['contact_model']}; rolling friction {code['rolling_model']}",
              f"Particle to Geometry: base model {code['contact_model']}; rolling friction {code['rolling_model']}",
              "", "[Materials]"]
    header = ["Material", "Poisson's Ratio", "Solid Density (kg/m3)", "Shear Modulus (Pa)"]
    if hysteretic:
        header.append("Yield Strength (Pa)")
    rows = []
    for name, m in condition["materials"].items():
        row = [name, number(m["poisson_ratio"]), number(m["density"]), number(m["shear_modulus"])]
        if hysteretic:
            row.append(number(m["yield_strength"]))
        rows.append(row)
    lines.append(_csv(header, rows))
    lines += ["", "[Interactions]"]
    header = ["Material 1", "Material 2", "Coefficient of Restitution", "Coefficient of Static Friction",
              "Coefficient of Rolling Friction"]
    if hysteretic:
        header += ["Damping Factor", "Stiffness Factor"]
    if type_c:
        header.append("Rolling Viscous Damping Ratio")
    if jkr:
        header.append("Surface Energy (J/m2)")
    rows = []
    for r in condition["interactions"]:
        row = [*r["materials"], number(r["restitution"]), number(r["static_friction"]), number(r["rolling_friction"])]
        if hysteretic:
            row += [number(r["damping_factor"]), number(r["stiffness_factor"])]
        if type_c:
            row.append(number(r["rolling_damping"]))
        if jkr:
            row.append(number(r["surface_energy"]))
        rows.append(row)
    lines.append(_csv(header, rows))
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


def _csv(header: list[str], rows: list[list[str]]) -> str:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue().rstrip("\n")
