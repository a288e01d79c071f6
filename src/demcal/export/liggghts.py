"""The material card as a LIGGGHTS 3.8 input-script snippet.

One block per condition, each complete by itself: paste *one* into an input script
after ``create_box`` and before the walls, insertion and ``run`` commands. It sets the
granular pair style, the material and pair properties (``fix property/global``), the
particle template and its size distribution. What the surrounding script must provide
is listed in the block's header (SI units, ``atom_style granular``, ``newton off``,
``create_box`` with the block's number of atom types, ``fix multisphere`` for a
multi-sphere template). Its header comments give each calibrated value beside the range
of its solution set (:mod:`demcal.export.solution`), or say there is none.

Models (LIGGGHTS-PUBLIC 3.8 sources: ``src/normal_model_hertz.h``,
``src/rolling_model_cdt.h``, ``src/rolling_model_epsd.h``, ``src/global_properties.cpp``;
docs ``doc/gran_model_hertz.txt``, ``doc/gran_rolling_friction_*.txt``,
``doc/fix_particletemplate_multisphere.txt``):

* demcal ``hertz_mindlin`` = ``model hertz tangential history``: the same Hertz normal
  and Mindlin no-slip tangential springs with the Tsuji damping ``-2 sqrt(5/6) beta
  sqrt(S m*)`` on both (tangential damping on, force not limited: LIGGGHTS' defaults).
  LIGGGHTS 3.8 has no Walton-Braun Hysteretic Spring and no linear spring on the yield
  strength: a card calibrated with those still gets a runnable block with ``hertz``, under
  a comment that the values do not carry over.
* rolling: demcal ``cdt`` = ``rolling_friction cdt``; ``type_c`` -> ``epsd`` (Ai et al.
  model C; LIGGGHTS takes the secant normal stiffness); ``type_a`` (EDEM's standard
  rolling friction) and ``type_a_limited`` (the same with a moment limiter) have no LIGGGHTS
  counterpart -> ``cdt``, flagged as not transferable.
* property names: ``youngsModulus``, ``poissonsRatio`` (``peratomtype``),
  ``coefficientRestitution``, ``coefficientFriction``, ``coefficientRollingFriction``,
  ``coefficientRollingViscousDamping`` (``peratomtypepair``). demcal stores the shear
  modulus G; LIGGGHTS takes Young's modulus ``E = 2 G (1 + nu)``.
* LIGGGHTS refuses ``youngsModulus`` below 5e6 Pa or above 1e9 Pa in SI units unless
  ``soft_particles yes`` / ``hard_particles yes`` is given (``global_properties.cpp``),
  and a restitution of 0.05 or less.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

from demcal.export.text import (calibrated_line, lab_line, number, solution_lines, verification_lines,
                                 warning_head, wrap)

#: Atom type of each material, in this order.
MATERIAL_ORDER = ("particle", "steel", "film")

#: LIGGGHTS' sanity limits on Young's modulus in SI units [Pa] (global_properties.cpp).
SOFT_LIMIT = 5.0e6
HARD_LIMIT = 1.0e9

#: IDs of what a block defines, so that a surrounding script can refer to them.
DISTRIBUTION_ID = "dc_pdd"
TEMPLATE_ID = "dc_pts"

#: Classes of the discrete size distribution that stands for a uniform scale factor.
SIZE_CLASSES = 5

#: Primes for the template and distribution seeds (LIGGGHTS wants primes above 10000).
_FIRST_SEED = 15485863


def to_liggghts(card: Mapping[str, Any]) -> str:
    """Every condition of ``card`` as a LIGGGHTS 3.8 block, one after the other, under the
    card's warnings (comment lines)."""
    blocks = [condition_block(card, condition) for condition in card["conditions"]]
    head = warning_head(card, "liggghts")
    if len(blocks) > 1:
        names = ", ".join(f"'{c['name']}'" for c in card["conditions"])
        head += (f"# demcal material card: {len(blocks)} conditions ({names}), one block each.\n"
                 f"# Paste ONE block into an input script; `demcal export --condition NAME` writes one.\n\n")
    return head + "\n".join(blocks)


