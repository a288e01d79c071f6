"""`demcal export`: the material card as JSON, a LIGGGHTS 3.8 snippet and EDEM's tables.

The campaigns are the residual-film-soil examples with a hand-written calibration.json
(no simulation runs): the card must carry the calibrated values under each code's names,
the full parameter set, the lab record, the campaign's hash and the verification
figures, and keep keys of calibration.json it does not know. The LIGGGHTS snippet is run
in LIGGGHTS itself (Debian's `liggghts`, 3.8) inside a minimal complete input script.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import pytest

from demcal.campaign.config import load_campaign
from demcal.cli import main
from demcal.dem.contact.registry import SUBMODELS
from demcal.export.card import (EDEM_ROLLING, LIGGGHTS_ROLLING, build_card, campaign_hash,
                                resolved_config, transfer_warning)

VERIFIED = {"response": "repose_angle_deg", "target": 31.07, "lab_sd": 2.1, "predicted": 31.07,
            "simulated": [30.5, 31.2, 31.9], "simulated_mean": 31.2, "simulated_sd": 0.7,
            "relative_error_percent": 0.42, "within_lab_sd": True, "reachable": [28.0, 40.0],
            "target_reachable": True}

#: calibration.json as `demcal calibrate` writes it, plus keys a newer calibration loop may add
#: ("final", "verified", "iterations"), which the card must keep untouched.
REPOSE_CALIBRATION = {
    "campaign": "repose", "profile": "quick", "test": "repose-funnel", "notes": ["a note"],
    "models": {"repose_angle_deg": {"order": "quadratic", "equation_coded": "y = 40 + 3 B"}},
    "iterations": [{"box": 0, "runs": 29}],
    "conditions": [
        {"name": "6.26 %", "chosen": {"particle.restitution": 0.58, "particle.static_friction": 0.312,
                                      "particle.rolling_friction": 0.105, "particle.damping_factor": 0.12},
         "chosen_coded": {"A": -0.2, "B": -0.88, "C": -0.95, "D": 0.2}, "desirability": 1.0,
         "factor_ranges": {"particle.restitution": [0.5, 0.7], "particle.static_friction": [0.29874, 0.33417],
                           "particle.rolling_friction": [0.1, 0.23162], "particle.damping_factor": [0.0, 0.2]},
         "final": {"iteration": 2, "profile": "quick"}, "verified": True, "verification": [VERIFIED]},
        {"name": "14.1 %", "chosen": {"particle.restitution": 0.69, "particle.static_friction": 0.38,
                                      "particle.rolling_friction": 0.23, "particle.damping_factor": 0.19},
         "factor_ranges": {"particle.restitution": [0.5, 0.7], "particle.static_friction": [0.35121, 0.4],
                           "particle.rolling_friction": [0.21043, 0.3], "particle.damping_factor": [0.0, 0.2]},
         "verification": []},
    ],
}

SLIDING_CALIBRATION = {
    "campaign": "sliding", "profile": "quick", "test": "incline",
    "conditions": [
        {"name": "14.1 %", "chosen": {"film.restitution": 0.53, "film.static_friction": 0.48,
                                      "film.rolling_friction": 0.22},
         "factor_ranges": {"film.restitution": [0.4, 0.6], "film.static_friction": [0.44612, 0.51274],
                           "film.rolling_friction": [0.1, 0.3]},
         "verification": [{"response": "sliding_angle_deg", "target": 30.46, "lab_sd": 3.2, "predicted": 30.1,
                           "simulated": [29.0, 30.0], "simulated_mean": 29.5, "simulated_sd": 0.71,
                           "relative_error_percent": 3.15, "within_lab_sd": True}]},
    ],
}

#: The sliding campaign with a Hertz-Mindlin material, type C rolling, single spheres and a
#: stiffer particle: the models LIGGGHTS has (so the card is transferable there, but for
#: type C's spring), three atom types (particle, steel, film).
HERTZ_SETTINGS = ('\n[experiment.settings]\n"contact.model" = "hertz_mindlin"\n"rolling.model" = "type_c"\n'
                  '"particles.shape" = "sphere"\n"particle.shear_modulus" = 5e6\n"particle.poisson_ratio" = 0.3\n')


#: The card's warnings on the repose calibration above (JSON: both codes' transferability).
QUICK = "calibrated at profile 'quick', smaller than the full-size bench: the values are the quick bench's, not the full-size one's."
UNVERIFIED = "condition '14.1 %' is not verified: no verification run simulated its values."
NOT_LIGGGHTS = ("the values do not carry over to LIGGGHTS 3.8, whose models differ from demcal's "
                "contact.model = hysteretic_spring and rolling.model = type_a; choose contact.model = hertz_mindlin "
                "and rolling.model = cdt in [experiment.settings] before the design, and calibrate again.")


def _calibrate(folder, name: str, data: dict) -> None:
    (folder / f"{name}-runs").mkdir(exist_ok=True)
    (folder / f"{name}-runs" / "calibration.json").write_text(json.dumps(data))


@pytest.fixture
def repose(example):
    _calibrate(example, "repose", REPOSE_CALIBRATION)
    return example


@pytest.fixture
def sliding(example):
    path = example / "sliding.toml"
    path.write_text(path.read_text().replace('profile = "quick"\n', 'profile = "quick"\n' + HERTZ_SETTINGS, 1))
    _calibrate(example, "sliding", SLIDING_CALIBRATION)
    return example


def _export(capsys, *argv) -> str:
    assert main(["export", *argv]) == 0
    return capsys.readouterr().out


def _card(capsys, *argv) -> dict:
    def refuse(constant):
        raise AssertionError(f"the card is not strict JSON: {constant}")

    return json.loads(_export(capsys, *argv), parse_constant=refuse)


# ----------------------------------------------------------------------------------- json


def test_json_card_holds_the_full_calibrated_material(repose, capsys):
    card = _card(capsys, "repose.toml")
    campaign = load_campaign("repose.toml")
    assert card["campaign"]["name"] == "repose" and card["campaign"]["test"] == "repose-funnel"
    assert card["campaign"]["hash"] == campaign_hash(campaign)
    assert re.fullmatch(r"sha256:[0-9a-f]{64}", card["campaign"]["hash"])
    assert [c["name"] for c in card["conditions"]] == ["6.26 %", "14.1 %"]

    low = card["conditions"][0]
    p = low["parameters"]
    assert p["particle.static_friction"] == {"value": 0.312, "unit": "-", "source": "calibrated",
                                            "description": p["particle.static_friction"]["description"]}
    # the full set, not only the factors: bulk properties, wall interaction, models, shape
    assert p["particle.density"]["value"] == 1687.85 and p["particle.density"]["source"] == "default"
    assert p["particle.shear_modulus"]["value"] == 1e6 and p["particle.shear_modulus"]["unit"] == "Pa"
    assert p["particle.yield_strength"]["value"] == 2e5
    assert p["wall.static_friction"]["value"] == 0.6
    assert p["contact.model"]["value"] == "hysteretic_spring" and p["rolling.model"]["value"] == "type_a"
    assert p["particles.scale_min"]["value"] == 0.5 and p["particles.scale_max"]["value"] == 1.5
    assert "particles.count" not in p and "geometry.scale" not in p  # the bench's, not the material's

    particle = low["materials"]["particle"]
    assert particle["youngs_modulus"] == pytest.approx(2 * 1e6 * (1 + 0.46))  # E = 2 G (1 + nu)
    assert low["materials"]["steel"]["youngs_modulus"] == pytest.approx(2 * 7e10 * 1.3)
    pp, pw = low["interactions"]
    assert pp["materials"] == ["particle", "particle"] and pw["materials"] == ["particle", "steel"]
    assert (pp["restitution"], pp["static_friction"], pp["rolling_friction"], pp["damping_factor"],
            pp["stiffness_factor"]) == (0.58, 0.312, 0.105, 0.12, 0.95)
    assert (pw["restitution"], pw["static_friction"], pw["rolling_friction"]) == (0.5, 0.6, 0.3)

    shape = card["particle"]
    assert shape["shape"] == "two-sphere" and [s["radius"] for s in shape["spheres"]] == [0.004, 0.005]
    assert shape["centre_distance"] == pytest.approx(0.007)
    assert shape["size_distribution"]["scale_min"] == 0.5 and shape["size_distribution"]["scale_max"] == 1.5

    lab = low["lab"]
    assert lab["sample"]["name"] == "L" and lab["sample"]["moisture_percent"] == 6.26
    assert lab["sample"]["sieve"]["edges_mm"][-1] == "inf"  # the open class, in strict JSON
    assert lab["targets"] == [{"response": "repose_angle_deg", "mean": 31.07, "sd": 2.1}]
    assert low["verification"] == [VERIFIED]

    # keys the card does not read are kept as written
    assert low["calibration"]["final"] == {"iteration": 2, "profile": "quick"}
    assert low["calibration"]["verified"] is True and low["calibration"]["desirability"] == 1.0
    assert card["conditions"][1]["calibration"] == {  # every digit, beside the card's rounded solution_set
        "factor_ranges": REPOSE_CALIBRATION["conditions"][1]["factor_ranges"]}
    assert card["calibration"]["iterations"] == [{"box": 0, "runs": 29}]
    assert card["calibration"]["models"] == REPOSE_CALIBRATION["models"]
    assert "conditions" not in card["calibration"]
    assert len(card["calibration_file"]["sha256"]) == 64
    assert card["warnings"] == [QUICK, UNVERIFIED, NOT_LIGGGHTS]

    edem, liggghts = card["codes"]["edem"], card["codes"]["liggghts"]
    assert (edem["contact_model"], edem["rolling_model"], edem["transferable"]) == (
        "Hysteretic Spring", "Standard Rolling Friction", True)
    assert (liggghts["contact_model"], liggghts["rolling_model"], liggghts["transferable"]) == (
        "hertz tangential history", "cdt", False)
    assert "no Walton-Braun Hysteretic Spring" in liggghts["reasons"][0]
    assert liggghts["atom_types"] == {"particle": 1, "steel": 2}


def test_campaign_hash_follows_what_decides_the_calibration(repose):
    campaign = load_campaign("repose.toml")
    text = (repose / "repose.toml").read_text()
    assert resolved_config(campaign)["settings"]["particle.density"] == 1687.85  # resolved defaults
    moved = repose / "elsewhere"
    moved.mkdir()
    for name in ("repose.toml", "lab.toml", "paper_table4_repose_bbd.csv"):
        shutil.copy(repose / name, moved / name)
    (moved / "repose.toml").write_text(text.replace('description = "', 'description = "Renamed. ', 1))
    assert campaign_hash(load_campaign(moved / "repose.toml")) == campaign_hash(campaign)
    (moved / "repose.toml").write_text(text.replace("low = 0.3\nhigh = 0.5", "low = 0.3\nhigh = 0.55", 1))
    assert campaign_hash(load_campaign(moved / "repose.toml")) != campaign_hash(campaign)
    assert campaign_hash(campaign.with_profile("tiny")) != campaign_hash(campaign)


def test_film_interaction_and_fixed_settings(sliding, capsys):
    card = _card(capsys, "sliding.toml")
    (condition,) = card["conditions"]
    p = condition["parameters"]
    assert p["film.static_friction"]["source"] == "calibrated" and p["film.static_friction"]["value"] == 0.48
    assert p["particle.shear_modulus"] == {**p["particle.shear_modulus"], "value": 5e6, "source": "fixed"}
    assert condition["materials"]["particle"]["youngs_modulus"] == pytest.approx(2 * 5e6 * 1.3)
    assert condition["materials"]["film"]["shear_modulus"] == 1e8
    film = condition["interactions"][2]
    assert film["materials"] == ["particle", "film"] and film["static_friction"] == 0.48
    assert card["codes"]["liggghts"]["rolling_model"] == "epsd"
    assert card["codes"]["liggghts"]["atom_types"] == {"particle": 1, "steel": 2, "film": 3}
    assert card["codes"]["edem"]["rolling_model"] == "Type C Rolling Friction"
    assert card["codes"]["edem"]["transferable"] is True
    assert [s["radius"] for s in card["particle"]["spheres"]] == [0.0045]


def test_every_rolling_model_has_a_row_for_each_code():
    """A rolling sub-model added to the engine (rvd the latest) must say what it
    is in EDEM and in LIGGGHTS, and why it does not carry over where it does not."""
    names = [m.name for m in SUBMODELS["rolling"]]
    assert "type_a_limited" in names and "rvd" in names
    for table in (EDEM_ROLLING, LIGGGHTS_ROLLING):
        assert sorted(table) == sorted(names)
        for name, (code_name, transferable, why) in table.items():
            assert transferable or "recalibrate" in why, name
            assert not transferable or why == "", name


def test_card_of_a_type_a_limited_material(sliding, capsys):
    """type_a_limited (EDEM's standard rolling friction with STAR-CCM+'s moment limiter)
    maps to EDEM's Standard Rolling Friction and LIGGGHTS' cdt, neither transferable."""
    path = sliding / "sliding.toml"
    text = path.read_text()
    assert '"rolling.model" = "type_c"' in text
    path.write_text(text.replace('"rolling.model" = "type_c"', '"rolling.model" = "type_a_limited"'))
    card = _card(capsys, "sliding.toml")
    assert card["models"] == {"contact": "hertz_mindlin", "rolling": "type_a_limited"}
    edem, liggghts = card["codes"]["edem"], card["codes"]["liggghts"]
    assert (edem["contact_model"], edem["rolling_model"], edem["transferable"]) == (
        "Hertz-Mindlin (no slip)", "Standard Rolling Friction", False)
    assert edem["reasons"] == [EDEM_ROLLING["type_a_limited"][2]]
    assert "recalibrate with rolling.model = type_a for EDEM" in edem["reasons"][0]
    assert (liggghts["rolling_model"], liggghts["transferable"]) == ("cdt", False)
    assert liggghts["reasons"] == [LIGGGHTS_ROLLING["type_a_limited"][2]]
    text = _export(capsys, "sliding.toml", "--format", "edem")
    assert "# NOT TRANSFERABLE: calibrated with demcal's contact.model = hertz_mindlin, " \
           "rolling.model = type_a_limited." in text
    assert "base model Hertz-Mindlin (no slip); rolling friction Standard Rolling Friction" in text
    assert "Rolling Viscous Damping Ratio" not in text      # type C's column only
    text = _export(capsys, "sliding.toml", "--format", "liggghts")
    assert "NOT TRANSFERABLE" in text
    assert "pair_style gran model hertz tangential history rolling_friction cdt" in text
    assert "coefficientRollingViscousDamping" not in text   # epsd's only


def test_build_card_is_a_pure_function_of_campaign_and_calibration(repose):
    campaign = load_campaign("repose.toml")
    calibration = json.loads(json.dumps(REPOSE_CALIBRATION))
    card = build_card(campaign, calibration, ["14.1 %"])
    assert [c["name"] for c in card["conditions"]] == ["14.1 %"]
    assert calibration == REPOSE_CALIBRATION and build_card(campaign, calibration, ["14.1 %"]) == card
    stale = dict(calibration, campaign="other")
    assert build_card(campaign, stale)["warnings"] == [
        "calibration.json names campaign 'other', the campaign file 'repose'.", QUICK, UNVERIFIED, NOT_LIGGGHTS]
    assert build_card(campaign, calibration, ["6.26 %"], code="edem")["warnings"] == [QUICK]


# ------------------------------------------------------------------------------- liggghts


def test_liggghts_snippet_names_and_values(repose, capsys):
    text = _export(capsys, "repose.toml", "--format", "liggghts", "--condition", "6.26 %")
    lines = text.splitlines()
    # the warnings come first: the card's (a quick calibration), then the models': the values
    # were calibrated with a model LIGGGHTS lacks (said once, in full, not again in the head)
    assert lines[:4] == ["# demcal material card: 1 warning; read it before using the values.",
                         "# WARNING: calibrated at profile 'quick', smaller than the full-size bench: the values",
                         "#   are the quick bench's, not the full-size one's.", ""]
    assert lines[5] == "# !!! NOT TRANSFERABLE TO LIGGGHTS !!!"
    assert "contact.model = hysteretic_spring" in " ".join(lines[5:9])
    assert "do not carry over to LIGGGHTS" not in text
    assert "pair_style gran model hertz tangential history rolling_friction cdt" in lines
    assert "fix dc_youngs all property/global youngsModulus peratomtype 2.92e+06 1.82e+11" in lines
    assert "fix dc_poisson all property/global poissonsRatio peratomtype 0.46 0.3" in lines
    assert re.search(r"coefficientRestitution peratomtypepair 2 &\n    0\.58 0\.5 &\n    0\.5 0\.5\n", text)
    assert re.search(r"coefficientFriction peratomtypepair 2 &\n    0\.312 0\.6 &\n", text)
    assert re.search(r"coefficientRollingFriction peratomtypepair 2 &\n    0\.105 0\.3 &\n", text)
    assert "soft_particles yes" in text and "hard_particles yes" in text  # E < 5e6 Pa, steel > 1e9 Pa
    assert "density constant 1687.85 nspheres 2" in text
    assert campaign_hash(load_campaign("repose.toml")) in text
    assert "sample L, moisture 6.26 ± 1.5 %" in text and "31.07 ± 2.1" in text
    flat = " ".join(line.lstrip("# ") for line in lines)
    assert "simulated 31.2 ± 0.7 (n = 3), error 0.42 %, inside the lab sd" in flat
    assert "14.1 %" not in text


def test_liggghts_snippet_of_a_transferable_material(sliding, capsys):
    text = _export(capsys, "sliding.toml", "--format", "liggghts")
    flat = " ".join(line.lstrip("# !") for line in text.splitlines())
    assert "NOT TRANSFERABLE" in text and "rolling spring is 2/3 as stiff" in flat  # type C only
    assert "no Walton-Braun" not in flat  # Hertz-Mindlin is LIGGGHTS' hertz
    assert "pair_style gran model hertz tangential history rolling_friction epsd" in text
    assert "youngsModulus peratomtype 1.3e+07 1.82e+11 2.8e+08" in text
    assert "soft_particles" not in text and "hard_particles yes" in text
    assert "coefficientRollingViscousDamping peratomtypepair 3" in text
    assert "particletemplate/sphere" in text and "radius constant 0.0045" in text


LIGGGHTS_NAMES = ("liggghts", "lmp_auto", "lmp_serial", "lmp_ubuntu", "lmp_fedora")


def _liggghts() -> str | None:
    """The LIGGGHTS binary on PATH (LAMMPS also installs lmp_*: its banner tells them apart)."""
    for name in LIGGGHTS_NAMES:
        path = shutil.which(name)
        if path is None:
            continue
        try:
            banner = subprocess.run([path, "-h"], capture_output=True, text=True, timeout=30).stdout
        except (OSError, subprocess.SubprocessError):
            continue
        if "LIGGGHTS" in banner:
            return path
    return None


def _input(card: dict, snippet: str) -> str:
    """A minimal complete LIGGGHTS input around ``snippet``: a box, a steel floor, 20
    particles of the card's template thrown onto it, 2,000 steps."""
    code = card["codes"]["liggghts"]
    types = code["atom_types"]
    integrate = ("fix dc_integrate all multisphere" if code["integration"] == "multisphere"
                 else "fix dc_integrate all nve/sphere")
    model = code["pair_style"].removeprefix("gran ")
    return "\n".join([
        "units si", "atom_style granular", "atom_modify map array", "boundary f f f", "newton off",
        "communicate single vel yes",
        "region domain block -0.05 0.05 -0.05 0.05 0.0 0.1 units box",
        f"create_box {len(types)} domain", "neighbor 0.004 bin", "neigh_modify delay 0",
        snippet,
        "timestep 2e-5",
        "fix gravity all gravity 9.81 vector 0.0 0.0 -1.0",
        f"fix floor all wall/gran {model} primitive type {types['steel']} zplane 0.0",
        integrate,
        "region drop block -0.03 0.03 -0.03 0.03 0.0 0.04 units box",
        f"fix drop all insert/pack seed 67867967 distributiontemplate {code['distribution_template']} "
        "vel constant 0 0 -0.5 insert_every once overlapcheck yes all_in yes particles_in_region 20 "
        "region drop",
        "compute contacts all contact/atom", "compute touching all reduce sum c_contacts",
        "thermo_style custom step atoms ke c_touching", "thermo 100",
        "run 2000", ""])


