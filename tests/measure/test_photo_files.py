"""Photo path plumbing: PNG writer, batch table without pandas, Theil-Sen without scipy.stats."""

import json

import numpy as np
import pandas as pd
import pytest
from PIL import Image
from scipy import stats

from demcal.measure.flank import theil_sen
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
    batch.write_csv(tmp_path / "table.csv")
    expected = tmp_path / "pandas.csv"
    batch.table.to_csv(expected, index=False)
    assert (tmp_path / "table.csv").read_text() == expected.read_text()
    records = batch.table.replace({np.nan: None}).to_dict(orient="records")
    assert json.dumps(batch.to_dict()["photos"]) == json.dumps(records)
    assert pd.read_csv(tmp_path / "table.csv")["error"].notna().tolist() == [False, True, False]
    assert all((tmp_path / "out" / f"h{i},{i}.png").stat().st_size > 10_000 for i in range(2))


@pytest.mark.parametrize("n", [5, 60, 401])
def test_theil_sen_equals_scipy(n):
    rng = np.random.default_rng(n)
    x = np.round(rng.uniform(0, 40, n))  # ties in x, as pixel columns have
    z = 0.6 * x + rng.standard_normal(n)
    z[:3] += 25  # outliers
    slope, intercept = stats.theilslopes(z, x)[:2]
    assert theil_sen(x, z) == (slope, intercept)
