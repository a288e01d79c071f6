"""Campaign files: every bad-file case of issue 5, acceptance 5, gets one sentence
naming the file, the line and the key; nothing is run and nothing is overwritten."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign, parse_campaign
from demcal.errors import ConfigError


def line_of(path, text: str) -> int:
    """Line of the first line of ``text`` (which must occur once) in the file."""
    content = path.read_text()
    assert content.count(text) == 1, text
    return content[: content.index(text)].count("\n") + 1


def test_good_file_loads(campaign_file):
    campaign = load_campaign(campaign_file())
    assert campaign.test == "test-heap" and campaign.profile == "tiny"
    assert [f.name for f in campaign.factors] == ["A", "B", "C", "D"]
    assert campaign.factors[1].parameter == "particle.static_friction"
    assert campaign.factors[1].to_actual(1.0) == pytest.approx(0.5)
    assert campaign.factors[3].to_coded(0.1) == pytest.approx(0.0)
    assert campaign.design.type == "box-behnken" and campaign.design.center == 5
    assert [c.name for c in campaign.conditions] == ["6.26 %", "14.1 %"]
    assert campaign.conditions[0].target("repose_angle_deg").mean == 36.0
    assert campaign.conditions[1].target("repose_angle_deg").sd == 2.2
    assert campaign.verification_replicates == 2
    assert campaign.workdir == campaign.path.parent / "test-campaign-runs"
    with pytest.raises(Exception):
        campaign.name = "x"  # frozen


# (edit to the good file, text on the offending line, words the sentence must contain)
BAD_FILES = {
    "unknown key": ({"low = 0.3\nhigh = 0.5": "lwo = 0.3\nhigh = 0.5"}, "lwo = 0.3",
                    ["unknown key 'lwo'", "did you mean 'low'"]),
    "unknown table key": ({'profile = "tiny"': 'profle = "tiny"'}, "profle",
                          ["unknown key 'profle'", "did you mean 'profile'"]),
    "low >= high": ({"low = 0.3\nhigh = 0.5": "low = 0.5\nhigh = 0.3"}, "low = 0.5\nhigh = 0.3",
                    ["factor 'particle.static_friction' has low 0.5 >= high 0.3; swap them."]),
    "parameter path does not exist": (
        {'parameter = "particle.static_friction"': 'parameter = "particle.static_fricton"'},
        "static_fricton", ["'particle.static_fricton' is not a setting of test-heap",
                           "did you mean 'particle.static_friction'"]),
    "restitution above 1": ({"low = 0.5\nhigh = 0.7": "low = 0.5\nhigh = 1.2"}, "high = 1.2",
                            ["'particle.restitution'", "(0, 1]"]),
    "restitution zero": ({"low = 0.5\nhigh = 0.7": "low = 0.0\nhigh = 0.7"}, "low = 0.0\nhigh = 0.7",
                         ["'particle.restitution'", "(0, 1]"]),
    "missing target": ({"targets = { repose_angle_deg = { mean = 42.0, sd = 2.2 } }": 'label = "wet"'},
                       '[[conditions]]\nname = "14.1 %"', ["condition '14.1 %' has no target for response 'repose_angle_deg'"]),
    "unknown design type": ({'type = "box-behnken"': 'type = "box-benken"'}, "box-benken",
                            ["unknown design type 'box-benken'", "did you mean 'box-behnken'"]),
    "unknown test": ({'test = "test-heap"': 'test = "test-heep"'}, "test-heep",
                     ["unknown virtual test 'test-heep'"]),
    "not TOML": ({'name = "A"': 'name = "A'}, 'name = "A', ["not valid TOML"]),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_file_names_key_and_line(campaign_file, case):
    edit, offending, words = BAD_FILES[case]
    path = campaign_file(replace=edit)
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    message = str(info.value)
    line = line_of(path, offending)
    assert message.startswith(f"campaign.toml line {line}: "), message
    for word in words:
        assert word in message, message
    assert "\n" not in message and message.endswith((".", "?")), message


def test_missing_conditions_table():
    # everything else a campaign needs is there, so only the conditions are missing
    text = ("[campaign]\nname = 'x'\n[experiment]\ntest = 'test-heap'\n"
            "[[factors]]\nname = 'A'\nparameter = 'particle.static_friction'\nlow = 0.3\nhigh = 0.5\n")
    with pytest.raises(ConfigError) as info:
        parse_campaign(text, "c.toml")
    # a table that is not there has no line: the sentence names the file alone
    assert str(info.value) == "c.toml: missing [[conditions]]; a campaign needs [[conditions]]."
    text = "[campaign]\nname = 'x'\n[experiment]\ntest = 'test-heap'\n"
    with pytest.raises(ConfigError) as info:
        parse_campaign(text, "c.toml")
    assert str(info.value) == "c.toml: missing [[factors]]; a campaign needs [[factors]]."


def test_design_point_outside_a_setting_range(campaign_file):
    # A circumscribed CCD puts axial points beyond the factor levels: restitution 0.9 + alpha.
    path = campaign_file(replace={
        "low = 0.5\nhigh = 0.7": "low = 0.8\nhigh = 0.95",
        'type = "box-behnken"\ncenter = 5': 'type = "central-composite"\ncenter = 3',
    })
    from demcal.campaign.runner import plan_design

    campaign = load_campaign(path)
    with pytest.raises(ConfigError, match=r"design point \d+ is not a valid run: setting 'particle.restitution'"):
        plan_design(campaign)


def test_design_too_large_is_one_sentence(campaign_file):
    """Every design point is a DEM simulation: a design above the run cap is refused with
    its run count before anything is built (4 factors at 100 levels once ran out of memory)."""
    cases = (  # the first case is cheap to build, so unchecked code fails it quickly
        ('type = "full-factorial"\nlevels = 20', "160,000 runs"),
        ('type = "full-factorial"\ncenter = 200000', "200,016 runs"),
        ('type = "box-behnken"\ncenter = 200000', "200,024 runs"),
        ('type = "full-factorial"\nlevels = 100', "100,000,000 runs"),
        ('type = "full-factorial"\ncenter = 1000000000000', "1,000,000,000,016 runs"),
    )
    for new, words in cases:
        path = campaign_file(replace={'type = "box-behnken"\ncenter = 5': new})
        with pytest.raises(ConfigError) as info:
            load_campaign(path)
        message = str(info.value)
        assert message.startswith("campaign.toml line "), message
        assert words in message and "100,000" in message, message
        assert "\n" not in message and message.endswith("."), message


def _digest(folder):
    return {p.relative_to(folder): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_bad_file_runs_nothing_and_overwrites_nothing(campaign_file, capsys):
    from demcal.cli import main

    good = campaign_file()
    assert main(["run", str(good), "--quiet"]) == 0
    workdir = good.parent / "test-campaign-runs"
    before = _digest(workdir)
    capsys.readouterr()
    for case, (edit, _, _) in sorted(BAD_FILES.items()):
        bad = campaign_file(replace=edit)
        assert main(["run", str(bad)]) == 2, case
        err = capsys.readouterr().err
        assert err.startswith("demcal: error: campaign.toml line "), (case, err)
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, (case, err)
        assert _digest(workdir) == before, case


EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "residual-film-soil"


def test_targets_from_the_lab_file(campaign_file):
    shutil.copy(EXAMPLE / "lab.toml", campaign_file().parent / "lab.toml")
    path = campaign_file(replace={
        'name = "test campaign"': 'name = "test campaign"\nlab = "lab.toml"',
        'targets = { repose_angle_deg = { mean = 36.0, sd = 2.1 } }': 'sample = "L"',
        'targets = { repose_angle_deg = { mean = 42.0, sd = 2.2 } }': 'sample = "I"',
    })
    campaign = load_campaign(path)
    low, high = campaign.conditions
    assert (low.target("repose_angle_deg").mean, low.target("repose_angle_deg").sd) == (31.07, 2.1)
    assert (high.target("repose_angle_deg").mean, high.target("repose_angle_deg").sd) == (39.88, 2.2)
    assert low.sample.moisture_percent == 6.26 and high.sample.bulk_density == 1087.85


def test_unknown_sample_is_named(campaign_file):
    shutil.copy(EXAMPLE / "lab.toml", campaign_file().parent / "lab.toml")
    path = campaign_file(replace={
        'name = "test campaign"': 'name = "test campaign"\nlab = "lab.toml"',
        'targets = { repose_angle_deg = { mean = 36.0, sd = 2.1 } }': 'sample = "X"',
    })
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    line = line_of(path, 'sample = "X"')
    assert str(info.value) == f"campaign.toml line {line}: sample 'X' is not in the lab file; samples: L, I."


@pytest.mark.parametrize("new, shown", [('type = "full-factorial"\nlevels = 2.5', "2.5"),
                                        ('type = "full-factorial"\nlevels = "x"', "'x'"),
                                        ('type = "fractional-factorial"\nfraction = 0', "0")])
def test_design_counts_must_be_whole_numbers(campaign_file, new, shown):
    """levels = 2.5 was truncated to 2 and levels = "x" raised a bare ValueError."""
    path = campaign_file(replace={'type = "box-behnken"\ncenter = 5': new})
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    message = str(info.value)
    assert "must be a whole number of at least" in message and f"got {shown};" in message
    assert "\n" not in message and message.endswith("."), message


# --------------------------------------------------------------------------- issue 20: limits

def test_the_largest_allowed_seed_plans_and_stores(campaign_file):
    """Seeds lie in 0 .. 2^63 - 1 with every run seed derived from them: the largest
    [runs] seed the file allows plans runs the store takes (2^63 - 1 itself raised
    OverflowError in the store and left it empty)."""
    from demcal.campaign.runner import open_store, plan_design

    with pytest.raises(ConfigError) as info:
        load_campaign(campaign_file(replace={"seed = 7": f"seed = {2**63 - 1}"}))
    top = int(str(info.value).rsplit("at most ", 1)[1].rstrip("."))
    campaign = load_campaign(campaign_file(replace={"seed = 7": f"seed = {top}"}))
    specs = plan_design(campaign).specs
    assert top < max(s.seed for s in specs) <= 2**63 - 1
    with open_store(campaign) as store:
        store.add(specs)
        assert store.counts()["pending"] == len(specs)


def test_replicates_times_design_runs_are_capped(campaign_file):
    """29 design runs x 3,448 replicates = 99,992 runs is allowed; one more replicate is
    refused by the loader with the run count (20,000 replicates built 580,000 rows)."""
    assert load_campaign(campaign_file(replace={"seed = 7": "seed = 7\nreplicates = 3448"})).replicates == 3448
    path = campaign_file(replace={"seed = 7": "seed = 7\nreplicates = 3449"})
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    assert str(info.value) == (
        f"campaign.toml line {line_of(path, 'replicates = 3449')}: 29 design runs x 3,449 replicates has "
        "100,021 runs, more than the 100,000 a design may have (every run is a DEM simulation); use fewer "
        "replicates.")


# --------------------------------------------------------------------------- issue 20: plugins

def test_reading_a_file_imports_no_plugin(campaign_file, tmp_path, monkeypatch):
    """A test only a plugin registers is refused by name when the file is just read
    (report, export); run and calibrate import the plugin from the campaign folder."""
    import sys

    monkeypatch.setattr(sys, "path", list(sys.path))
    (tmp_path / "heap_plugin_20.py").write_text(
        "from pathlib import Path\n"
        "Path(__file__).with_name('imported').write_text('yes')\n"
        "import campaign_testbench\n"
        "from demcal.bench.registry import register\n"
        "class Heap(campaign_testbench.HeapDouble):\n    name = 'heap-20'\n"
        "register(Heap())\n")
    path = campaign_file(replace={'test = "test-heap"': 'test = "heap-20"',
                                  'plugins = ["campaign_testbench"]': 'plugins = ["heap_plugin_20"]'})
    try:
        with pytest.raises(ConfigError) as info:
            load_campaign(path)
        message = str(info.value)
        assert message.startswith(f"campaign.toml line {line_of(path, 'heap-20')}: unknown virtual test 'heap-20'")
        assert "plugins that may register it (heap_plugin_20) are imported only by" in message
        assert not (tmp_path / "imported").exists()
        campaign = load_campaign(path, import_plugins=True)
        assert campaign.test == "heap-20" and (tmp_path / "imported").read_text() == "yes"
        assert str(tmp_path) in sys.path  # where spawned workers find it too
    finally:
        sys.modules.pop("heap_plugin_20", None)


def test_report_captions_are_checked(campaign_file):
    """Issue 19: `[report] captions` name the published tables a report table reproduces."""
    from demcal.campaign.config import load_campaign

    good = load_campaign(campaign_file(replace={"[executor]": '[report.captions]\nfactors = "paper Table 3"\n\n[executor]'}))
    assert good.captions == {"factors": "paper Table 3"}
    assert load_campaign(campaign_file()).captions == {}
    with pytest.raises(ConfigError, match=r"unknown caption 'factor' in \[report\] captions; did you mean 'factors'\?"):
        load_campaign(campaign_file(replace={"[executor]": '[report.captions]\nfactor = "paper Table 3"\n\n[executor]'}))


@pytest.mark.parametrize("new, runs", [('type = "fractional"\ngenerators = ["D=ABC"]', 8),
                                       ('type = "fractional-factorial"\ngenerators = "D=-ABC"\ncenter = 2', 10),
                                       ('type = "ccd"\nfraction = 1\nvariant = "inscribed"', 22),
                                       ('type = "bbd"', 29)])
def test_design_kinds_and_options_of_the_catalogue(campaign_file, new, runs):
    """[design] takes every spelling and option of demcal.doe.catalog, as `demcal design` does."""
    from demcal.campaign.runner import plan_design

    campaign = load_campaign(campaign_file(replace={'type = "box-behnken"\ncenter = 5': new}))
    assert plan_design(campaign).coded.shape == (runs, 4)


def test_design_option_of_another_kind_is_one_sentence(campaign_file):
    path = campaign_file(replace={'type = "box-behnken"\ncenter = 5': 'type = "ccd"\ngenerators = "C=AB"'})
    with pytest.raises(ConfigError) as info:
        load_campaign(path)
    message = str(info.value)
    assert message.startswith("campaign.toml line ") and "\n" not in message, message
    assert "option 'generators' does not apply to a central-composite design" in message, message


def test_the_executor_names_its_backend(campaign_file):
    assert load_campaign(campaign_file()).executor.backend == "cpu"
    cuda = load_campaign(campaign_file(replace={"[executor]": '[executor]\nbackend = "cuda"'}))
    assert cuda.executor.backend == "cuda"
    path = campaign_file(replace={"[executor]": '[executor]\nbackend = "gpu"'})
    with pytest.raises(ConfigError, match=r"'backend' = 'gpu' is not known; did you mean 'cpu'"):
        load_campaign(path)


def test_a_cuda_campaign_without_a_gpu_is_one_sentence_before_any_run(campaign_file):
    from demcal.campaign.runner import run_campaign
    from demcal.campaign.store import Store
    from demcal.dem.backend import BACKENDS
    from demcal.dem.cuda.backend import device_present

    if device_present():  # the check the runner makes passes: nothing to refuse
        BACKENDS["cuda"].prepare()
        return
    campaign = load_campaign(campaign_file(replace={"[executor]": '[executor]\nbackend = "cuda"'}))
    with pytest.raises(ConfigError, match="backend 'cuda'"):
        run_campaign(campaign, progress=False)
    store = Store(campaign.store_path, readonly=True)
    try:
        assert {r.status for r in store.records(None)} == {"pending"}
    finally:
        store.close()


SHIPPED = {  # every campaign file under examples/, with the design runs its comment promises
    "residual-film-soil/repose.toml": 29,
    "residual-film-soil/cohesion.toml": 29,
    "residual-film-soil/no-cohesion.toml": 17,
    "joint-funnel-drum/campaign.toml": 11,
    "own-material/campaign.toml": 15,
}


@pytest.mark.parametrize("name, runs", sorted(SHIPPED.items()))
def test_every_shipped_campaign_loads_and_plans_its_design(name, runs):
    from demcal.campaign.runner import plan_design

    path = EXAMPLE.parent / name
    campaign = load_campaign(path)
    assert len(plan_design(campaign).specs) == runs
    assert f"{runs} " in path.read_text()


def test_no_campaign_file_ships_untested():
    files = {str(p.relative_to(EXAMPLE.parent)) for p in EXAMPLE.parent.rglob("*.toml")
             if p.name != "lab.toml" and "-runs" not in str(p)}
    assert files - {"residual-film-soil/sliding.toml"} == set(SHIPPED)
