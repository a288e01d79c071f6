"""Chained campaigns: a condition's fixed settings from another campaign's calibration
(``from_campaign``) and from ``[conditions.settings]``, on the test double ``test-heap``.

The first campaign calibrates static and rolling friction for two conditions; the second
varies restitution and damping and takes, for each condition, the friction values the
first calibrated for it. Every run the second asks for -- its designs, the closed loop's
path runs, moved boxes and production runs -- must carry them, and a run key must change
with them (and only with them: a campaign without per-condition settings keeps its keys).
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest

from demcal.campaign.calibrate import calibrate, describe
from demcal.campaign.chain import resolve_chain
from demcal.campaign.config import load_campaign, parse_campaign
from demcal.campaign.runner import design_specs, plan_design, run_campaign
from demcal.campaign.store import Store
from demcal.cli import main
from demcal.errors import DataError

from conftest import CAMPAIGN, InlineExecutor, edited
from sentences import one_sentence

FRICTION = ("particle.static_friction", "particle.rolling_friction")

EXPERIMENT = """\
[experiment]
test = "test-heap"
profile = "tiny"
plugins = ["campaign_testbench"]

[experiment.settings]
"test.sleep_s" = 0.0
"""

#: Calibrates static (B) and rolling (C) friction; restitution and damping at the defaults.
UPSTREAM = """\
[campaign]
name = "up"

""" + EXPERIMENT + """
[[factors]]
name = "B"
parameter = "particle.static_friction"
low = 0.3
high = 0.5

[[factors]]
name = "C"
parameter = "particle.rolling_friction"
low = 0.1
high = 0.3

[design]
type = "full-factorial"
levels = 3
center = 3

[runs]
seed = 5

[[conditions]]
name = "dry"
targets = { repose_angle_deg = { mean = 36.0, sd = 1.5 } }

[[conditions]]
name = "wet"
targets = { repose_angle_deg = { mean = 42.0, sd = 1.5 } }

[verification]
replicates = 2
"""

#: Varies restitution (A) and damping (D); the friction of each condition comes from up.toml.
DOWNSTREAM = """\
[campaign]
name = "down"
from_campaign = "up.toml"

""" + EXPERIMENT + """\
"geometry.scale" = 5.0

[[factors]]
name = "A"
parameter = "particle.restitution"
low = 0.5
high = 0.7

[[factors]]
name = "D"
parameter = "particle.damping_factor"
low = 0.0
high = 0.2

[design]
type = "full-factorial"
levels = 3
center = 3

[runs]
seed = 9

[[conditions]]
targets = { repose_angle_deg = { mean = DRY, sd = 1.0 } }
name = "dry"

[[conditions]]
targets = { repose_angle_deg = { mean = WET, sd = 1.0 } }
name = "wet"

[verification]
replicates = 2