@pytest.mark.parametrize("campaign", ["repose", "sliding"])
def test_liggghts_snippet_runs_in_liggghts(campaign, request, capsys, tmp_path):
    binary = _liggghts()
    if binary is None:
        pytest.skip("LIGGGHTS is not installed (no liggghts or lmp_* binary with a LIGGGHTS banner on "
                    "PATH; Debian: apt-get install liggghts)")
    request.getfixturevalue(campaign)
    card = _card(capsys, f"{campaign}.toml", "--condition", "14.1 %")
    snippet = _export(capsys, f"{campaign}.toml", "--condition", "14.1 %", "--format", "liggghts")
    run = tmp_path / "liggghts"
    run.mkdir()
    (run / "in.demcal").write_text(_input(card, snippet))
    done = subprocess.run([binary, "-in", "in.demcal", "-log", "none", "-echo", "screen"], cwd=run,
                          capture_output=True, text=True, timeout=120)
    output = done.stdout + done.stderr
    assert done.returncode == 0, output[-3000:]
    assert "ERROR" not in output, output[-3000:]
    assert "inserted 20 particle templates" in output
    table = re.findall(r"^\s+(\d+)\s+(\d+)\s+\S+\s+(\d+)\s*$", output, re.M)
    assert table and table[-1][0] == "2000"
    assert max(int(t[2]) for t in table) > 0, "the particles never touched: the contact law was not exercised"


