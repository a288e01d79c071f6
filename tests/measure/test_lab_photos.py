"""Lab records measured from heap photos: a photo that cannot be measured is named,
never silently left out of the target."""

import numpy as np
import pytest
from PIL import Image

from demcal.errors import ConfigError, DataError
from demcal.measure.lab import LabRecord, resolve_targets
from demcal.measure.synthetic import synthetic_photo


@pytest.fixture
def photos(tmp_path):
    folder = tmp_path / "photos"
    folder.mkdir()
    for i, angle in enumerate([30.0, 32.0]):
        Image.fromarray(synthetic_photo(angle, seed=i).image).save(folder / f"h{i}.png")
    return folder


def record(**repose):
    return LabRecord.from_dict({"name": "L", "repose": {"photos": ["photos/*.png"], **repose}},
                               where="lab.toml [L]")


def test_good_photos_give_the_target(tmp_path, photos):
    angle = resolve_targets(record(), tmp_path)["repose_angle_deg"]
    assert (angle.n, angle.source) == (2, "photos")
    assert angle.mean_deg == pytest.approx(31.0, abs=0.5)


@pytest.mark.parametrize("bad", ["empty", "unreadable", "blank"])
def test_a_bad_photo_in_the_glob_is_named_not_dropped(tmp_path, photos, bad):
    path = photos / "h9.png"
    if bad == "empty":
        path.write_bytes(b"")
    elif bad == "unreadable":
        path.write_bytes(b"\x89PNG broken")
    else:
        Image.fromarray(np.full((600, 800, 3), 255, np.uint8)).save(path)
    with pytest.raises(DataError) as info:
        resolve_targets(record(), tmp_path)
    sentence = str(info.value)
    assert "photo 'photos/h9.png' of sample 'L' cannot be measured" in sentence
    assert 'exclude = ["photos/h9.png"]' in sentence
    assert sentence.count("\n") == 0 and sentence.endswith(".")
    # left out on purpose, it is left out
    angle = resolve_targets(record(exclude=["photos/h9.png"]), tmp_path)["repose_angle_deg"]
    assert angle.n == 2 and angle.mean_deg == pytest.approx(31.0, abs=0.5)


def test_two_bad_photos_are_counted(tmp_path, photos):
    (photos / "a.png").write_bytes(b"")
    (photos / "b.png").write_bytes(b"")
    with pytest.raises(DataError, match=r"2 of the 4 photos of sample 'L' cannot be measured.*"
                                        r'exclude = \["photos/a.png", "photos/b.png"\]'):
        resolve_targets(record(), tmp_path)


def test_exclusions_are_checked(tmp_path, photos):
    with pytest.raises(DataError, match="'photos/typo.png' of sample 'L' matches no photo"):
        resolve_targets(record(exclude=["photos/typo.png"]), tmp_path)
    with pytest.raises(DataError, match="every photo of sample 'L' is excluded"):
        resolve_targets(record(exclude="photos/*.png"), tmp_path)
    with pytest.raises(ConfigError, match="'exclude' must be a file pattern or a list"):
        record(exclude=[3])
