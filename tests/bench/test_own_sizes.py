"""A user's own size distribution (a lab sieve table, coarse-grained) and particle shape.

The sieve table is examples/own-material/lab.toml's [dry.sieve]: bounds 0, 0.5, 1, 2, 5,
inf mm, mass 18, 22.5, 31, 21.5, 7 %.
"""

import math

import numpy as np
import pytest

from demcal.bench import common as C
from demcal.bench.registry import get_experiment, resolve_settings
from demcal.cli import main
from demcal.particles.sizes import scaled_sieve
from demcal.particles.templates import two_sphere_paper

EDGES = [0, 0.5, 1, 2, 5, math.inf]
MASS = [18, 22.5, 31, 21.5, 7]
SIEVE = {"particles.sizes": "sieve", "particles.sieve_mm": EDGES, "particles.sieve_percent": MASS}


def test_default_window_drops_the_class_from_zero_and_closes_the_open_top_at_twice_its_bound():
    scaled = scaled_sieve(EDGES, MASS, 0.01)
    assert scaled.window_mm == (0.5, 10.0)
    assert scaled.left_out_percent == pytest.approx(18.0, rel=1e-12)
    table = scaled.distribution
    assert np.allclose(table.apertures, [0.5e-3, 1e-3, 2e-3, 5e-3, 10e-3], rtol=1e-12)
    assert np.allclose(table.mass_fractions, np.array([22.5, 31, 21.5, 7]) / 82.0, rtol=1e-12)


def test_a_window_that_cuts_a_class_keeps_the_part_of_its_mass_inside():
    # 1.5-5 mm keeps half of the 1-2 mm class (sizes uniform within a class) and all of 2-5
    scaled = scaled_sieve(EDGES, MASS, 0.01, size_min_mm=1.5, size_max_mm=5)
    kept = np.array([15.5, 21.5])
    assert np.allclose(scaled.distribution.mass_fractions, kept / kept.sum(), rtol=1e-12)
    assert scaled.left_out_percent == pytest.approx(100 - kept.sum(), rel=1e-12)


def test_coarse_graining_multiplies_every_size_and_the_sampled_mass_follows_the_table():
    one = scaled_sieve(EDGES, MASS, 0.01, coarse_grain=1.0, size_min_mm=1, size_max_mm=10)
    four = scaled_sieve(EDGES, MASS, 0.01, coarse_grain=4.0, size_min_mm=1, size_max_mm=10)
    a, b = one.distribution.sample(2000, seed=3), four.distribution.sample(2000, seed=3)
    assert np.allclose(b, 4.0 * a, rtol=1e-12)
    # mass per class of a large sample against the table (sampling error well below 1 %)
    s = four.distribution.sample(400_000, seed=1)
    bounds = np.asarray(four.distribution.apertures) / four.distribution.reference_size
    mass = np.histogram(s, bins=bounds, weights=s ** 3)[0]
    assert np.allclose(mass / mass.sum(), four.distribution.mass_fractions, atol=0.01)
    # the exact mean volume factor against the sample's
    assert four.distribution.mean_cube() == pytest.approx(np.mean(s ** 3), rel=0.02)


def test_the_template_is_scaled_by_its_volume_equivalent_diameter():
    s = resolve_settings(get_experiment("repose-cylinder"), {**SIEVE, "particles.coarse_grain": 3.0}, "tiny")
    tpl = C.template_for(s)
    sizes = C.sizes_for(s, tpl)
    d_v = 2.0 * tpl.equivalent_radius
    assert sizes.min_scale * d_v == pytest.approx(3.0 * 0.5e-3, rel=1e-12)
    assert sizes.max_scale * d_v == pytest.approx(3.0 * 10e-3, rel=1e-12)


def test_count_by_volume_fills_the_solid_volume_of_the_profiles_paper_units():
    s = resolve_settings(get_experiment("repose-cylinder"),
                         {**SIEVE, "particles.coarse_grain": 3.5, "particles.size_min_mm": 1,
                          "particles.size_max_mm": 5, "particles.count_by": "volume"}, "tiny")
    tpl = C.template_for(s)
    sizes = C.sizes_for(s, tpl)
    n = C.count_of(s, tpl, sizes)
    paper = two_sphere_paper().volume * (1.5 ** 4 - 0.5 ** 4) / 4.0  # E[s^3] of U(0.5, 1.5)
    assert n == round(250 * paper / (tpl.volume * sizes.mean_cube()))
    assert n * tpl.volume * sizes.mean_cube() == pytest.approx(250 * paper, rel=1e-3)
    assert C.count_of({**s, "particles.count_by": "number"}) == 250