# ----------------------------------------------------------------------------------- edem


def test_edem_tables(repose, capsys):
    text = _export(capsys, "repose.toml", "--format", "edem", "--condition", "6.26 %")
    assert "Particle to Particle: base model Hysteretic Spring; rolling friction Standard Rolling Friction" in text
    assert ("Material,Poisson's Ratio,Solid Density (kg/m3),Shear Modulus (Pa),Yield Strength (Pa)\n"
            "particle,0.46,1687.85,1e+06,200000\nsteel,0.3,7800,7e+10,2.5e+08\n") in text
    # each calibrated value with the low and high ends of its solution set beside it
    assert ("Material 1,Material 2,Coefficient of Restitution,Coefficient of Restitution low,"
            "Coefficient of Restitution high,Coefficient of Static Friction,Coefficient of Static Friction low,"
            "Coefficient of Static Friction high,Coefficient of Rolling Friction,Coefficient of Rolling Friction low,"
            "Coefficient of Rolling Friction high,Damping Factor,Damping Factor low,Damping Factor high,"
            "Stiffness Factor\n"
            "particle,particle,0.58,0.5,0.7,0.312,0.298,0.335,0.105,0.1,0.232,0.12,0,0.2,0.95\n"
            "particle,steel,0.5,,,0.6,,,0.3,,,0.1,,,0.95\n") in text
    assert "Sphere,Radius (mm),X (mm),Y (mm),Z (mm)\n1,4," in text and "\n2,5," in text
    assert "distance between the sphere centres: 7 mm" in text
    assert "Factory size: Random (uniform scale), Min 0.5, Max 1.5" in text
    assert campaign_hash(load_campaign("repose.toml")) in text
    flat = " ".join(line.lstrip("# ") for line in text.splitlines())
    assert "sample L, moisture 6.26 ± 1.5 %, bulk density 1697.95 kg/m3" in flat
    assert "simulated 31.2 ± 0.7 (n = 3), error 0.42 %, inside the lab sd" in flat


