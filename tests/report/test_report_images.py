"""The report's heap images and full parameter table (issue 19, items 5 and 6).

A small campaign (two factors, a central composite design) on a test double of the heap
test that, besides the double's angle, leaves what the repose benches leave in their run
folders: ``heap.png`` (the silhouette with the fitted flanks) and ``heap_spheres.npz``
(the final spheres), here of a cone of spheres. It runs in this process
(``InlineExecutor``); the verification runs of ``calibrate`` write those files too. One
condition has a lab photo of a heap (a synthetic one of known angle), the other a blank
picture that cannot be measured.
"""

from __future__ import annotations

import dataclasses
import html
import importlib.util
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

CAMPAIGN_TESTS = Path(__file__).resolve().parents[1] / "campaign"
if str(CAMPAIGN_TESTS) not in sys.path:  # the test double, campaign_testbench
    sys.path.insert(0, str(CAMPAIGN_TESTS))
_spec = importlib.util.spec_from_file_location("_campaign_fixtures_images", CAMPAIGN_TESTS / "conftest.py")
_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_fixtures)

CAMPAIGN = """\
[campaign]
name = "images"

[experiment]
test = "test-heap-images"
profile = "tiny"

[experiment.settings]
"test.sleep_s" = 0.0

""" + _fixtures.factor_tables("BC") + """\
[design]
type = "ccd"
center = 3

[runs]
seed = 7

[model]
order = "quadratic"

[[conditions]]
name = "dry"
photo = "lab.png"
targets = { repose_angle_deg = { mean = 40.0, sd = 2.0 } }

[[conditions]]
name = "wet"
photo = "blank.png"
targets = { repose_angle_deg = { mean = 43.0, sd = 2.0 } }

[verification]
replicates = 1

[report]
title = "Loam heaps"
"""


def _heap_files(folder: Path) -> Path:
    """heap.png and heap_spheres.npz of a 35-degree cone of spheres, written once."""
    from demcal.io.spheres import SPHERES_FILE, write_spheres
    from demcal.measure.heap import measure_heap
    from demcal.measure.synthetic import particle_cone

    folder.mkdir(parents=True, exist_ok=True)
    positions, radii = particle_cone(35.0, base_radius=0.05, radius=0.004, seed=1)
    measure_heap(positions, radii, views=2, plate_radius=0.1, png=folder / "heap.png")
    write_spheres(folder / SPHERES_FILE, positions, radii, plate_radius=0.1)
    return folder


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    import campaign_testbench
    from demcal.bench.registry import RunResult, register
    from demcal.campaign.calibrate import calibrate
    from demcal.campaign.config import parse_campaign
    from demcal.campaign.runner import run_campaign
    from demcal.measure.synthetic import synthetic_photo
    from demcal.report.campaign_report import write_report

    folder = tmp_path_factory.mktemp("images")
    heap = _heap_files(folder / "heap-files")

    class HeapWithImages(campaign_testbench.HeapDouble):
        name = "test-heap-images"

        def run(self, settings=None, seed=0, profile="quick", out_dir=None, vtk=False, progress=False):
            result = super().run(settings, seed, profile, None, vtk, progress)
            artifacts = {}
            if out_dir is not None:
                for key, file in (("heap_png", "heap.png"), ("heap_spheres", "heap_spheres.npz")):
                    artifacts[key] = str(shutil.copy(heap / file, Path(out_dir) / file))
            return RunResult(**{**result.__dict__, "artifacts": artifacts})

    register(HeapWithImages())
    Image.fromarray(synthetic_photo(34.0, seed=3).image).save(folder / "lab.png")
    Image.fromarray(np.full((300, 400, 3), 255, np.uint8)).save(folder / "blank.png")
    path = folder / "campaign.toml"
    path.write_text(CAMPAIGN)
    campaign = parse_campaign(CAMPAIGN, path)
    run_campaign(campaign, progress=False, executor=_fixtures.InlineExecutor())
    cal = calibrate(campaign, progress=False, executor=_fixtures.InlineExecutor())
    report = write_report(campaign, folder / "report", [cal], figure_files=False)
    return campaign, cal, report, report.read_text()


