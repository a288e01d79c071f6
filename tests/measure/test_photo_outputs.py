"""What a batch writes: annotated pictures that never replace a photo, one picture per
photo, blank photos as error rows, and a table that is never left half written."""

import hashlib
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from demcal.cli import main
from demcal.errors import DataError
from demcal.measure.photo import measure_photo, measure_photos
from demcal.measure.synthetic import synthetic_photo


def heap(path, angle=30.0, seed=0):
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(synthetic_photo(angle, seed=seed).image).save(path)
    return path


def digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_annotated_picture_in_the_photos_folder_keeps_the_photo(tmp_path):
    photo = heap(tmp_path / "lossy" / "h.png")
    before = digest(photo)
    assert main(["measure", "repose", str(photo), "--out", str(photo.parent)]) == 0
    assert digest(photo) == before  # the photo is still the photo
    table = pd.read_csv(photo.parent / "table.csv")
    png = table.loc[0, "png"]
    assert png != str(photo) and os.path.isfile(png)
    assert os.path.basename(png) == "h_fit.png"
    assert digest(photo.parent / "h_fit.png") != before
    assert measure_photo(photo).angle_deg == pytest.approx(30.0, abs=0.5)


def test_photos_of_the_same_name_in_two_folders_get_two_pictures(tmp_path):
    a = heap(tmp_path / "a" / "IMG.png", 28.0, seed=1)
    b = heap(tmp_path / "b" / "IMG.png", 40.0, seed=2)
    batch = measure_photos([a, b], out_dir=tmp_path / "o2")
    pngs = batch.table["png"].tolist()
    assert len(set(pngs)) == 2 and all(os.path.isfile(p) for p in pngs)
    assert digest(tmp_path / "o2" / os.path.basename(pngs[0])) != digest(
        tmp_path / "o2" / os.path.basename(pngs[1]))
    assert [os.path.basename(p) for p in pngs] == ["a_IMG_fit.png", "b_IMG_fit.png"]
    # each row's picture shows its own photo's angle
    for row, m in zip(batch.rows, batch.measurements):
        assert row["png"] == m.png


def test_a_name_taken_by_an_input_photo_is_not_reused(tmp_path):
    # h_fit.png is a photo of the batch and lies in the output folder: h.png's
    # picture must get another name, and neither photo is touched
    out = tmp_path / "out"
    h = heap(tmp_path / "h.png", 30.0, seed=3)
    taken = heap(out / "h_fit.png", 35.0, seed=4)
    before = digest(h), digest(taken)
    batch = measure_photos([h, taken], out_dir=out)
    assert (digest(h), digest(taken)) == before
    pngs = batch.table["png"].tolist()
    assert len(set(pngs)) == 2 and str(taken) not in pngs and str(h) not in pngs
    assert all(os.path.isfile(p) for p in pngs)


def test_an_output_that_is_an_input_under_another_name_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    h = heap(tmp_path / "h.png")
    os.link(h, out / "h_fit.png")  # the same file under the picture's name
    before = digest(h)
    with pytest.raises(DataError, match=r"would overwrite the photo .*h\.png.*another"):
        measure_photos([h], out_dir=out)
    with pytest.raises(DataError, match="would overwrite the photo"):
        measure_photo(h, png=out / "h_fit.png")
    with pytest.raises(DataError, match="would overwrite the photo"):
        measure_photo(h, png=h)
    assert digest(h) == before


BLANK = {
    "white": np.full((600, 800, 3), 255, np.uint8),
    "brown": np.full((600, 800, 3), (120, 80, 40), np.uint8),
    "black-grey": np.zeros((600, 800), np.uint8),
    "noisy-grey": np.clip(np.random.default_rng(0).normal(128, 3, (600, 800, 3)), 0, 255).astype(np.uint8),
    "float-white": np.ones((600, 800, 3)),
}


@pytest.mark.parametrize("case", sorted(BLANK))
def test_a_blank_photo_is_one_sentence(case):
    with pytest.raises(DataError, match="the picture is uniform; check the exposure and the region"):
        measure_photo(BLANK[case], name=case)


def test_a_blank_photo_is_an_error_row_and_the_others_are_measured(tmp_path, capsys):
    good = heap(tmp_path / "heap0.png", 32.0, seed=5)
    white = tmp_path / "white.png"
    Image.fromarray(BLANK["white"]).save(white)
    brown = tmp_path / "brown.png"
    Image.fromarray(BLANK["brown"]).save(brown)
    assert main(["measure", "repose", str(good), str(white), str(brown)]) == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    assert f"{white}: not measured: no heap found in photo '{white}': the picture is uniform" in captured.out
    assert f"{brown}: not measured:" in captured.out
    assert f"{good}: 32." in captured.out or f"{good}: 31." in captured.out
    assert captured.err.count("demcal: warning:") == 2


def test_an_interrupted_table_write_keeps_the_old_table(tmp_path, monkeypatch):
    batch = measure_photos([heap(tmp_path / "h.png")])
    table = tmp_path / "table.csv"
    table.write_text("the previous table\n")

    def interrupted(src, dst):  # Ctrl-C after the new table is written, before it is renamed
        assert Path(src).read_text().startswith("photo,")
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        batch.write_csv(table)
    assert table.read_text() == "the previous table\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.png", "table.csv"]  # no leftovers
    monkeypatch.undo()
    batch.write_csv(table)
    assert pd.read_csv(table)["angle_deg"].item() == pytest.approx(30.0, abs=0.5)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.png", "table.csv"]