def test_edem_tables_of_a_hertz_mindlin_material(sliding, capsys):
    text = _export(capsys, "sliding.toml", "--format", "edem")
    assert "base model Hertz-Mindlin (no slip); rolling friction Type C Rolling Friction" in text
    assert "Yield Strength" not in text and "Damping Factor" not in text
    assert "Rolling Viscous Damping Ratio\n" in text
    assert "particle,film,0.53,0.4,0.6,0.48,0.446,0.513,0.22,0.1,0.3,0.3\n" in text
    assert "film,0.4,920,1e+08\n" in text


def test_edem_tables_of_a_jkr_material(example, capsys):
    # a cohesive soil: EDEM's Hertz-Mindlin with JKR Cohesion, the surface energies in the
    # interaction table; LIGGGHTS 3.8 has no JKR, so its snippet says not transferable
    path = example / "sliding.toml"
    jkr = ('\n[experiment.settings]\n"contact.model" = "hertz_mindlin_jkr"\n'
           '"particle.surface_energy" = 0.4\n"film.surface_energy" = 0.1\n'
           '"particle.rolling_damping" = 0.2\n')
    path.write_text(path.read_text().replace('profile = "quick"\n', 'profile = "quick"\n' + jkr, 1))
    _calibrate(example, "sliding", SLIDING_CALIBRATION)
    text = _export(capsys, "sliding.toml", "--format", "edem")
    assert "base model Hertz-Mindlin with JKR Cohesion; rolling friction Standard Rolling Friction" in text
    assert "NOT TRANSFERABLE" not in text
    assert ",Coefficient of Rolling Friction high,Surface Energy (J/m2)\n" in text
    assert "particle,particle,0.6,,,0.4,,,0.2,,,0.4\n" in text
    assert "particle,film,0.53,0.4,0.6,0.48,0.446,0.513,0.22,0.1,0.3,0.1\n" in text
    card = _card(capsys, "sliding.toml", "--format", "json")
    rows = {tuple(r["materials"]): r for r in card["conditions"][0]["interactions"]}
    assert rows[("particle", "particle")]["rolling_damping"] == 0.2     # the setting, not a default
    assert rows[("particle", "steel")]["surface_energy"] == 0.0
    ligg = _export(capsys, "sliding.toml", "--format", "liggghts")
    assert "has no JKR cohesion" in " ".join(line.lstrip("# ") for line in ligg.splitlines())


