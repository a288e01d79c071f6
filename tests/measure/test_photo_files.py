"""Photo path plumbing: PNG writer and the batch table (CSV, JSON)."""

import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from demcal.measure.photo import measure_photos, write_png
from demcal.measure.synthetic import synthetic_photo


@pytest.mark.parametrize("shape", [(1, 1), (17, 5), (120, 161)])
def test_png_writer_round_trips_every_pixel(tmp_path, shape):
    rgb = np.random.default_rng(sum(shape)).integers(0, 256, shape + (3,), dtype=np.uint8)
    write_png(tmp_path / "x.png", rgb)
    with Image.open(tmp_path / "x.png") as im:
        assert im.format == "PNG" and im.mode == "RGB"
        assert np.array_equal(np.asarray(im), rgb)


def test_batch_csv_and_json_match_the_pandas_table(tmp_path):
    paths = []
    for i, angle in enumerate([28.0, 35.0]):
        paths.append(tmp_path / f"h{i},{i}.png")  # a comma: the CSV must quote it
        Image.fromarray(synthetic_photo(angle, seed=i).image).save(paths[-1])
    bad = tmp_path / "bad.png"
    bad.write_text("not a picture")
    batch = measure_photos([paths[0], bad, paths[1]], out_dir=tmp_path / "out")
    # the table holds the measured angles: the photos' known angles, in the order given
    table = batch.table
    assert table["photo"].tolist() == [str(paths[0]), str(bad), str(paths[1])]
    assert table.loc[[0, 2], "angle_deg"].tolist() == pytest.approx([28.0, 35.0], abs=0.5)
    assert table.loc[1, ["angle_deg", "left_deg", "right_deg"]].isna().all()
    for row, m in zip(table.loc[[0, 2]].itertuples(), batch.measurements):
        assert (row.angle_deg, row.left_deg, row.right_deg, row.r2) == (
            m.angle_deg, m.left_deg, m.right_deg, m.r2)
    batch.write_csv(tmp_path / "table.csv")
    read = pd.read_csv(tmp_path / "table.csv")
    assert read["photo"].tolist() == table["photo"].tolist()
    assert read.loc[[0, 2], "angle_deg"].tolist() == pytest.approx([28.0, 35.0], abs=0.5)
    expected = tmp_path / "pandas.csv"
    batch.table.to_csv(expected, index=False)
    assert (tmp_path / "table.csv").read_text() == expected.read_text()
    records = batch.table.replace({np.nan: None}).to_dict(orient="records")
    assert json.dumps(batch.to_dict()["photos"]) == json.dumps(records)
    assert pd.read_csv(tmp_path / "table.csv")["error"].notna().tolist() == [False, True, False]
    assert all((tmp_path / "out" / f"h{i},{i}_fit.png").stat().st_size > 10_000 for i in range(2))
