"""The material card: everything a calibration found, in one plain dict.

:func:`build_card` is a pure function of a :class:`~demcal.campaign.config.Campaign` and
the parsed ``calibration.json`` that ``demcal calibrate`` wrote into the campaign's work
folder. It returns the card (layout below); :mod:`demcal.export.liggghts` and
:mod:`demcal.export.edem` format it as input for those codes, and the JSON format is the
card itself.

Layout::

    card, card_version, demcal_version
    campaign        name, description, file, test, profile, hash (sha256:...), hash_of
    models          contact, rolling: demcal's model names (contact.model, rolling.model)
    codes           edem / liggghts: the contact and rolling model each code uses for these
                    values, "transferable" (true when the values carry over without a new
                    calibration) and the reasons when not, plus each code's own details
    particle        shape, spheres (radius, centre [m], principal frame), centre_distance,
                    volume, size_distribution (kind "uniform": scale_min, scale_max by
                    number; kind "sieve": classes [{scale_min, scale_max, mass_fraction}] by
                    mass, reference_size, coarse_grain, lab_window_mm, left_out_percent)
    conditions[]    name, label,
                    lab           sample (the lab record) and targets (mean, sd)
                    fixed_settings  KEY -> value, source: every setting the condition's runs
                                  kept fixed besides the factors (source: "campaign file", or
                                  "campaign repose.toml, calibrated" for a value taken from
                                  another campaign's calibration by ``from_campaign``), as
                                  calibration.json records them
                    parameters    KEY -> value, unit, source, description: the full parameter
                                  set of the calibrated material (source: calibrated, fixed
                                  by the campaign file, the other campaign's calibration as in
                                  fixed_settings, default of the virtual test, or demcal
                                  default where the test has no such setting)
                    materials     particle, steel, film -> density, shear_modulus,
                                  poisson_ratio, youngs_modulus, yield_strength
                    interactions  [{materials, restitution, static_friction,
                                  rolling_friction, damping_factor, stiffness_factor,
                                  rolling_damping, surface_energy}]
                    solution_set  KEY -> low, high, unit: each calibrated value's range over
                                  the settings of the last design box whose fitted surface
                                  meets every lab mean (desirability >= 0.99; not widened
                                  for the lab sd, the prediction interval or the seed
                                  noise), ends rounded outward to 3 significant digits;
                                  meaning: that in one sentence (demcal.export.solution);
                                  null where calibration.json holds no range (a warning
                                  says why)
                    verification  the verification figures of calibration.json, as written
                    calibration   every other key of the condition in calibration.json, as written
                                  (factor_ranges too, with every digit)
    calibration     every top-level key of calibration.json but its conditions, as written
    calibration_file  path and sha256 of calibration.json
    warnings        every reason not to trust the card, one sentence each, in this order:
                    calibration.json of another campaign name or of an edited campaign
                    file, calibrated values that are not factors, settings taken from
                    another campaign that calibration.json does not record; values verified
                    at a profile cheaper than the paper's (tiny, quick, medium: the cheap
                    bench's values); each exported condition not verified (its loop's
                    status, or no, unfinished or missed verification runs), and each
                    without a solution set (verified on the path, no setting meeting the
                    targets, none recorded); models that do not carry over to the code
                    the card is for (both codes for the JSON card); then
                    calibration.json's own warnings, as written

The campaign hash (:func:`demcal.campaign.digest.campaign_hash`, re-exported here) is the
same one ``demcal calibrate`` writes into calibration.json; ``demcal export`` refuses a
calibration whose hash differs from the campaign file's.
"""

from __future__ import annotations

import json
import math
import numpy as np
from typing import Any, Mapping

from demcal import __version__
from demcal.campaign.chain import SOURCE_FILE
from demcal.campaign.digest import calibrated_from, campaign_hash, resolved_config  # noqa: F401  (the card's API)
from demcal.errors import DataError
from demcal.export.solution import solution_set