# ------------------------------------------------------------------------------ warnings


def _warned(capsys, *argv) -> tuple[str, list[str]]:
    """``demcal export argv``: exit status 0, the card on stdout, and the warnings of its
    stderr (every line a ``demcal: warning:`` sentence)."""
    assert main(["export", *argv]) == 0
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert all(line.startswith("demcal: warning: ") and line.endswith(".") for line in lines), lines
    return captured.out, [line.removeprefix("demcal: warning: ") for line in lines]


def test_every_warning_is_said_on_stderr_for_every_format(repose, capsys):
    out, said = _warned(capsys, "repose.toml")
    assert json.loads(out)["warnings"] == said == [QUICK, UNVERIFIED, NOT_LIGGGHTS]  # stdout stays the card
    out, said = _warned(capsys, "repose.toml", "--format", "liggghts", "-o", "soil.liggghts")
    assert out == "liggghts card: soil.liggghts\n" and said == [QUICK, UNVERIFIED, NOT_LIGGGHTS]
    text = (repose / "soil.liggghts").read_text()
    flat = " ".join(line.removeprefix("#").strip() for line in text.split("\n\n")[0].splitlines())
    assert flat == f"demcal material card: 2 warnings; read them before using the values. " \
                   f"WARNING: {QUICK} WARNING: {UNVERIFIED}"
    assert text.count("NOT TRANSFERABLE TO LIGGGHTS") == 2  # once a block, not in the head
    out, said = _warned(capsys, "repose.toml", "--format", "edem", "--condition", "6.26 %")
    assert said == [QUICK]  # EDEM has the Hysteretic Spring and the standard rolling friction
    assert out.startswith("# demcal material card: 1 warning; read it before using the values.\n# WARNING: ")
    assert "14.1 %" not in out