def _images_table(page: str) -> str:
    start = page.index(">Heap images: simulated and measured</h3>")
    return page[start:page.index("</table>", start)]


def test_each_condition_shows_the_3d_heap_the_silhouette_and_the_lab_photo(built):
    campaign, cal, _, page = built
    assert all(r.verified for r in cal.conditions)
    table = _images_table(page)
    rows = table.split("<tr>")[2:]  # after the heading row
    assert [re.match(r'<td class="t">(\w+)', row).group(1) for row in rows] == ["dry", "wet"]
    for row, name in zip(rows, ("dry", "wet")):
        assert f'alt="simulated heap of {name} in 3-D" src="data:image/png;base64,' in row
        assert f'alt="simulated {name}" ' in row  # the run's heap.png: silhouette and flanks
    assert 'alt="lab photo of dry as measured" src="data:image/png;base64,' in rows[0]
    # the blank picture is shown as it is, with the reason it does not measure
    assert 'alt="lab photo of wet"' in rows[1] and "not measured: no heap found in photo" in html.unescape(rows[1])
    for name in ("3-D", "silhouette and fitted flanks", "outline and fitted flanks"):
        assert name in table


def test_the_images_caption_describes_this_campaign_and_cites_nothing(built):
    campaign, cal, _, page = built
    caption = html.unescape(re.search(r"<caption>([^<]*)</caption>", _images_table(page)).group(1))
    assert caption.startswith("Loam heaps: the verification run of each condition at its calibrated parameters "
                              "(virtual test test-heap-images, profile tiny) beside its lab photo")
    assert "paper" not in caption and "Fig." not in caption
    chosen = cal.conditions[0].chosen["particle.static_friction"]
    assert f"particle.static_friction = {chosen:g}" in _images_table(page)


def test_the_parameter_table_lists_every_value_with_its_source(built):
    campaign, cal, report, page = built
    table = pd.read_csv(report.parent / "tables" / "material_parameters.csv", index_col=0)
    for result in cal.conditions:
        name = result.condition.name
        for key, factor in (("particle.static_friction", "B"), ("particle.rolling_friction", "C")):
            assert float(table.loc[key, name]) == pytest.approx(result.chosen[key])
            assert table.loc[key, f"{name} source"] == f"calibrated (factor {factor})"
        # a setting of the test left at its default, and material keys the double lacks
        assert float(table.loc["particle.restitution", name]) == 0.6
        assert table.loc["particle.restitution", f"{name} source"] == "default of test-heap-images (tiny)"
        assert table.loc["particle.density", f"{name} source"] == "demcal default (not a setting of the test)"
        g, nu = float(table.loc["particle.shear_modulus", name]), float(table.loc["particle.poisson_ratio", name])
        assert float(table.loc["particle.youngs_modulus", name]) == pytest.approx(2 * g * (1 + nu))
    for key in ("particle.damping_factor", "contact.model", "rolling.model", "wall.static_friction",
                "particle template", "size distribution"):
        assert key in table.index, key
    assert table.loc["contact.model", "dry"] == "hysteretic_spring"
    assert table.loc["particle template", "dry"].startswith("two-sphere: radii 4 + 5 mm")
    assert set(table["unit"].dropna()) >= {"kg/m3", "Pa", "-", "mm"}
    section = page[page.index(">Calibrated material: every parameter</h3>"):]
    section = section[:section.index("<h3", 5)]
    assert "particle.youngs_modulus" in section and "paper" not in section.lower()


def test_the_parameter_table_is_the_material_card(built):
    """One piece of code decides each value and source: the card `demcal export` writes."""
    from demcal.export.card import build_card

    campaign, cal, report, _ = built
    table = pd.read_csv(report.parent / "tables" / "material_parameters.csv", index_col=0)
    card = build_card(cal.campaign, cal.to_dict())
    for condition in card["conditions"]:
        for key, entry in condition["parameters"].items():
            shown = table.loc[key, condition["name"]]
            assert str(shown) == str(entry["value"]) or float(shown) == pytest.approx(float(entry["value"]))