CARD_VERSION = 1

#: The profile of the paper's bench; values verified at any other are the cheaper bench's.
PAPER_PROFILE = "paper"

#: Why a condition's loop stopped short of verifying it, in a few words, by its status
#: (:data:`demcal.campaign.loop.OUT_OF_REACH` ...; docs/guide-run.md, "7. Calibrate").
LOOP_STOPS = {
    "out of reach": "the test cannot give the lab's angle within the factors' limits",
    "budget spent": "the run budget ran out first",
    "iterations spent": "its re-solves or box moves ran out first",
    "noise": "the mean's interval stayed wider than the lab sd at max_replicates",
    "unfinished": "runs it asked for are not done yet",
    "not verified": "its production runs failed or none were asked for",
}

#: Settings that describe the calibrated material (the rest belong to the virtual test).
MATERIAL_PREFIXES = ("particle.", "wall.", "film.", "contact.", "rolling.")
PARTICLE_KEYS = ("particles.shape", "particles.clump_mm", "particles.scale_min", "particles.scale_max",
                 "particles.sizes", "particles.sieve_mm", "particles.sieve_percent", "particles.coarse_grain",
                 "particles.size_min_mm", "particles.size_max_mm")

#: Keys of a condition in calibration.json that the card reads; every other key is kept
#: untouched under the condition's "calibration".
_CONDITION_KEYS = ("name", "chosen", "verification", "settings")

#: demcal contact model -> (EDEM model, transferable, reason when not).
EDEM_CONTACT = {
    "hertz_mindlin": ("Hertz-Mindlin (no slip)", True, ""),
    "hysteretic_spring": ("Hysteretic Spring", True, ""),
    "linear": ("Linear Spring", False,
               "demcal's linear spring (k = 5 R* Y, viscous damping, k_t = xi k) is not known to "
               "match the stiffness rule of EDEM's Linear Spring; recalibrate with "
               "contact.model = hertz_mindlin or hysteretic_spring"),
    "hertz_mindlin_jkr": ("Hertz-Mindlin with JKR Cohesion", True, ""),
}

#: What a reader of the EDEM tables should know although the values carry over.
EDEM_NOTES = {
    "hysteretic_spring": "the damping factor and stiffness factor follow demcal's reading of the "
                         "paper's Eq. 3 (docs/dem.md: extra viscous normal damping 2 zeta |beta| "
                         "sqrt(m* K), tangential spring k_t = xi K1), which EDEM describes only in words",
}

#: demcal rolling model -> (EDEM rolling friction model, transferable, reason when not).
EDEM_ROLLING = {
    "type_a": ("Standard Rolling Friction", True, ""),
    "cdt": ("RVD Rolling Friction", False,
            "demcal's cdt (LIGGGHTS' constant directional torque on w_i - w_j) is nearest to EDEM's "
            "RVD Rolling Friction, which also uses R* but takes its direction from the contact's "
            "tangential velocity; recalibrate with rolling.model = rvd (or type_a) for EDEM"),
    "type_c": ("Type C Rolling Friction", True, ""),
    "rvd": ("RVD Rolling Friction", True, ""),
    "type_a_limited": ("Standard Rolling Friction", False,
                       "demcal's type_a_limited caps EDEM's standard rolling torque at 0.08 of the "
                       "moment that stops the particle's spin in one time step (the moment limiter "
                       "of STAR-CCM+'s constant torque method); EDEM documents no such limiter, so "
                       "the values assume a torque EDEM may not apply; recalibrate with "
                       "rolling.model = type_a for EDEM"),
    "none": ("none", True, ""),
}