def test_tiny_profile_and_stopped_loops_are_named(repose, capsys):
    """A tiny calibration whose loops stopped short: the profile (a smoke test), each
    condition with its loop's status, and calibration.json's own warnings, as written."""
    tiny = "profile 'tiny' is a smoke test; not a calibration: its particles are too few."
    data = json.loads(json.dumps(REPOSE_CALIBRATION))
    data.update(profile="tiny", production="tiny", warnings=[tiny])
    data["conditions"][0].update(status="out of reach", status_reason="the path ends at the limits")
    data["conditions"][1].update(status="unfinished", verification=[{**VERIFIED, "simulated": []}])
    _calibrate(repose, "repose", data)
    card, said = _warned(capsys, "repose.toml")
    assert json.loads(card)["warnings"] == said == [
        "calibrated at profile 'tiny' (a smoke test), smaller than the full-size bench: the values are the tiny bench's, "
        "not the full-size one's.",
        "condition '6.26 %' is not verified: its calibration loop ended 'out of reach' (the test cannot give the "
        "lab's angle within the factors' limits).",
        "condition '14.1 %' is not verified: its calibration loop ended 'unfinished' (runs it asked for are not "
        "done yet; run `demcal calibrate repose.toml` to finish them).",
        NOT_LIGGGHTS, tiny]
    # designed at one cheap profile and verified at another: the values are the second's
    data.update(profile="tiny", production="quick", warnings=[])
    for condition in data["conditions"]:
        condition["status"] = "verified"
    _calibrate(repose, "repose", data)
    assert _warned(capsys, "repose.toml", "--format", "edem")[1] == [
        "designed at profile 'tiny' and verified at 'quick', smaller than the full-size bench: the values are the quick "
        "bench's, not the full-size one's."]