def atom_types(condition: Mapping[str, Any]) -> dict[str, int]:
    """Material name -> LIGGGHTS atom type (1, 2, ...) of a card condition."""
    present = [m for m in MATERIAL_ORDER if m in condition["materials"]]
    return {name: i + 1 for i, name in enumerate(present)}


def condition_block(card: Mapping[str, Any], condition: Mapping[str, Any]) -> str:
    """One condition's LIGGGHTS snippet."""
    code = card["codes"]["liggghts"]
    types = atom_types(condition)
    n = len(types)
    mats = condition["materials"]
    pairs = _pair_table(condition, types)
    rolling = code["rolling_model"]
    params = condition["parameters"]
    lines = _header(card, condition, code, types)

    youngs = {m: mats[m]["youngs_modulus"] for m in types}
    soft, hard = min(youngs, key=youngs.get), max(youngs, key=youngs.get)
    if youngs[soft] < SOFT_LIMIT:
        lines.append(f"soft_particles yes   # {soft} Young's modulus {number(youngs[soft])} Pa is below "
                     f"LIGGGHTS' {number(SOFT_LIMIT)} Pa sanity limit")
    if youngs[hard] > HARD_LIMIT:
        lines.append(f"hard_particles yes   # {hard} Young's modulus {number(youngs[hard])} Pa is above "
                     f"LIGGGHTS' {number(HARD_LIMIT)} Pa sanity limit")
    low_e = sorted({r["restitution"] for r in condition["interactions"] if r["restitution"] <= 0.05})
    if low_e:
        lines.append(f"# WARNING: LIGGGHTS refuses a coefficient of restitution of 0.05 or less "
                     f"(here {', '.join(number(e) for e in low_e)}); this block stops there.")
    model = code["pair_style"].removeprefix("gran ")
    lines += [f"pair_style {code['pair_style']}", "pair_coeff * *", ""]
    lines.append("# Young's modulus E = 2 G (1 + nu) [Pa] from demcal's shear modulus G; Poisson ratio [-]")
    lines.append("fix dc_youngs all property/global youngsModulus peratomtype "
                 + " ".join(number(v) for v in youngs.values()))
    lines.append("fix dc_poisson all property/global poissonsRatio peratomtype "
                 + " ".join(number(mats[m]["poisson_ratio"]) for m in types))
    lines.append("# pair tables, row i = atom type i: " + ", ".join(f"{t} = {m}" for m, t in types.items()))
    properties = [("dc_restitution", "coefficientRestitution", "restitution"),
                  ("dc_friction", "coefficientFriction", "static_friction")]
    if rolling:
        properties.append(("dc_rolling", "coefficientRollingFriction", "rolling_friction"))
    if rolling == "epsd":
        properties.append(("dc_rolling_damping", "coefficientRollingViscousDamping", "rolling_damping"))
    for fix_id, name, prop in properties:
        lines.append(f"fix {fix_id} all property/global {name} peratomtypepair {n} &")
        rows = [" ".join(number(pairs[(i, j)][prop]) for j in range(1, n + 1)) for i in range(1, n + 1)]
        lines += [f"    {row}" + (" &" if k < n - 1 else "") for k, row in enumerate(rows)]
    lines.append("")
    lines += _template(card, condition, types)
    lines.append("")
    lines.append(f"# Walls take the same model keywords, e.g. (atom type {types['steel']} = steel):")
    lines.append(f"#   fix dc_floor all wall/gran {model} primitive type {types['steel']} zplane 0.0")
    tr = _rayleigh_time(card, params)
    if tr is not None:
        lines.append(f"# Time step: at most 20 % of the Rayleigh time of the smallest sphere "
                     f"({number(tr)} s): timestep {number(0.2 * tr, 2)}")
    return "\n".join(lines) + "\n"


