"""Lab targets measured from the photos a lab file's glob matches: a blank or broken
photo stops the campaign with one sentence naming it, not a traceback or a silent
mean over the others."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from demcal.campaign.config import load_campaign
from demcal.errors import DataError
from demcal.measure.synthetic import synthetic_photo

LAB = """\
[L]
name = "L"
[L.repose]
photos = ["photos/*.png"]
{exclude}
"""


def lab_campaign(campaign_file, exclude=""):
    path = campaign_file(replace={
        'name = "test campaign"': 'name = "test campaign"\nlab = "lab.toml"',
        'targets = { repose_angle_deg = { mean = 36.0, sd = 2.1 } }': 'sample = "L"',
    })
    (path.parent / "lab.toml").write_text(LAB.format(exclude=exclude))
    photos = path.parent / "photos"
    photos.mkdir(exist_ok=True)
    for i, angle in enumerate([33.0, 35.0]):
        Image.fromarray(synthetic_photo(angle, seed=i).image).save(photos / f"heap{i}.png")
    Image.fromarray(np.full((600, 800, 3), 255, np.uint8)).save(photos / "white.png")
    return path


def test_a_blank_lab_photo_is_one_sentence(campaign_file, capsys):
    from demcal.cli import main

    path = lab_campaign(campaign_file)
    with pytest.raises(DataError, match=r"photo 'photos/white.png' of sample 'L' cannot be measured "
                                        r"\(.*the picture is uniform; check the exposure"):
        load_campaign(path)
    assert main(["run", str(path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("demcal: error: photo 'photos/white.png' of sample 'L' cannot be measured")
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (path.parent / "test-campaign-runs").exists()


def test_an_excluded_lab_photo_is_left_out(campaign_file):
    path = lab_campaign(campaign_file, exclude='exclude = ["photos/white.png"]')
    target = load_campaign(path).conditions[0].target("repose_angle_deg")
    assert target.mean == pytest.approx(34.0, abs=0.5) and target.sd > 0