def test_verification_without_a_loop_status_is_judged(repose, capsys):
    """A calibration.json without the loop's status (an older one): its verification runs
    tell unfinished, missed and not judged (no lab sd) apart."""
    data = json.loads(json.dumps(REPOSE_CALIBRATION))
    data["conditions"][0]["verification"] = [{**VERIFIED, "within_lab_sd": False}]
    data["conditions"][1]["verification"] = [{**VERIFIED, "simulated": []}, {**VERIFIED, "lab_sd": None,
                                                                                "within_lab_sd": None}]
    _calibrate(repose, "repose", data)
    assert _warned(capsys, "repose.toml", "--format", "edem")[1] == [QUICK, (
        "condition '6.26 %' is not verified: the simulated repose_angle_deg misses the lab's sd."), (
        "condition '14.1 %' is not verified: the verification of repose_angle_deg is unfinished."), (
        "condition '14.1 %' is not verified: repose_angle_deg has no lab sd to judge it by.")]


def test_a_paper_verified_hertz_mindlin_cdt_card_warns_only_where_it_must(sliding, capsys):
    """Hertz-Mindlin with cdt rolling, designed at quick and verified at the paper's profile:
    nothing to warn about for LIGGGHTS; EDEM has no cdt. Verified at quick, it warns too."""
    path = sliding / "sliding.toml"
    path.write_text(path.read_text().replace('"rolling.model" = "type_c"', '"rolling.model" = "cdt"'))
    data = json.loads(json.dumps(SLIDING_CALIBRATION))
    data["production"] = "paper"
    fixed = {"contact.model": "hertz_mindlin", "rolling.model": "cdt", "particles.shape": "sphere",
             "particle.shear_modulus": 5e6, "particle.poisson_ratio": 0.3}
    taken = REPOSE_CALIBRATION["conditions"][1]["chosen"]  # from_campaign = "repose.toml", as recorded
    data["conditions"][0].update(status="verified", settings={
        **{k: {"value": v, "source": "campaign file"} for k, v in fixed.items()},
        **{k: {"value": v, "source": "campaign repose.toml, calibrated"} for k, v in taken.items()}})
    _calibrate(sliding, "sliding", data)
    out, said = _warned(capsys, "sliding.toml", "--format", "liggghts")
    assert said == [] and out.startswith("# ---") and "NOT TRANSFERABLE" not in out and "WARNING" not in out
    not_edem = transfer_warning({"contact": "hertz_mindlin", "rolling": "cdt"}, "edem")
    assert not_edem == ("the values do not carry over to EDEM, whose models differ from demcal's rolling.model "
                        "= cdt; choose rolling.model = type_a, type_c or rvd in [experiment.settings] before the "
                        "design, and calibrate again.")
    assert _warned(capsys, "sliding.toml")[1] == [not_edem]
    out, said = _warned(capsys, "sliding.toml", "--format", "edem")
    assert said == [not_edem] and "# NOT TRANSFERABLE" in out and "WARNING" not in out
    data["production"] = "quick"
    _calibrate(sliding, "sliding", data)
    assert _warned(capsys, "sliding.toml", "--format", "liggghts")[1] == [QUICK]


