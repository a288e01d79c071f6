"""Numeric settings must be finite (and whole where the setting is an integer): NaN
compares false with every bound, so it must be refused by name, before anything runs --
on the command line (``--set``) and in a campaign's ``[experiment.settings]``."""

from pathlib import Path

import pytest

from demcal.bench.registry import RunResult, Setting, get_experiment, resolve_settings
from demcal.campaign.config import load_campaign
from demcal.cli import main
from demcal.errors import ConfigError

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "residual-film-soil"


class _Open:
    """A stand-in experiment with settings bounded on one side only, or not at all."""

    name = "open-bounds"
    description = "settings with open ranges"
    responses = ("x",)
    profiles = ("quick",)

    def settings(self, profile="quick"):
        return {"a.rate": Setting("a.rate", 2.0, "1/s", low=0.0),
                "a.free": Setting("a.free", 1.0),
                "a.steps": Setting("a.steps", 10, low=1)}

    def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
        return RunResult(self.name, {"x": 0.0})


@pytest.mark.parametrize("key, value, allowed", [
    ("particles.count", float("nan"), "whole number from 1 to 1000000"),
    ("particles.count", "nan", "whole number from 1 to 1000000"),
    ("particles.count", "NaN", "whole number from 1 to 1000000"),
    ("particles.count", float("inf"), "whole number from 1 to 1000000"),
    ("measure.views", "nan", "whole number from 1 to 64"),
    ("measure.views", "-inf", "whole number from 1 to 64"),
    ("particle.restitution", float("nan"), "number from 0.01 to 1,"),
    ("particle.restitution", "nan", "number from 0.01 to 1,"),
    ("particle.density", "inf", "number from 100 to 20000 kg/m"),
    ("geometry.scale", "inf", "number from 0.25 to 20,"),
])
def test_non_finite_values_are_refused_naming_key_and_range(key, value, allowed):
    with pytest.raises(ConfigError) as err:
        resolve_settings(get_experiment("repose-funnel"), {key: value}, "tiny")
    text = str(err.value)
    assert text.startswith(f"setting '{key}' must be a finite {allowed}"), text
    assert "\n" not in text


@pytest.mark.parametrize("key, value", [("a.rate", "inf"), ("a.free", float("nan")), ("a.free", "-inf"),
                                        ("a.steps", "inf")])
def test_non_finite_values_are_refused_without_bounds_too(key, value):
    with pytest.raises(ConfigError, match=f"setting '{key}' must be a finite"):
        resolve_settings(_Open(), {key: value}, "quick")


@pytest.mark.parametrize("key, value", [("particles.count", 150.5), ("particles.count", "2.5"),
                                        ("measure.views", "7.2")])
def test_integer_settings_must_be_whole_numbers(key, value):
    with pytest.raises(ConfigError) as err:
        resolve_settings(get_experiment("repose-funnel"), {key: value}, "tiny")
    assert f"setting '{key}' must be a whole number" in str(err.value)


@pytest.mark.parametrize("value", [300, 300.0, "300", "300.0", "3e2"])
def test_whole_numbers_of_an_integer_setting_become_int(value):
    s = resolve_settings(get_experiment("repose-funnel"), {"particles.count": value}, "tiny")
    assert s["particles.count"] == 300 and type(s["particles.count"]) is int


def test_booleans_are_not_numbers():
    with pytest.raises(ConfigError, match="must be a whole number from 1 to 1000000, got 'True'"):
        resolve_settings(get_experiment("repose-funnel"), {"particles.count": True}, "tiny")


@pytest.mark.parametrize("assignment", ["particles.count=nan", "measure.views=nan", "particle.restitution=inf",
                                        "particles.count=2.5"])
def test_set_nan_is_one_sentence_before_simulating(capsys, assignment):
    assert main(["bench", "repose-funnel", "--profile", "tiny", "--set", assignment]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"demcal: error: setting '{assignment.split('=')[0]}' must be a ")
    assert len(err.splitlines()) == 1 and "Traceback" not in err


@pytest.mark.parametrize("line", ['"particles.count" = nan', '"measure.views" = inf',
                                  '"particle.density" = -inf', '"particles.count" = 20.5'])
def test_campaign_settings_with_nan_are_refused_at_load(tmp_path, line):
    text = (EXAMPLE / "repose.toml").read_text()
    assert "[experiment]\n" in text
    if "[experiment.settings]\n" in text:
        text = text.replace("[experiment.settings]\n", f"[experiment.settings]\n{line}\n", 1)
    else:
        text = text.replace('profile = "quick"\n', f'profile = "quick"\n\n[experiment.settings]\n{line}\n', 1)
    for path in EXAMPLE.iterdir():
        if path.is_file() and path.name != "repose.toml":
            (tmp_path / path.name).write_bytes(path.read_bytes())
    (tmp_path / "repose.toml").write_text(text)
    key = line.split('"')[1]
    with pytest.raises(ConfigError) as err:
        load_campaign(tmp_path / "repose.toml")
    message = str(err.value)
    assert f"setting '{key}' must be a " in message and "\n" not in message, message