#: demcal contact model -> (LIGGGHTS 3.8 normal + tangential model, transferable, reason).
LIGGGHTS_CONTACT = {
    "hertz_mindlin": ("hertz tangential history", True, ""),
    "hysteretic_spring": ("hertz tangential history", False,
                          "LIGGGHTS 3.8 has no Walton-Braun Hysteretic Spring model (its "
                          "hooke/hysteresis is another hysteretic spring: a Hooke stiffness from a "
                          "characteristic velocity, an unloading stiffness that grows with the largest "
                          "overlap, adhesion and a plasticity depth, besides viscous damping), so the "
                          "values were calibrated with a model LIGGGHTS does not have; recalibrate with "
                          "contact.model = hertz_mindlin"),
    "linear": ("hertz tangential history", False,
               "LIGGGHTS 3.8 has no linear spring on the yield strength (k = 5 R* Y); recalibrate "
               "with contact.model = hertz_mindlin"),
    "hertz_mindlin_jkr": ("hertz tangential history", False,
                          "LIGGGHTS 3.8 has no JKR cohesion: its cohesion sjkr and sjkr2 add a force "
                          "k A (a cohesion energy density [J/m3] times the contact area) while the "
                          "particles overlap, a simplified law with no pull-off distance, so a surface "
                          "energy does not carry over; recalibrate with contact.model = hertz_mindlin"),
}

#: demcal rolling model -> (LIGGGHTS 3.8 rolling_friction model, transferable, reason).
LIGGGHTS_ROLLING = {
    "type_a": ("cdt", False,
               "demcal's type_a (EDEM's standard rolling friction: the particle's own angular "
               "velocity and its contact-point distance R_i) is not LIGGGHTS' cdt, which uses the "
               "relative angular velocity w_i - w_j and R* (half R_i for two equal spheres) between "
               "particles (against a wall both take the particle's own angular velocity and about "
               "its radius); recalibrate with rolling.model = cdt"),
    "cdt": ("cdt", True, ""),
    "type_c": ("epsd", False,
               "LIGGGHTS' epsd is the same model C of Ai et al. (2011) but takes k_n as the secant "
               "Hertz stiffness 4/3 E* sqrt(R* delta) where demcal takes the tangent one, "
               "2 E* sqrt(R* delta), so its rolling spring is 2/3 as stiff (the torque limit "
               "mu_r R* Fn is the same); recalibrate in LIGGGHTS or accept the stiffer spring"),
    "rvd": ("cdt", False,
            "demcal's rvd (EDEM's RVD rolling friction: the same torque on both particles, against "
            "the tangential part of w_i + w_j, from the total normal force) is not LIGGGHTS' cdt "
            "(opposite torques along w_i - w_j, from the elastic force k_n delta); recalibrate with "
            "rolling.model = cdt"),
    "type_a_limited": ("cdt", False,
                       "demcal's type_a_limited (EDEM's standard rolling friction on the particle's "
                       "own spin, with a moment limiter) is neither LIGGGHTS' cdt (relative spin, "
                       "R*, no limiter) nor its epsd; recalibrate with rolling.model = cdt"),
    "none": (None, True, ""),
}


# ----------------------------------------------------------------------------- the card