def _header(card, condition, code, types) -> list[str]:
    camp = card["campaign"]
    models = card["models"]
    bar = "# " + "-" * 86
    lines = [bar]
    if not code["transferable"]:
        lines.append("# !!! NOT TRANSFERABLE TO LIGGGHTS !!!")
        lines += wrap(f"These values were calibrated with demcal's contact.model = {models['contact']} and "
                      f"rolling.model = {models['rolling']}.", "# !!! ")
        for reason in code["reasons"]:
            lines += wrap(f"{reason}.", "# !!! ")
        lines += wrap("This block runs in LIGGGHTS 3.8 with the nearest models, but the calibrated values "
                      "are not valid for them without the new calibration said above.", "# !!! ")
        lines.append(bar)
    lines += [f"# demcal material card for LIGGGHTS 3.8: campaign '{camp['name']}', condition "
              f"'{condition['name']}'",
              f"# campaign hash {camp['hash']}",
              f"# demcal {card['demcal_version']}; virtual test {camp['test']}, profile {camp['profile']}",
              f"# contact model: demcal {models['contact']} -> LIGGGHTS {code['contact_model']}",
              f"# rolling model: demcal {models['rolling']} -> LIGGGHTS {code['rolling_model'] or 'none'}"]
    lines += wrap(f"lab: {lab_line(condition['lab'])}", "# ")
    for line in verification_lines(condition.get("verification", [])):
        lines += wrap(line, "# ")
    unused = _unused(card, condition, code)
    if unused:
        lines += wrap(f"not used by LIGGGHTS' {code['contact_model']}: {unused}", "# ")
    lines += wrap(calibrated_line(condition), "# ")
    for line in solution_lines(condition):
        lines += wrap(line, "# ")
    lines += wrap("The surrounding script needs: units si, atom_style granular, atom_modify map array, "
                  f"newton off, communicate single vel yes, create_box {len(types)} ... (atom types: "
                  f"{', '.join(f'{t} = {m}' for m, t in types.items())}), {_integration(card)}, and an "
                  f"insertion fix with distributiontemplate {DISTRIBUTION_ID}.", "# ")
    lines.append(bar)
    return lines


def _integration(card) -> str:
    if len(card["particle"]["spheres"]) > 1:
        return "fix ID all multisphere (the template is a clump; no nve/sphere)"
    return "fix ID all nve/sphere"


def _template(card, condition, types) -> list[str]:
    part = card["particle"]
    spheres = part["spheres"]
    size = part["size_distribution"]
    density = condition["materials"]["particle"]["density"]
    scales, weights, basis, said = _size_table(size)
    shape = (f"{len(spheres)} spheres, radii {' + '.join(_mm(s['radius']) for s in spheres)}"
             + (f", centres {_mm(part['centre_distance'])} apart" if "centre_distance" in part else ""))
    lines = [f"# Particle template '{part['shape']}': {shape}; centre of mass at the origin.", said]
    seeds = _primes(_FIRST_SEED, len(scales) + 1)
    ids = []
    for k, (scale, seed) in enumerate(zip(scales, seeds)):
        fix_id = f"{TEMPLATE_ID}{k + 1}"
        ids.append(fix_id)
        head = f"fix {fix_id} all particletemplate/"
        if len(spheres) == 1:
            lines.append(f"{head}sphere {seed} atom_type {types['particle']} density constant {number(density)} "
                         f"radius constant {number(spheres[0]['radius'] * scale)}")
        else:
            data = " ".join(" ".join(number(x * scale) for x in (*s["centre"], s["radius"])) for s in spheres)
            lines.append(f"{head}multisphere {seed} atom_type {types['particle']} density constant "
                         f"{number(density)} nspheres {len(spheres)} ntry 1000000 spheres {data} type {k + 1}")
    pairs = " ".join(f"{fix_id} {number(w)}" for fix_id, w in zip(ids, weights))
    lines.append(f"fix {DISTRIBUTION_ID} all particledistribution/discrete/{basis} {seeds[-1]} "
                 f"{len(ids)} {pairs}")
    return lines


