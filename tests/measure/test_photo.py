"""Lab photo path: synthetic photos of known angle (issue 6, acceptance 1-3)."""

import numpy as np
import pytest
from skimage import io

from demcal.errors import DataError
from demcal.measure.heap import measure_heap
from demcal.measure.photo import measure_photo, measure_photos
from demcal.measure.render import render_heap
from demcal.measure.synthetic import particle_cone, synthetic_photo

DISTURBANCES = {
    "noise": dict(noise=0.08),
    "blur": dict(blur=3.0),
    "uneven-light": dict(gradient=0.45),
    "shadow": dict(shadow=True),
    "tilt": dict(tilt_deg=2.0),
    "back-lit": dict(lighting="back"),
    "bright-heap": dict(lighting="bright"),
    "plain-background": dict(texture=False),
}


@pytest.mark.parametrize("angle", [20.0, 30.0, 40.0, 50.0])
@pytest.mark.parametrize("case", sorted(DISTURBANCES))
def test_synthetic_photo_within_half_a_degree(case, angle):
    photo = synthetic_photo(angle, seed=int(angle * 10), **DISTURBANCES[case])
    m = measure_photo(photo.image)
    assert m.angle_deg == pytest.approx(angle, abs=0.5)
    assert m.r2 > 0.98


def test_tilt_cancels_in_the_mean_but_not_per_flank():
    m = measure_photo(synthetic_photo(30.0, seed=1, tilt_deg=2.0).image)
    assert m.angle_deg == pytest.approx(30.0, abs=0.5)
    # rotated counter-clockwise: the left flank reads steeper by the tilt
    assert (m.left_deg - m.right_deg) / 2 == pytest.approx(2.0, abs=0.5)


def test_file_roi_base_line_scale_and_png(tmp_path):
    photo = synthetic_photo(33.0, seed=2)
    # the light box does not fill the picture: a dark frame (the lab around it) on top
    # and both sides, standing on the base line, all of it outside the region of interest
    image = photo.image.copy()
    image[:96] = image[:int(photo.base_row) + 1, :56] = image[:int(photo.base_row) + 1, 764:] = 35
    with pytest.raises(DataError):  # without the region the frame spoils the measurement
        measure_photo(image, base_y=photo.base_row)
    path = tmp_path / "heap.png"
    io.imsave(path, image)
    png = tmp_path / "out" / "heap_fit.png"
    x0 = 60
    m = measure_photo(path, roi=(x0, 100, 760, 560), base_y=photo.base_row, mm_per_px=0.5, png=png)
    assert m.angle_deg == pytest.approx(33.0, abs=0.5)
    assert m.base_row == photo.base_row
    # x is measured from the region's left edge: the flanks meet the base line where the
    # drawn heap's feet are, half_width = 250 px either side of the apex column
    for flank, foot_col in ((m.fit.left, photo.apex_col - 250), (m.fit.right, photo.apex_col + 250)):
        assert -flank.intercept / flank.slope == pytest.approx((foot_col - x0) * 0.5, abs=2.0)
        assert flank.x.min() >= 0 and flank.x.max() <= (760 - x0) * 0.5
    assert m.unit == "mm"
    assert m.height == pytest.approx(0.5 * 250 * np.tan(np.radians(33.0)), rel=0.08)
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize("angle", [22.0, 36.0, 48.0])
def test_rendered_heap_photo_path_matches_outline_path_within_1_degree(angle):
    positions, radii = particle_cone(angle, base_radius=0.06, radius=0.002, seed=int(angle))
    picture = render_heap(positions, radii, view_deg=0.0)
    by_photo = measure_photo(picture.image, mm_per_px=picture.mm_per_px)
    by_outline = measure_heap(positions, radii, views=1)
    assert by_photo.angle_deg == pytest.approx(by_outline.angle_deg, abs=1.0)


def test_unreadable_and_missing_files_get_one_sentence(tmp_path):
    bad = tmp_path / "bad.jpg"
    bad.write_text("not an image")
    with pytest.raises(DataError, match="cannot read photo .*bad.jpg"):
        measure_photo(bad)
    with pytest.raises(DataError, match="does not exist"):
        measure_photo(tmp_path / "missing.png")


def test_photo_without_heap_is_refused():
    empty = synthetic_photo(30.0, seed=3).image.copy()
    wall = synthetic_photo(30.0, seed=3, fines=False)
    empty[:] = wall.image[:40].mean(axis=(0, 1)).astype(np.uint8)
    empty = np.clip(empty + np.random.default_rng(0).normal(0, 6, empty.shape), 0, 255).astype(np.uint8)
    with pytest.raises(DataError, match="no heap found"):
        measure_photo(empty)


def test_heap_touching_the_border_is_refused():
    photo = synthetic_photo(40.0, seed=4, half_width=250)
    cropped = photo.image[:, 250:]  # cut through the left flank
    with pytest.raises(DataError, match="touches the left border"):
        measure_photo(cropped)
    with pytest.raises(DataError, match="touches the top border"):
        measure_photo(photo.image[int(photo.base_row - photo.height_px) + 20:, :])


def test_batch_keeps_going_and_flags_an_outlier(tmp_path):
    paths = []
    for i, angle in enumerate([31.0, 31.5, 30.5, 31.2, 30.8, 44.0]):
        p = tmp_path / f"p{i}.png"
        io.imsave(p, synthetic_photo(angle, seed=i).image)
        paths.append(p)
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"\x89PNG broken")
    batch = measure_photos(paths[:3] + [bad] + paths[3:])
    assert len(batch.measurements) == 6
    assert [p for p, _ in batch.failures] == [str(bad)]
    assert batch.table.loc[batch.table["photo"] == str(paths[-1]), "outlier"].item()
    assert batch.table["outlier"].sum() == 1
    assert batch.summary.n == 6
    d = batch.to_dict()
    assert d["summary"]["failed"] == [str(bad)] and d["summary"]["outliers"] == [str(paths[-1])]