[calibration]
production = "quick"
box_moves = 2
# lay the moved box's design even where the path crosses the target: the test checks
# that its runs carry the condition's values too
verify_on_path = false
"""


def write(folder: Path, name: str, text: str, replace: dict[str, str] | None = None) -> Path:
    path = folder / name
    path.write_text(edited(text, replace))
    return path


def downstream(folder: Path, dry: float = 36.5, wet: float = 41.5, replace: dict[str, str] | None = None) -> Path:
    text = DOWNSTREAM.replace("DRY", str(dry)).replace("WET", str(wet))
    return write(folder, "down.toml", text, replace)


def calibrated_upstream(folder: Path) -> dict[str, dict[str, float]]:
    """Run and calibrate up.toml in ``folder``; condition -> its calibrated friction."""
    up = load_campaign(write(folder, "up.toml", UPSTREAM))
    assert run_campaign(up, executor=InlineExecutor(), progress=False).done == 12
    cal = calibrate(up, executor=InlineExecutor(), progress=False)
    return {r.condition.name: r.chosen for r in cal.conditions}


def fake_calibration(folder: Path, chosen: dict[str, dict[str, float]], status: str = "verified") -> None:
    """up.toml and a calibration.json of it as `demcal calibrate` writes it (no runs behind it)."""
    write(folder, "up.toml", UPSTREAM)
    (folder / "up-runs").mkdir(exist_ok=True)
    (folder / "up-runs" / "calibration.json").write_text(json.dumps(
        {"campaign": "up", "profile": "tiny", "test": "test-heap",
         "conditions": [{"name": name, "chosen": values, "status": status} for name, values in chosen.items()]}))


@pytest.fixture(scope="module")
def chained(tmp_path_factory):
    """up.toml calibrated, then down.toml run and calibrated; the wet target of down.toml
    lies above its box, so its loop moves the box (path runs, a new design)."""
    folder = tmp_path_factory.mktemp("chain")
    upstream = calibrated_upstream(folder)
    campaign = load_campaign(downstream(folder, wet=46.0))
    summary = run_campaign(campaign, executor=InlineExecutor(), progress=False)
    cal = calibrate(campaign, executor=InlineExecutor(), progress=False)
    return folder, upstream, campaign, summary, cal


def test_the_second_campaign_runs_each_condition_with_the_first_ones_values(chained):
    folder, upstream, campaign, summary, cal = chained
    assert upstream["dry"] != upstream["wet"]
    # one 12-run design per condition, each with that condition's calibrated friction
    assert summary.done == 24 and summary.total == 24
    resolved = resolve_chain(campaign)
    assert [c.upstream.values for c in resolved.conditions] == [upstream["dry"], upstream["wet"]]
    assert [d.name for d in cal.designs] == ["dry", "wet"]
    for design in cal.designs:
        assert len(design.table) == 12 and (design.table["status"] == "done").all()
        values = upstream[design.name]
        assert {k: design.campaign.settings[k] for k in FRICTION} == values
        assert design.campaign.settings["geometry.scale"] == 5.0  # [experiment.settings] kept
    with Store(campaign.store_path, readonly=True) as store:
        records = store.records()
    by_condition = {name: [r for r in records if {k: r.settings.get(k) for k in FRICTION} == values]
                    for name, values in upstream.items()}
    # every run of the store -- designs, path runs, moved boxes, production runs -- is one
    # condition's, with its values
    assert sum(len(runs) for runs in by_condition.values()) == len(records)
    assert all(r.settings["geometry.scale"] == 5.0 for r in records)
    kinds = {name: {(r.kind, r.profile) for r in runs} for name, runs in by_condition.items()}
    assert kinds["dry"] >= {("design", "tiny"), ("verification", "quick")}
    assert kinds["wet"] >= {("design", "tiny"), ("path", "tiny"), ("verification", "quick")}
    assert all(r.label.startswith(("dry ", "wet ")) for r in records if r.kind == "design" and "box" not in r.label)
    dry, wet = cal.conditions
    assert len(wet.loop.boxes) > 1 and len(dry.loop.boxes) == 1
    # each condition's loop saw its own runs only: its production runs carry its values
    for result in cal.conditions:
        assert result.verification and all({k: r.settings[k] for k in FRICTION} == upstream[result.condition.name]
                                           for r in result.verification)
    assert dry.loop.status == "verified", dry.loop.reason
    assert abs(dry.verdicts[0].simulated_mean - 36.5) <= 1.0


def test_calibration_json_report_and_card_say_where_each_value_came_from(chained, capsys, monkeypatch):
    folder, upstream, campaign, summary, cal = chained
    data = json.loads((campaign.workdir / "calibration.json").read_text())
    source = "campaign up.toml, calibrated"
    for entry in data["conditions"]:
        settings = entry["settings"]
        assert {k: settings[k] for k in FRICTION} == {k: {"value": v, "source": source}
                                                      for k, v in upstream[entry["name"]].items()}
        assert settings["geometry.scale"] == {"value": 5.0, "source": "campaign file"}
        assert set(entry["models"]) == {"repose_angle_deg"}  # each condition's own design's model
    text = describe(cal)
    assert "geometry.scale = 5.0 (campaign file)" in text
    assert f"particle.static_friction = {upstream['dry']['particle.static_friction']} ({source})" in text

    from demcal.report.campaign_report import write_report

    html = write_report(campaign, campaign.workdir / "report", [cal], figure_files=False).read_text()
    assert "Fixed settings per condition" in html and source in html
    assert "Design and results of dry" in html and "Design and results of wet" in html
    assert "Response model of Repose angle [°] (wet)" in html
    table = json.loads((campaign.workdir / "report" / "tables" / "condition_settings.json").read_text())
    assert {(r["condition"], r["setting"], r["source"]) for r in table} == {
        (name, key, source) for name in upstream for key in FRICTION} | {
        (name, "test.sleep_s", "campaign file") for name in upstream} | {
        (name, "geometry.scale", "campaign file") for name in upstream}

    monkeypatch.chdir(folder)
    assert main(["export", "down.toml"]) == 0
    card = json.loads(capsys.readouterr().out)
    # nothing about the chain; what any card of a cheap profile and the default models says, and
    # calibration.json's own warnings (both loops verified: no condition is named)
    assert [r.loop.status for r in cal.conditions] == ["verified", "verified"]
    assert card["warnings"] == [
        "designed at profile 'tiny' and verified at 'quick', smaller than the full-size bench: the values are the quick "
        "bench's, not the full-size one's.",
        "the values do not carry over to LIGGGHTS 3.8, whose models differ from demcal's contact.model = "
        "hysteretic_spring and rolling.model = type_a; choose contact.model = hertz_mindlin and rolling.model = "
        "cdt in [experiment.settings] before the design, and calibrate again.", *data["warnings"]]
    assert data["warnings"] and all("profile 'tiny'" in w for w in data["warnings"])
    for condition in card["conditions"]:
        values = upstream[condition["name"]]
        assert {k: condition["fixed_settings"][k] for k in FRICTION} == {
            k: {"value": v, "source": source} for k, v in values.items()}
        parameters = condition["parameters"]
        assert parameters["particle.static_friction"]["source"] == source
        assert parameters["particle.static_friction"]["value"] == values["particle.static_friction"]
        assert parameters["particle.restitution"]["source"] == "calibrated"
        assert parameters["particle.density"]["source"] == "demcal default"  # test-heap has none
    assert main(["export", "down.toml", "--format", "liggghts", "--condition", "dry"]) == 0
    flat = " ".join(line.lstrip("# ") for line in capsys.readouterr().out.splitlines())
    dry = upstream["dry"]
    assert (f"{source}: particle.static_friction = {dry['particle.static_friction']:g}, "
            f"particle.rolling_friction = {dry['particle.rolling_friction']:g};") in flat


def test_report_and_calibrate_again_replay_without_running(chained, markers):
    folder, upstream, campaign, summary, cal = chained
    again = calibrate(load_campaign(campaign.path), executor=InlineExecutor(), progress=False)
    assert not markers()  # every run it asks for is in the store already
    assert [r.chosen for r in again.conditions] == [r.chosen for r in cal.conditions]
    replay = calibrate(load_campaign(campaign.path), simulate=False, progress=False)
    assert [r.chosen for r in replay.conditions] == [r.chosen for r in cal.conditions]


# ------------------------------------------------------------------- precedence, keys


def test_conditions_settings_win_over_from_campaign_which_wins_over_experiment_settings(tmp_path):
    fake_calibration(tmp_path, {"dry": {"particle.static_friction": 0.41, "particle.rolling_friction": 0.22},
                                "wet": {"particle.static_friction": 0.47, "particle.rolling_friction": 0.28}})
    path = downstream(tmp_path, replace={
        '"geometry.scale" = 5.0\n': '"geometry.scale" = 5.0\n"particle.rolling_friction" = 0.15\n',
        'name = "dry"\n': 'name = "dry"\n[conditions.settings]\n"particle.static_friction" = 0.35\n'
                          '"geometry.scale" = 6.0\n'})
    campaign = resolve_chain(load_campaign(path))
    dry, wet = (campaign.for_condition(c).settings for c in campaign.conditions)
    assert (dry["particle.static_friction"], dry["particle.rolling_friction"], dry["geometry.scale"]) == (0.35, 0.22, 6.0)
    assert (wet["particle.static_friction"], wet["particle.rolling_friction"], wet["geometry.scale"]) == (0.47, 0.28, 5.0)
    specs = design_specs(campaign)
    assert len(specs) == 24
    assert {s.settings["particle.static_friction"] for s in specs if s.label.startswith("dry ")} == {0.35}
    assert {s.settings["particle.static_friction"] for s in specs if s.label.startswith("wet ")} == {0.47}

    from demcal.campaign.chain import condition_settings

    sources = condition_settings(campaign)
    assert sources["dry"]["particle.static_friction"] == (0.35, "campaign file")
    assert sources["dry"]["particle.rolling_friction"] == (0.22, "campaign up.toml, calibrated")
    assert sources["wet"]["geometry.scale"] == (5.0, "campaign file")
    assert sources["dry"]["geometry.scale"] == (6.0, "campaign file")


def test_a_condition_may_take_another_campaign_or_none(tmp_path):
    """from_campaign per condition; a condition without it keeps the defaults (source "default")."""
    fake_calibration(tmp_path, {"wet": {"particle.static_friction": 0.47, "particle.rolling_friction": 0.28}})
    path = downstream(tmp_path, replace={'from_campaign = "up.toml"\n': "",
                                         'name = "wet"\n': 'name = "wet"\nfrom_campaign = "up.toml"\n'})
    campaign = resolve_chain(load_campaign(path))
    assert campaign.conditions[0].upstream is None and campaign.per_condition
    from demcal.campaign.chain import condition_settings

    assert condition_settings(campaign)["dry"]["particle.static_friction"] == (0.4, "default")
    dry, wet = campaign.designs()
    assert dry[0].settings == campaign.settings and wet[0].settings["particle.static_friction"] == 0.47


#: Keys computed before per-condition settings existed (conftest.CAMPAIGN with sleep 0.02,
#: loaded from /tmp/x/campaign.toml): the first design run, the SHA-256 of every design
#: key joined by newlines, two production runs, and the design of a moved box.
KEYS_BEFORE = {
    "first": "c5f2f5a088754cef8de6878225a9bdce660877382b756b901421d4efbdd24f18",
    "design": "eddbc056cad59e36b1746726d86e800088ca235568ebe26c0e3e83b271673802",
    "production": ["d3a4d7ebf3f2686468746fa322b5606fc16df9724cd59e95ed8948ee7b26ce0d",
                   "1379cfce701b384cff3fd2083404d22850dfca21e99f69a541c6209f9b353cc3"],
    "box": "8f61c96d1b6ef47a03d034f6b943070e74e195920d50a78596497db6b46eef0f",
}


def test_a_campaign_without_per_condition_settings_keeps_its_run_keys():
    from demcal.campaign.loop import Box, _production_specs

    campaign = parse_campaign(CAMPAIGN.format(sleep=0.02), Path("/tmp/x/campaign.toml"))
    assert not campaign.per_condition and resolve_chain(campaign) is campaign
    assert campaign.designs() == [(campaign, campaign.conditions)]
    keys = [s.key for s in design_specs(campaign)]
    assert keys == [s.key for s in plan_design(campaign).specs]
    assert keys[0] == KEYS_BEFORE["first"]
    assert hashlib.sha256("\n".join(keys).encode()).hexdigest() == KEYS_BEFORE["design"]
    chosen = {"particle.restitution": 0.6, "particle.static_friction": 0.45, "particle.rolling_friction": 0.2,
              "particle.damping_factor": 0.1}
    production = _production_specs(campaign, campaign.conditions[1], 1, chosen, "tiny", 2)
    assert [s.key for s in production] == KEYS_BEFORE["production"]
    box = Box(1, (0.55, 0.35, 0.15, 0.05), (0.75, 0.55, 0.35, 0.25))
    moved = [s.key for s in plan_design(box.campaign(campaign)).specs]
    assert hashlib.sha256("\n".join(moved).encode()).hexdigest() == KEYS_BEFORE["box"]


def test_fixed_settings_change_the_run_keys_and_runs_are_never_reused_across_them(tmp_path, markers):
    """Resume safety: a recalibrated first campaign gives the second new run keys (its old
    runs are kept, not reused); going back to the old values finds them again."""
    fake_calibration(tmp_path, {"dry": {"particle.static_friction": 0.41, "particle.rolling_friction": 0.22},
                                "wet": {"particle.static_friction": 0.47, "particle.rolling_friction": 0.28}})
    path = downstream(tmp_path)
    first = run_campaign(load_campaign(path), executor=InlineExecutor(), progress=False)
    assert (first.done, first.ran) == (24, 24) and sum(markers().values()) == 24
    dry = {s.key for s in design_specs(load_campaign(path)) if s.label.startswith("dry ")}
    wet = {s.key for s in design_specs(load_campaign(path)) if s.label.startswith("wet ")}
    assert len(dry) == len(wet) == 12 and not dry & wet  # the same seeds, other settings

    again = run_campaign(load_campaign(path), executor=InlineExecutor(), progress=False)
    assert (again.ran, again.skipped) == (0, 24) and sum(markers().values()) == 24

    # the first campaign calibrated again: wet's values change, dry's do not
    fake_calibration(tmp_path, {"dry": {"particle.static_friction": 0.41, "particle.rolling_friction": 0.22},
                                "wet": {"particle.static_friction": 0.46, "particle.rolling_friction": 0.28}})
    with pytest.raises(DataError, match=r"12 of 12 design runs are not done yet"):
        calibrate(load_campaign(path), executor=InlineExecutor(), progress=False)
    moved = run_campaign(load_campaign(path), executor=InlineExecutor(), progress=False)
    assert (moved.ran, moved.skipped) == (12, 12) and sum(markers().values()) == 36
    with Store(load_campaign(path).store_path, readonly=True) as store:
        assert store.counts()["done"] == 36  # nothing overwritten

    fake_calibration(tmp_path, {"dry": {"particle.static_friction": 0.41, "particle.rolling_friction": 0.22},
                                "wet": {"particle.static_friction": 0.47, "particle.rolling_friction": 0.28}})
    back = run_campaign(load_campaign(path), executor=InlineExecutor(), progress=False)
    assert (back.ran, back.skipped) == (0, 24) and sum(markers().values()) == 36


# --------------------------------------------------------------------------- sentences


def test_missing_upstream_results_name_the_command_to_run_first(tmp_path, capsys):
    write(tmp_path, "up.toml", UPSTREAM)
    path = downstream(tmp_path)
    message = one_sentence(lambda: run_campaign(load_campaign(path), executor=InlineExecutor(), progress=False),
                           DataError)
    assert message.startswith("down.toml takes the settings of its conditions from up.toml: up.toml has no "
                              "calibration yet")
    assert message.endswith(f"run `demcal calibrate {tmp_path / 'up.toml'}` first.")
    for command in ("run", "calibrate", "report"):
        assert main([command, str(path)]) == 2
        err = capsys.readouterr().err
        assert "Traceback" not in err and f"`demcal calibrate {tmp_path / 'up.toml'}` first." in err, err
    assert not (tmp_path / "down-runs" / "store.sqlite").exists()  # nothing planned, nothing stored


def test_upstream_without_the_condition_is_one_sentence(tmp_path):
    fake_calibration(tmp_path, {"dry": {"particle.static_friction": 0.41, "particle.rolling_friction": 0.22}})
    message = one_sentence(lambda: resolve_chain(load_campaign(downstream(tmp_path))), DataError)
    assert message.startswith("down.toml, condition 'wet': the calibration of up.toml holds no condition 'wet' "
                              "(it holds 'dry'); name the conditions alike in both files")


def test_a_factor_may_not_be_fixed(tmp_path, capsys):
    write(tmp_path, "up.toml", UPSTREAM)
    # by [conditions.settings]: refused while the file is read, with its line
    path = downstream(tmp_path, replace={'name = "wet"\n': 'name = "wet"\n[conditions.settings]\n'
                                                           '"particle.damping_factor" = 0.1\n'})
    message = one_sentence(lambda: load_campaign(path))
    line = path.read_text().splitlines().index('"particle.damping_factor" = 0.1') + 1
    assert message == (f"down.toml line {line}: 'particle.damping_factor' is a factor of this campaign, so "
                       "condition 'wet' cannot fix it; remove it from [conditions.settings] (the design varies it).")
    assert main(["run", str(path)]) == 2 and "Traceback" not in capsys.readouterr().err
    # by the other campaign's calibration
    fake_calibration(tmp_path, {name: {"particle.static_friction": 0.41, "particle.damping_factor": 0.12}
                                for name in ("dry", "wet")})
    message = one_sentence(lambda: resolve_chain(load_campaign(downstream(tmp_path))))
    assert message == ("down.toml, condition 'dry': 'particle.damping_factor', calibrated by up.toml, is a factor "
                       "of this campaign and cannot also be fixed; drop the factor, or take this condition's "
                       "settings from a campaign that does not calibrate it.")


@pytest.mark.parametrize("edit, words", [
    ({'from_campaign = "up.toml"': 'from_campaign = "nowhere.toml"'},
     "from_campaign 'nowhere.toml' does not exist next to the campaign file"),
    ({'from_campaign = "up.toml"': 'from_campaign = "down.toml"'},
     "from_campaign 'down.toml' is this campaign file itself"),
    ({'name = "wet"\n': 'name = "wet"\n[conditions.settings]\n"particle.static_fricton" = 0.4\n'},
     "'particle.static_fricton' is not a setting of test-heap; did you mean 'particle.static_friction'?"),
    ({'name = "wet"\n': 'name = "wet"\nfrom_campaign = "../up.toml"\n'}, "lies outside the campaign file's folder"),
])
def test_bad_chains_are_refused_while_the_file_is_read(tmp_path, edit, words):
    folder = tmp_path / "sub" if "../" in str(edit) else tmp_path
    folder.mkdir(exist_ok=True)
    for where in {tmp_path, folder}:
        write(where, "up.toml", UPSTREAM)
    message = one_sentence(lambda: load_campaign(downstream(folder, replace=edit)), full_stop=False)
    assert message.startswith("down.toml line ") and words in message, message


def test_upstream_values_out_of_range_and_unknown_settings(tmp_path):
    fake_calibration(tmp_path, {name: {"particle.static_friction": 0.41, "film.static_friction": 0.3}
                                for name in ("dry", "wet")})
    message = one_sentence(lambda: resolve_chain(load_campaign(downstream(tmp_path))))
    assert "'film.static_friction', calibrated by up.toml, is not a setting of test-heap" in message
    fake_calibration(tmp_path, {name: {"particle.static_friction": 3.0} for name in ("dry", "wet")})
    message = one_sentence(lambda: resolve_chain(load_campaign(downstream(tmp_path))))
    assert message.startswith("down.toml, condition 'dry': the values calibrated by up.toml are not a valid run:")


def test_an_unverified_upstream_is_noted(tmp_path):
    fake_calibration(tmp_path, {name: {"particle.static_friction": 0.41, "particle.rolling_friction": 0.22}
                                for name in ("dry", "wet")}, status="budget spent")
    from demcal.campaign.chain import chain_notes

    notes = chain_notes(resolve_chain(load_campaign(downstream(tmp_path))))
    assert notes[0] == ("condition 'dry' takes the values up.toml calibrated for it, whose loop there ended "
                        "'budget spent', not verified; calibrate up.toml further before trusting what rests on them.")


def test_the_example_sliding_campaign_takes_the_repose_values(example):
    sliding = load_campaign("sliding.toml")
    assert {c.upstream.path.name for c in sliding.conditions} == {"repose.toml"}
    message = one_sentence(lambda: resolve_chain(sliding), DataError)
    assert message.endswith("run `demcal calibrate repose.toml` first.")