def build_card(campaign, calibration: Mapping[str, Any], conditions: list[str] | None = None,
               calibration_file: Mapping[str, str] | None = None, code: str | None = None) -> dict[str, Any]:
    """The material card of ``campaign`` calibrated as ``calibration`` (calibration.json).

    Parameters
    ----------
    campaign : Campaign
        The campaign, at the profile the calibration was made at.
    calibration : mapping
        The parsed calibration.json; each condition's ``chosen`` parameters and
        ``verification`` list are read, every other key is kept as written.
    conditions : list of str, optional
        The conditions to export (default: every calibrated condition of the campaign).
    calibration_file : mapping, optional
        ``path`` and ``sha256`` of calibration.json, recorded in the card.
    code : {"edem", "liggghts"}, optional
        The code the card is written for: its ``warnings`` say when the values do not
        carry over to it (default: to either code, as the JSON card serves both).

    Raises
    ------
    ConfigError
        A condition that the campaign does not have.
    DataError
        A condition that calibration.json does not hold, or holds without parameters.
    """
    from demcal._checks import and_list
    from demcal.bench.registry import get_experiment
    from demcal.errors import ConfigError
    from demcal.export.text import or_list

    known = [c.name for c in campaign.conditions]
    calibrated = {c.get("name"): c for c in calibration.get("conditions", []) if isinstance(c, Mapping)}
    again = f"run `demcal calibrate {campaign.path}`"
    if conditions is None:
        names = [n for n in known if n in calibrated]
        if not names:
            raise DataError(f"calibration.json holds none of the conditions of {campaign.path.name} "
                            f"({and_list(repr(n) for n in known)}); {again} again.")
    else:
        for name in conditions:
            if name not in known:
                raise ConfigError(f"condition '{name}' is not in {campaign.path.name}; choose "
                                  f"{or_list(repr(n) for n in known)}.")
            if name not in calibrated:
                raise DataError(f"condition '{name}' has no calibration yet; {again} first.")
        names = list(dict.fromkeys(conditions))

    experiment = get_experiment(campaign.test)
    table = experiment.settings(campaign.profile)
    warnings = _warnings(campaign, calibration)
    cards = []
    for name in names:
        raw = calibrated[name]
        chosen = raw.get("chosen")
        if not isinstance(chosen, Mapping) or not chosen:
            raise DataError(f"condition '{name}' has no chosen parameters in calibration.json; "
                            f"{again} again.")
        condition = next(c for c in campaign.conditions if c.name == name)
        fixed = fixed_settings(campaign, condition, raw, warnings)
        parameters = material_parameters(table, {k: v for k, (v, _) in fixed.items()}, chosen,
                                         {k: source for k, (_, source) in fixed.items() if source != SOURCE_FILE})
        cards.append({
            "name": name,
            "label": condition.label,
            "lab": _lab(condition),
            "fixed_settings": {k: {"value": _json_safe(v), "source": source} for k, (v, source) in fixed.items()},
            "parameters": parameters,
            "materials": materials(parameters),
            "interactions": interactions(parameters),
            "solution_set": solution_set(raw, parameters)[0],
            "verification": _json_safe(raw.get("verification", [])),
            "calibration": _json_safe({k: v for k, v in raw.items() if k not in _CONDITION_KEYS}),
        })

    first = cards[0]["parameters"]
    contact = str(first["contact.model"]["value"])
    rolling = str(first["rolling.model"]["value"])
    codes = {"edem": _code(EDEM_CONTACT, EDEM_ROLLING, contact, rolling),
             "liggghts": _code(LIGGGHTS_CONTACT, LIGGGHTS_ROLLING, contact, rolling)}
    codes["edem"]["notes"] = [EDEM_NOTES[contact]] if contact in EDEM_NOTES else []
    shape = particle(first)
    codes["liggghts"].update(_liggghts_details(codes["liggghts"], cards[0], shape))
    warnings = _trust_warnings(campaign, calibration, names, {"contact": contact, "rolling": rolling},
                               [code] if code else ["edem", "liggghts"], warnings)
    return {
        "card": "demcal material card",
        "card_version": CARD_VERSION,
        "demcal_version": __version__,
        "campaign": {
            "name": campaign.name,
            "description": campaign.description,
            "file": str(campaign.path),
            "test": campaign.test,
            "profile": campaign.profile,
            "hash": campaign_hash(campaign),
            "hash_of": "the resolved campaign configuration (demcal.export.card.resolved_config)",
        },
        "models": {"contact": contact, "rolling": rolling},
        "codes": codes,
        "particle": shape,
        "conditions": cards,
        "calibration": _json_safe({k: v for k, v in calibration.items() if k != "conditions"}),
        "calibration_file": dict(calibration_file or {}),
        "warnings": warnings,
    }