def _size_table(size) -> tuple[list[float], list[float], str, str]:
    """The card's size distribution as LIGGGHTS' discrete classes: scale factors, their
    weights, the basis (numberbased or massbased) and a comment line saying so."""
    if size["kind"] == "sieve":
        classes = size["classes"]
        scales = [0.5 * (c["scale_min"] + c["scale_max"]) for c in classes]
        weights = [c["mass_fraction"] for c in classes]
        said = (f"# Size: sieve table, coarse-grained x{number(size['coarse_grain'])} (lab sizes "
                f"{number(size['lab_window_mm'][0])}-{number(size['lab_window_mm'][1])} mm, "
                f"{number(size['left_out_percent'])} % of the lab mass outside them left out), written as "
                f"{len(classes)} classes at their middle scale by mass (LIGGGHTS' distributions are discrete).")
        return scales, weights, "massbased", said
    scales = _size_classes(size["scale_min"], size["scale_max"])
    said = (f"# Size: scale factor uniform in [{number(size['scale_min'])}, {number(size['scale_max'])}] by number, "
            f"written as {len(scales)} equally likely classes (LIGGGHTS' distributions are discrete).")
    return scales, [1.0 / len(scales)] * len(scales), "numberbased", said


def _size_classes(low: float, high: float) -> list[float]:
    """Midpoints of :data:`SIZE_CLASSES` equal classes of a uniform scale factor."""
    if not high > low:
        return [float(low)]
    step = (high - low) / SIZE_CLASSES
    return [low + (k + 0.5) * step for k in range(SIZE_CLASSES)]


def _pair_table(condition, types) -> dict[tuple[int, int], dict[str, float]]:
    """Pair properties by atom-type pair. The card gives particle-X pairs; two walls never
    touch, and their pair takes the particle-wall values of the one with the lower atom
    type (LIGGGHTS wants symmetric tables)."""
    rows = {tuple(r["materials"]): r for r in condition["interactions"]}
    table = {}
    for a, i in types.items():
        for b, j in types.items():
            row = rows.get((a, b)) or rows.get((b, a))
            if row is None:  # wall-wall: never in contact
                row = rows[("particle", a if i < j else b)]
            table[(i, j)] = row
    return table


def _unused(card, condition, code) -> str:
    """The calibrated Hysteretic Spring or linear spring parameters hertz does not read."""
    if card["models"]["contact"] == "hertz_mindlin" or code["contact_model"] != "hertz tangential history":
        return ""
    mats = condition["materials"]["particle"]
    pp = next(r for r in condition["interactions"] if r["materials"] == ["particle", "particle"])
    return (f"particle yield strength {number(mats['yield_strength'])} Pa, particle-particle damping factor "
            f"{number(pp['damping_factor'])}, stiffness factor {number(pp['stiffness_factor'])} "
            f"({card['models']['contact']} parameters)")




def _rayleigh_time(card, params) -> float | None:
    """Rayleigh time [s] of the smallest sphere, ``pi R sqrt(rho / G) / (0.1631 nu + 0.8766)``
    (EDEM manual; Li, Xu & Thornton 2005, Powder Technol. 160, 219-228)."""
    try:
        radius = min(s["radius"] for s in card["particle"]["spheres"]) * card["particle"]["size_distribution"]["scale_min"]
        rho = float(params["particle.density"]["value"])
        g = float(params["particle.shear_modulus"]["value"])
        nu = float(params["particle.poisson_ratio"]["value"])
    except (KeyError, TypeError, ValueError):
        return None
    return math.pi * radius * math.sqrt(rho / g) / (0.1631 * nu + 0.8766)


def _primes(start: int, count: int) -> list[int]:
    """``count`` primes from ``start`` on."""
    out, n = [], start
    while len(out) < count:
        if n > 1 and all(n % d for d in range(2, math.isqrt(n) + 1)):
            out.append(n)
        n += 1
    return out



def _mm(x: float) -> str:
    return f"{float(x) * 1000:g} mm"
