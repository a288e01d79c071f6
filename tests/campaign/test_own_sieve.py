"""A campaign's particles from its lab sample's sieve table ([experiment] sieve), and the
card that carries the table."""

import json
import shutil
from pathlib import Path

import pytest

from demcal.campaign.config import load_campaign
from demcal.cli import main
from demcal.campaign.digest import resolved_config
from demcal.errors import ConfigError

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "own-material"


def _campaign(tmp_path, experiment_lines: str = "", settings_lines: str = "") -> Path:
    folder = tmp_path / "own"
    shutil.copytree(EXAMPLE, folder, ignore=shutil.ignore_patterns("*-runs"))
    path = folder / "campaign.toml"
    text = path.read_text()
    # the example may take its sieve already: start from a campaign without one
    text = "\n".join(line for line in text.splitlines()
                     if not line.startswith(("sieve =", '"particles.coarse_grain"', '"particles.size_m',
                                             '"particles.count_by"')))
    text = text.replace('plugins = []', f'plugins = []\n{experiment_lines}', 1)
    text = text.replace('[experiment.settings]', f'[experiment.settings]\n{settings_lines}', 1)
    path.write_text(text)
    return path


def test_the_samples_sieve_becomes_the_runs_sizes(tmp_path):
    path = _campaign(tmp_path, 'sieve = "dry"', '"particles.coarse_grain" = 3.5\n"particles.size_min_mm" = 1\n'
                                               '"particles.size_max_mm" = 5')
    campaign = load_campaign(path)
    assert campaign.settings["particles.sizes"] == "sieve"
    assert campaign.settings["particles.sieve_mm"] == "0.0, 0.5, 1.0, 2.0, 5.0, inf"
    assert campaign.settings["particles.sieve_percent"] == "18.0, 22.5, 31.0, 21.5, 7.0"
    assert resolved_config(campaign)["settings"]["particles.sieve_mm"] == "0.0, 0.5, 1.0, 2.0, 5.0, inf"


def test_options_left_off_stay_out_of_the_campaign_hash(tmp_path):
    settings = resolved_config(load_campaign(_campaign(tmp_path)))["settings"]
    assert not any(key in settings for key in ("particles.sizes", "particles.sieve_mm", "particles.coarse_grain",
                                               "particles.count_by", "particles.clump_mm"))
    assert "particles.scale_min" in settings  # settings that decide a run stay in


@pytest.mark.parametrize("experiment, settings, words", [
    ('sieve = "wet"', "", "sample 'wet' of the lab file has no [wet.sieve] table"),
    ('sieve = "moist"', "", "sample 'moist' is not in the lab file"),
    ('sieve = "dry"', '"particles.sieve_mm" = [0, 1, 2]', "both give the sizes"),
    ('sieve = "dry"', '"particles.coarse_grain" = 6', "lower particles.coarse_grain to 1.96 or less"),
])
def test_bad_sieve_campaigns_are_one_sentence_when_the_file_loads(tmp_path, experiment, settings, words):
    with pytest.raises(ConfigError) as err:
        load_campaign(_campaign(tmp_path, experiment, settings))
    assert words in str(err.value) and "\n" not in str(err.value)
    assert str(err.value).startswith("campaign.toml line ")


SIEVE_SETTINGS = ('sieve = "L"\n[experiment.settings]\n"particles.coarse_grain" = 2.0\n'
                  '"particles.size_min_mm" = 2\n"particles.size_max_mm" = 10\n')


def test_the_cards_carry_the_sieve_classes_and_what_was_left_out(example, capsys):
    """JSON, LIGGGHTS and EDEM cards of a funnel calibration on the paper's surface sample's
    sieve (IJABE 2020 Table 1: 24.52 % at 2-5 mm, 12.73 % above 5 mm, taken as 5-10 mm)."""
    from tests.campaign.test_export import REPOSE_CALIBRATION, _calibrate

    path = example / "repose.toml"
    path.write_text(path.read_text().replace('profile = "quick"\n', 'profile = "quick"\n' + SIEVE_SETTINGS, 1))
    _calibrate(example, "repose", REPOSE_CALIBRATION)
    assert main(["export", "repose.toml"]) == 0
    size = json.loads(capsys.readouterr().out)["particle"]["size_distribution"]
    assert size["kind"] == "sieve" and size["basis"] == "mass" and size["coarse_grain"] == 2.0
    assert size["lab_window_mm"] == [2.0, 10.0]
    assert size["left_out_percent"] == pytest.approx(100 - 24.52 - 12.73, abs=1e-3)
    fractions = [c["mass_fraction"] for c in size["classes"]]
    assert fractions == pytest.approx([24.52 / 37.25, 12.73 / 37.25], rel=1e-5)
    # a lab size D is the template at coarse_grain x D of volume-equivalent diameter
    d_v = size["reference_size"]
    assert size["classes"][0]["scale_min"] * d_v == pytest.approx(2.0 * 2e-3, rel=1e-5)
    assert size["classes"][-1]["scale_max"] * d_v == pytest.approx(2.0 * 10e-3, rel=1e-5)

    assert main(["export", "repose.toml", "--format", "liggghts", "-o", "card.liggghts"]) == 0
    text = Path("card.liggghts").read_text()
    assert "particledistribution/discrete/massbased" in text and "62.75 % of the lab mass" in text
    assert main(["export", "repose.toml", "--format", "edem", "-o", "card.csv"]) == 0
    text = Path("card.csv").read_text()
    assert "User Defined, by mass" in text and "65.8255" in text  # 24.52 / 37.25 of the mass