def fixed_settings(campaign, condition, calibrated: Mapping[str, Any],
                   warnings: list[str]) -> dict[str, tuple[Any, str]]:
    """KEY -> (value, source) of every setting the runs of ``condition`` kept fixed: as its
    entry ``calibrated`` of calibration.json records them (a campaign with per-condition
    settings), else as the campaign file gives them. A condition that took values from
    another campaign without such a record adds a sentence to ``warnings``."""
    from demcal.campaign.chain import SOURCE_DEFAULT

    recorded = calibrated.get("settings")
    if isinstance(recorded, Mapping):
        return {str(k): (v.get("value"), str(v.get("source", SOURCE_FILE))) for k, v in recorded.items()
                if isinstance(v, Mapping) and v.get("source") != SOURCE_DEFAULT}
    if condition.upstream is not None:
        warnings.append(f"calibration.json does not record the settings condition '{condition.name}' took from "
                        f"{condition.upstream.path.name}, so the card gives only the campaign file's; "
                        f"run `demcal calibrate {campaign.path}` again.")
    return {k: (v, SOURCE_FILE) for k, v in {**campaign.settings, **condition.settings}.items()}


def material_parameters(table: Mapping[str, Any], fixed: Mapping[str, Any], chosen: Mapping[str, Any],
                        sources: Mapping[str, str] | None = None) -> dict[str, dict[str, Any]]:
    """The full parameter set of the calibrated material, KEY -> value, unit, source,
    description.

    ``table`` is the virtual test's settings table (:class:`~demcal.bench.registry.Setting`
    by key), ``fixed`` the settings the runs kept fixed, ``chosen`` the calibrated values;
    a fixed value's source is "fixed" (by the campaign file) unless ``sources`` names
    another (e.g. "campaign repose.toml, calibrated").
    Keys of the material that the test has no setting for (a plug-in test) take demcal's
    defaults (:func:`demcal.bench.common.material_settings`) with source ``demcal default``.
    """
    from demcal.bench.common import material_settings, particle_settings

    defaults = {s.key: s for s in material_settings(film=False) + particle_settings("quick", 1)}
    keys = [k for k in table if _is_material(k)]
    keys += [k for k in defaults if _is_material(k) and k not in table]
    keys += [k for k in chosen if k not in keys]
    out = {}
    for key in keys:
        spec = table.get(key, defaults.get(key))
        if key in chosen:
            value, source = chosen[key], "calibrated"
        elif key in fixed:
            value, source = fixed[key], (sources or {}).get(key, "fixed")
        elif key in table:
            value, source = table[key].default, "default"
        else:
            value, source = spec.default, "demcal default"
        if source in ("default", "demcal default") and getattr(spec, "inert", False):
            continue  # an option left off (a sieve, a clump): the card is as without it
        out[key] = {"value": _json_safe(value), "unit": spec.unit if spec else "-", "source": source,
                    "description": spec.help if spec else ""}
    return out


def _is_material(key: str) -> bool:
    return key.startswith(MATERIAL_PREFIXES) or key in PARTICLE_KEYS


def _value(parameters: Mapping[str, Mapping[str, Any]], key: str, default=None):
    entry = parameters.get(key)
    return default if entry is None else entry["value"]