# ---------------------------------------------------------------------------- the command


def test_out_file_is_written_whole(repose, capsys):
    assert main(["export", "repose.toml", "--format", "edem", "-o", "cards/soil.txt"]) == 0
    assert "cards/soil.txt" in capsys.readouterr().out
    assert "# demcal material card for EDEM" in (repose / "cards" / "soil.txt").read_text()
    assert main(["export", "repose.toml", "--format", "edem", "-o", "cards/soil.txt"]) == 0  # its own card
    assert main(["export", "repose.toml", "-o", "cards/soil.txt"]) == 0  # replaced
    assert json.loads((repose / "cards" / "soil.txt").read_text())["card"] == "demcal material card"
    assert sorted(p.name for p in (repose / "cards").iterdir()) == ["soil.txt"]  # no temporary left


def _error(capsys, *argv) -> str:
    assert main(["export", *argv]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert captured.out == "" and "Traceback" not in err and len(err.splitlines()) == 1, err
    assert err.startswith("demcal: error: ") and err.endswith(".")
    return err.removeprefix("demcal: error: ")


def test_no_calibration_yet_is_one_sentence(example, capsys):
    err = _error(capsys, "repose.toml")
    assert err.startswith("repose.toml has no calibration yet")
    assert err.endswith("run `demcal calibrate repose.toml` first.")


@pytest.mark.parametrize("argv, words", [
    (["--condition", "7 %"], "condition '7 %' is not in repose.toml; choose '6.26 %' or '14.1 %'."),
    (["--format", "xml"], "unknown export format 'xml'; choose json, liggghts or edem."),
    (["-o", "."], "--out . is a folder; give a file path."),
])
def test_bad_options_are_one_sentence(repose, capsys, argv, words):
    assert _error(capsys, "repose.toml", *argv) == words


def test_condition_without_calibration_and_broken_file(repose, capsys):
    data = json.loads(json.dumps(REPOSE_CALIBRATION))
    data["conditions"] = data["conditions"][:1]
    _calibrate(repose, "repose", data)
    assert _error(capsys, "repose.toml", "--condition", "14.1 %") == (
        "condition '14.1 %' has no calibration yet; run `demcal calibrate repose.toml` first.")
    assert len(_card(capsys, "repose.toml")["conditions"]) == 1  # every calibrated condition
    (repose / "repose-runs" / "calibration.json").write_text('{"conditions": [')
    assert "is not valid JSON" in _error(capsys, "repose.toml")