def test_figures_have_axis_labels_with_units(tmp_path):
    from demcal.io.spheres import read_spheres
    from demcal.measure.photo import measure_photo
    from demcal.measure.synthetic import synthetic_photo
    from demcal.report.heaps import heap_3d_figure, photo_figure

    spheres = read_spheres(_heap_files(tmp_path) / "heap_spheres.npz")
    # a sphere that rolled far away is counted, not drawn: the axes frame the heap
    rolled = dataclasses.replace(spheres, positions=np.vstack([spheres.positions, [[0.5, 0.0, 0.004]]]),
                                 radii=np.append(spheres.radii, 0.004))
    fig = heap_3d_figure(rolled)
    ax = fig.axes[0]
    assert ax.get_title() == f"{len(spheres.radii)} spheres of the heap (1 off the heap, not shown)"
    assert ax.get_xlim()[1] < 100.0
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()) == ("x [mm]", "y [mm]", "z [mm]")
    assert fig.axes[1].get_ylabel().endswith("[mm]")  # the height colour bar
    # equal scaling: the box has the proportions of the axis ranges
    ranges = np.array([np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())])
    box = np.asarray(ax._box_aspect)
    np.testing.assert_allclose(box / box[0], ranges / ranges[0], rtol=1e-6)
    image = synthetic_photo(30.0, seed=2).image
    for scale, unit in ((0.5, "mm"), (None, "px")):
        m = measure_photo(image, mm_per_px=scale)
        ax = photo_figure(image / 255.0, m, mm_per_px=scale).axes[0]
        assert ax.get_xlabel().endswith(f"[{unit}]") and ax.get_ylabel().endswith(f"[{unit}]")
        assert "angle of repose 30." in ax.get_title() or "angle of repose 29." in ax.get_title()


def test_side_by_side_figures_are_written_at_300_dpi(tmp_path):
    from matplotlib.figure import Figure

    from demcal.report.html import HtmlReport

    report = HtmlReport("t", tmp_path)  # PNG and SVG for figure(), PNG only for pictures in a table
    fig = Figure(figsize=(2, 1))
    ax = fig.add_subplot()
    ax.set_xlabel("x [mm]")
    img = report.figure_html(fig, "cell", "a cell")
    assert img.startswith('<img alt="a cell" src="data:image/png;base64,')
    assert not report.blocks  # laid out by the caller
    with Image.open(tmp_path / "figures" / "cell.png") as png:
        assert png.size == (600, 300)
        assert png.info["dpi"][0] == pytest.approx(300, abs=0.5)
    assert [p.name for p in (tmp_path / "figures").iterdir()] == ["cell.png"]


def test_the_summary_gives_each_conditions_simulated_mean_n_and_verdict(built):
    """Issue 40: the first screen's verdict, for conditions whose verification ran."""
    from demcal.campaign.wording import half_width
    from demcal.rounding import measured

    campaign, cal, _, page = built
    start = page.index('<section id="summary">')
    summary = html.unescape(page[start:page.index("</section>", start)])
    for result in cal.conditions:
        row = summary[summary.index(f"<b>{result.condition.name}</b>"):]
        row = row[:row.index("</tr>")]
        (v,) = result.verdicts
        # each to the precision its noise supports, with its unit (demcal.rounding)
        simulated = measured(v.simulated_mean, half_width(result, v), "°")
        assert v.simulated and f"; simulated {simulated} (95 %)" in row and f"n = {len(v.simulated)}" in row
        assert f"lab {measured(v.target, v.lab_sd, '°')}" in row
        if result.loop is not None:
            assert result.loop.status in row
        else:
            assert ("inside the lab's mean ± sd" if v.within_lab_sd else "outside the lab's mean ± sd") in row
    assert "Verification: Repose angle [°]" in summary
    card = Path(os.path.relpath(campaign.workdir / "calibration.json", built[2].parent)).as_posix()
    assert f'<a href="{card}">calibration.json</a>' in summary  # calibrate wrote it