def materials(parameters: Mapping[str, Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per-material bulk properties (EDEM's material table): the particle, the steel of
    the walls (:func:`demcal.particles.materials.steel`) and, where the test has one, the
    film. Young's modulus ``E = 2 G (1 + nu)`` [Pa] is derived from the shear modulus G."""
    from demcal.particles.materials import steel

    out = {"particle": _material(*(_value(parameters, f"particle.{p}") for p in
                                   ("density", "shear_modulus", "poisson_ratio", "yield_strength")))}
    wall = steel()
    out["steel"] = _material(wall.density, wall.shear_modulus, wall.poisson_ratio, wall.yield_strength)
    if "film.density" in parameters:
        out["film"] = _material(*(_value(parameters, f"film.{p}") for p in
                                  ("density", "shear_modulus", "poisson_ratio", "yield_strength")))
    return out


def _material(density, shear_modulus, poisson_ratio, yield_strength) -> dict[str, float]:
    g, nu = float(shear_modulus), float(poisson_ratio)
    return {"density": float(density), "shear_modulus": g, "poisson_ratio": nu,
            "youngs_modulus": float(f"{2.0 * g * (1.0 + nu):.12g}"),
            "yield_strength": float(yield_strength)}


def interactions(parameters: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per-pair contact properties (EDEM's interaction table): particle-particle
    (``particle.*``), particle-steel (``wall.*``) and particle-film (``film.*``); a pair
    without its own stiffness factor takes the particle's, as the virtual tests do."""
    from demcal.particles.materials import Interaction

    xi = _value(parameters, "particle.stiffness_factor")
    rolling_damping = Interaction().rolling_damping
    surface_energy = Interaction().value("surface_energy", 0.0)
    out = []
    for other, prefix in (("particle", "particle"), ("steel", "wall"), ("film", "film")):
        if f"{prefix}.restitution" not in parameters:
            continue
        row = {"materials": ["particle", other]}
        for prop in ("restitution", "static_friction", "rolling_friction", "damping_factor"):
            row[prop] = _value(parameters, f"{prefix}.{prop}")
        row["stiffness_factor"] = _value(parameters, f"{prefix}.stiffness_factor", xi)
        row["rolling_damping"] = _value(parameters, f"{prefix}.rolling_damping", rolling_damping)
        row["surface_energy"] = _value(parameters, f"{prefix}.surface_energy", surface_energy)
        row["source"] = sorted({parameters[f"{prefix}.{p}"]["source"] for p in
                                ("restitution", "static_friction", "rolling_friction")})
        out.append(row)
    return out


def particle(parameters: Mapping[str, Mapping[str, Any]]) -> dict[str, Any]:
    """The particle template (spheres in its principal frame, centre of mass at the
    origin [m]) and the size distribution (a scale factor on the template)."""
    from demcal.bench.common import template_for

    shape = _value(parameters, "particles.shape", "two-sphere")
    settings = {key: _value(parameters, key) for key in PARTICLE_KEYS if key in parameters}
    settings["particles.centre_distance"] = float(_value(parameters, "particles.centre_distance", 0.007))
    template = template_for({**settings, "particles.shape": shape})
    spheres = [{"radius": float(r), "centre": [_nm(x) for x in c]}
               for r, c in zip(template.radii, template.centers)]
    out = {"shape": shape, "spheres": spheres,
           "frame": "principal axes, centre of mass at the origin [m]",
           "volume": float(f"{template.volume:.9g}")}
    if len(spheres) == 2:
        a, b = (s["centre"] for s in spheres)
        out["centre_distance"] = _nm(math.dist(a, b))
    if _value(parameters, "particles.sizes", "scale") == "sieve":
        out["size_distribution"] = _sieve_sizes(settings, template)
        return out
    low = float(_value(parameters, "particles.scale_min", 1.0))
    high = float(_value(parameters, "particles.scale_max", 1.0))
    out["size_distribution"] = {"kind": "uniform", "basis": "number", "scale_min": low,
                                "scale_max": high,
                                "meaning": "each particle is the template scaled by a factor drawn "
                                           "uniformly in [scale_min, scale_max]"}
    return out


def _sieve_sizes(settings: Mapping[str, Any], template) -> dict[str, Any]:
    """The card's size distribution from a sieve table: the simulated classes as scale
    factors on the template with their mass fractions, and what was left out."""
    from demcal.bench.common import sieve_for

    scaled = sieve_for(settings, template)
    table = scaled.distribution
    edges = np.asarray(table.apertures) / table.reference_size
    classes = [{"scale_min": float(f"{a:.6g}"), "scale_max": float(f"{b:.6g}"), "mass_fraction": float(f"{w:.6g}")}
               for a, b, w in zip(edges[:-1], edges[1:], table.mass_fractions)]
    return {"kind": "sieve", "basis": "mass", "classes": classes,
            "scale_min": float(f"{edges[0]:.6g}"), "scale_max": float(f"{edges[-1]:.6g}"),
            "reference_size": _nm(table.reference_size), "coarse_grain": scaled.coarse_grain,
            "lab_window_mm": [float(f"{x:.6g}") for x in scaled.window_mm],
            "left_out_percent": float(f"{scaled.left_out_percent:.4g}"),
            "meaning": "a lab particle of sieve size D is the template scaled so that its volume-"
                       "equivalent diameter (reference_size at scale 1) is coarse_grain x D; each class "
                       "holds its mass fraction, sizes uniform within it; the lab mass outside "
                       "lab_window_mm (left_out_percent) is not simulated"}


def _nm(x: float) -> float:
    """A length [m] rounded to the nanometre (drops the template's 1e-22 m noise)."""
    return round(float(x), 9) + 0.0


def _code(contact_map, rolling_map, contact: str, rolling: str) -> dict[str, Any]:
    c_name, c_ok, c_why = contact_map.get(contact, (None, False, f"no model for contact.model = {contact}"))
    r_name, r_ok, r_why = rolling_map.get(rolling, (None, False, f"no model for rolling.model = {rolling}"))
    return {"contact_model": c_name, "rolling_model": r_name, "transferable": bool(c_ok and r_ok),
            "reasons": [why for ok, why in ((c_ok, c_why), (r_ok, r_why)) if not ok]}


def _liggghts_details(code: Mapping[str, Any], condition: Mapping[str, Any],
                      shape: Mapping[str, Any]) -> dict[str, Any]:
    """What a LIGGGHTS script around the snippet refers to (:mod:`demcal.export.liggghts`)."""
    from demcal.export import liggghts

    rolling = f" rolling_friction {code['rolling_model']}" if code["rolling_model"] else ""
    return {"version": "3.8",
            "pair_style": f"gran model hertz tangential history{rolling}",
            "atom_types": liggghts.atom_types(condition),
            "distribution_template": liggghts.DISTRIBUTION_ID,
            "integration": "multisphere" if len(shape["spheres"]) > 1 else "nve/sphere"}


def _lab(condition) -> dict[str, Any]:
    sample = condition.sample.to_dict() if condition.sample is not None else None
    return {"sample": _json_safe(sample),
            "targets": [{"response": t.response, "mean": t.mean, "sd": t.sd} for t in condition.targets]}


def _warnings(campaign, calibration: Mapping[str, Any]) -> list[str]:
    out = []
    name = calibration.get("campaign")
    if name is not None and name != campaign.name:
        out.append(f"calibration.json names campaign '{name}', the campaign file '{campaign.name}'.")
    if calibrated_from(campaign, calibration) is False:
        out.append("the campaign file changed since the calibration (its hash differs); calibrate again.")
    factors = {f.parameter for f in campaign.factors}
    for raw in calibration.get("conditions", []):
        chosen = raw.get("chosen") if isinstance(raw, Mapping) else None
        extra = sorted(set(chosen or {}) - factors)
        if extra:
            out.append(f"condition '{raw.get('name')}' has calibrated values of {', '.join(extra)}, "
                       "which are not factors of the campaign file.")
    return out


def _trust_warnings(campaign, calibration: Mapping[str, Any], names: list[str], models: Mapping[str, str],
                    codes: list[str], first: list[str]) -> list[str]:
    """The card's warnings: ``first`` (:func:`_warnings`, :func:`fixed_settings`), then the
    profile, each condition of ``names`` not verified, the ``codes`` the models do not carry
    over to, and calibration.json's own warnings; each sentence once."""
    out = list(first)
    profile = profile_warning(campaign, calibration)
    out += [profile] if profile else []
    calibrated = {c.get("name"): c for c in calibration.get("conditions", []) if isinstance(c, Mapping)}
    for name in names:
        out += condition_warnings(campaign, name, calibrated[name])
        none = solution_set(calibrated[name], {})[1]
        out += [f"condition '{name}' has no solution set: {none}."] if none else []
    out += [w for w in (transfer_warning(models, code) for code in codes) if w]
    out += [w for w in calibration.get("warnings") or [] if isinstance(w, str)]
    return list(dict.fromkeys(out))


def profile_warning(campaign, calibration: Mapping[str, Any]) -> str | None:
    """One sentence when the values were verified at a profile cheaper than the paper's
    (``production`` of calibration.json, else its ``profile``): they are that bench's."""
    cheap = str(calibration.get("profile") or campaign.profile)
    verified = str(calibration.get("production") or cheap)
    if verified == PAPER_PROFILE:
        return None
    where = (f"calibrated at profile '{cheap}'" if verified == cheap
             else f"designed at profile '{cheap}' and verified at '{verified}'")
    smoke = " (a smoke test)" if verified == "tiny" else ""
    return f"{where}{smoke}, smaller than the full-size bench: the values are the {verified} bench's, not the full-size one's."


def condition_warnings(campaign, name: str, calibrated: Mapping[str, Any]) -> list[str]:
    """Why condition ``name`` (its entry ``calibrated`` of calibration.json) is not verified:
    its loop's ``status`` when that is not "verified", else (a calibration without a loop
    status) no verification runs, unfinished ones, or a mean outside the lab's sd."""
    status = calibrated.get("status")
    if status is not None:
        if status == "verified":
            return []
        why = LOOP_STOPS.get(str(status))
        if status == "unfinished":
            why += f"; run `demcal calibrate {campaign.path}` to finish them"
        return [f"condition '{name}' is not verified: its calibration loop ended '{status}'"
                + (f" ({why})." if why else ".")]
    checks = [v for v in calibrated.get("verification") or [] if isinstance(v, Mapping)]
    if not checks:
        return [f"condition '{name}' is not verified: no verification run simulated its values."]
    out = []
    for v in checks:
        response = v.get("response")
        if not v.get("simulated"):
            out.append(f"condition '{name}' is not verified: the verification of {response} is unfinished.")
        elif v.get("within_lab_sd") is False:
            out.append(f"condition '{name}' is not verified: the simulated {response} misses the lab's sd.")
        elif v.get("within_lab_sd") is None:
            out.append(f"condition '{name}' is not verified: {response} has no lab sd to judge it by.")
    return out


def transfer_warning(models: Mapping[str, str], code: str) -> str | None:
    """One sentence when the values calibrated with ``models`` (contact, rolling) do not
    carry over to ``code`` ("edem", "liggghts"), naming the models to choose instead."""
    from demcal.export.text import not_transferable, or_list

    tables = {"edem": (EDEM_CONTACT, EDEM_ROLLING), "liggghts": (LIGGGHTS_CONTACT, LIGGGHTS_ROLLING)}[code]
    wrong, choose = [], []
    for (kind, name), table in zip(models.items(), tables):
        if not table.get(name, (None, False, ""))[1]:
            wrong.append(f"{kind}.model = {name}")
            choose.append(f"{kind}.model = {or_list(m for m, (_, ok, _) in table.items() if ok and m != 'none')}")
    if not wrong:
        return None
    return not_transferable(code, wrong, choose)


def _json_safe(value: Any) -> Any:
    """Strict JSON data: NaN -> None, infinities -> "inf" / "-inf" (a sieve's open class)."""
    if isinstance(value, float):
        if math.isnan(value):
            return None
        return value if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, Mapping):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    if hasattr(value, "tolist"):
        return _json_safe(value.tolist())
    return value


def to_json(card: Mapping[str, Any]) -> str:
    """The card as JSON text (strict: no NaN or Infinity), ending with a newline."""
    return json.dumps(card, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