def test_listed_settings_take_lists_or_text_and_keep_canonical_text():
    exp = get_experiment("repose-funnel")
    from_list = resolve_settings(exp, SIEVE, "tiny")
    from_text = resolve_settings(exp, {"particles.sizes": "sieve", "particles.sieve_mm": "0, 0.5 1,2,5, inf",
                                       "particles.sieve_percent": "18,22.5,31,21.5,7"}, "tiny")
    assert from_list["particles.sieve_mm"] == from_text["particles.sieve_mm"] == "0.0, 0.5, 1.0, 2.0, 5.0, inf"
    assert resolve_settings(exp, from_list, "tiny") == from_list


def test_a_clump_of_the_users_spheres():
    s = resolve_settings(get_experiment("repose-cylinder"),
                         {"particles.shape": "clump", "particles.clump_mm": [[0, 0, 0, 3], [4, 0, 0, 3], [2, 3, 0, 2]]},
                         "tiny")
    tpl = C.template_for(s)
    assert tpl.n_spheres == 3 and np.allclose(sorted(tpl.radii), [0.002, 0.003, 0.003], rtol=1e-12)


def _cli(argv, capsys) -> tuple[int, str]:
    status = main(argv)
    err = capsys.readouterr().err.strip()
    return status, err


BAD = [
    (["particles.sieve_percent=18,22.5,31,21.5,8"], "sum to 101.00 %"),
    (["particles.sieve_mm=0,-0.5,1,2,5,inf"], "must be >= 0 and increasing"),
    (["particles.sieve_mm=0,1,0.5,2,5,inf"], "must be >= 0 and increasing"),
    (["particles.coarse_grain=10"], "lower particles.coarse_grain to 2.18 or less"),
    (["particles.size_min_mm=5", "particles.size_max_mm=2"], "window of simulated sizes 5 to 2 mm is empty"),
    (["particles.shape=clump", "particles.clump_mm=1,2,3"], "four numbers a sphere"),
]


@pytest.mark.parametrize("sets, words", BAD)
def test_bad_sieve_input_is_one_sentence_and_exit_status_2(sets, words, capsys):
    base = {"particles.sizes": "sieve", "particles.sieve_mm": "0,0.5,1,2,5,inf",
            "particles.sieve_percent": "18,22.5,31,21.5,7"}
    base.update(item.split("=", 1) for item in sets)
    argv = ["bench", "repose-funnel", "--profile", "tiny"]
    for key, value in base.items():
        argv += ["--set", f"{key}={value}"]
    status, err = _cli(argv, capsys)
    assert status == 2 and words in err, err
    assert "\n" not in err and "Traceback" not in err


def test_sieve_sizes_without_a_table_is_one_sentence(capsys):
    status, err = _cli(["bench", "repose-funnel", "--profile", "tiny", "--set", "particles.sizes=sieve"], capsys)
    assert status == 2 and "needs particles.sieve_mm and particles.sieve_percent" in err


def test_a_tiny_cylinder_heap_of_sieve_sizes(tmp_path):
    """The insertion draws the sieve's sizes: every sphere of the final heap lies within
    the coarse-grained window, both ends of it are reached, and the heap is measured."""
    overrides = {**SIEVE, "particles.coarse_grain": 3.5, "particles.size_min_mm": 1, "particles.size_max_mm": 5}
    result = get_experiment("repose-cylinder").run(overrides, seed=1, profile="tiny", out_dir=tmp_path)
    s = resolve_settings(get_experiment("repose-cylinder"), overrides, "tiny")
    tpl = C.template_for(s)
    sizes = C.sizes_for(s, tpl)
    spheres = np.load(result.artifacts["heap_spheres"])
    radii = np.sort(spheres["radii"])
    r_small, r_large = np.min(tpl.radii), np.max(tpl.radii)
    assert radii[0] >= r_small * sizes.min_scale * (1 - 1e-9)
    assert radii[-1] <= r_large * sizes.max_scale * (1 + 1e-9)
    assert radii[-1] > r_large * 2.5 * sizes.min_scale  # some from the 2-5 mm class
    assert result.particles == 250 and 0.0 < result.responses["repose_angle_deg"] < 60.0
