"""Angle of repose tests: reproducibility and physics sanity (issue 4, acceptance 2 and 3).

The repose angle must rise with the inter-particle static friction and with the rolling
friction: the grid averages three seeds at the tiny profile (rolling friction's grid in
``make test-slow``), and the corners of the grid are compared with one seed. The seed-to-seed spread of the quick profile (six runs of
about 20 s) is a ``slow`` bench run.
"""

import numpy as np
import pytest

from demcal.bench.registry import get_experiment

FUNNEL = get_experiment("repose-funnel")


def angle(seed=0, profile="tiny", **overrides):
    settings = {k.replace("__", "."): v for k, v in overrides.items()}
    return FUNNEL.run(settings, seed=seed, profile=profile).responses["repose_angle_deg"]


def test_same_seed_gives_the_same_angle_to_the_last_digit(tmp_path):
    a = FUNNEL.run({}, seed=3, profile="tiny", out_dir=tmp_path / "a")
    b = FUNNEL.run({}, seed=3, profile="tiny", out_dir=tmp_path / "b")
    assert a.responses == b.responses
    assert a.steps == b.steps
    assert (tmp_path / "a" / "heap.png").stat().st_size > 10_000
    assert 0.0 < a.responses["repose_angle_deg"] < 60.0
    assert set(a.spread) == {"repose_angle_deg"}


def test_corners_of_the_friction_grid():
    low = angle(particle__static_friction=0.1, particle__rolling_friction=0.02)
    high = angle(particle__static_friction=0.6, particle__rolling_friction=0.4)
    assert high > low + 3.0


@pytest.mark.parametrize("key, low, high", [
    ("particle.static_friction", 0.15, 0.6),
    # twelve funnel runs a case (21 s on the 2-core VM): make test-slow; the fast suite
    # raises rolling friction with static friction in the corners above
    pytest.param("particle.rolling_friction", 0.02, 0.4, marks=pytest.mark.slow),
])
def test_repose_angle_rises_with_friction(key, low, high):
    seeds = (1, 2, 3)
    a_low = np.mean([FUNNEL.run({key: low}, seed=s, profile="tiny").responses["repose_angle_deg"] for s in seeds])
    a_high = np.mean([FUNNEL.run({key: high}, seed=s, profile="tiny").responses["repose_angle_deg"] for s in seeds])
    assert a_high > a_low + 2.0


def test_lifted_cylinder_builds_a_heap(tmp_path):
    # Measured at the tiny profile: 32.8 deg at seed 0 (24.5 and 28.8 at seeds 1 and 2),
    # heap 147-155 mm across. A column never lifted stays a 120 mm cylinder of grains
    # and measures 9.8 deg; both checks below fail for it.
    cylinder = get_experiment("repose-cylinder")
    r = cylinder.run({}, seed=0, profile="tiny", out_dir=tmp_path)
    assert 22.0 < r.responses["repose_angle_deg"] < 42.0
    settings = cylinder.settings("tiny")
    bore_mm = 1e3 * settings["geometry.cylinder_diameter"].default * settings["geometry.scale"].default
    assert r.responses["heap_diameter_mm"] > 1.1 * bore_mm  # the grains spread out of the bore
    assert (tmp_path / "heap.png").exists()
    # the final spheres it keeps measure as the run did (single precision: 0.1 um at 1 m)
    from demcal.io.spheres import read_spheres
    from demcal.measure.heap import measure_heap

    assert r.artifacts["heap_spheres"] == str(tmp_path / "heap_spheres.npz")
    spheres = read_spheres(r.artifacts["heap_spheres"])
    r_plate = 0.5 * settings["geometry.scale"].default * settings["geometry.plate_diameter"].default
    assert spheres.base_z == 0.0 and spheres.plate_radius == pytest.approx(r_plate)
    again = measure_heap(spheres.positions, spheres.radii, base_z=spheres.base_z, axis_xy=(0.0, 0.0),
                         plate_radius=spheres.plate_radius)
    assert again.angle_deg == pytest.approx(r.responses["repose_angle_deg"], abs=1e-3)
    assert again.height * 1e3 == pytest.approx(r.responses["heap_height_mm"], abs=1e-3)


def test_spheres_file_round_trips_and_a_broken_one_is_one_sentence(tmp_path):
    from demcal.errors import DataError
    from demcal.io.spheres import read_spheres, write_spheres

    rng = np.random.default_rng(0)
    positions, radii = rng.uniform(-0.5, 0.5, (300, 3)), rng.uniform(0.001, 0.006, 300)
    path = write_spheres(tmp_path / "s.npz", positions, radii, base_z=0.01)
    back = read_spheres(path)
    np.testing.assert_array_equal(back.positions, positions.astype(np.float32))
    np.testing.assert_array_equal(back.radii, radii.astype(np.float32))
    np.testing.assert_allclose(back.positions, positions, rtol=0, atol=1e-7)
    assert (back.base_z, back.plate_radius) == (0.01, None)
    assert path.stat().st_size < 300 * 16 + 1000 and not list(tmp_path.glob(".*.tmp"))
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(DataError, match=r"^'.*bad.npz' is not a spheres file of demcal"):
        read_spheres(tmp_path / "bad.npz")


@pytest.mark.slow
def test_quick_profile_seed_to_seed_spread():
    # measured 22 Nov 2026: mean 35.30, sd 2.45 deg over seeds 1-6; after the third
    # session's engine changes mean 35.62, sd 1.23; with the exact rotation of the
    # two-sphere clumps (fourth session) mean 35.09, sd 2.34; with the touching pairs
    # last in each neighbour row (fifth session) mean 34.78, sd 1.96; today's figure in
    # docs/validation.md, "Seed-to-seed spread";
    # the aim is 1.5 deg, this guards against a regression well beyond that
    angles = [angle(seed=s, profile="quick") for s in range(1, 7)]
    print(f"quick repose angle over seeds 1-6: mean {np.mean(angles):.2f}, "
          f"sd {np.std(angles, ddof=1):.2f} deg")
    assert np.std(angles, ddof=1) < 3.5
    assert 25.0 < np.mean(angles) < 45.0


def test_a_grain_held_on_the_funnel_wall_is_left_out_not_a_jam(monkeypatch):
    # A grain or two that stay on the funnel's cone when the rest has run out used to stop
    # the run ("the funnel jammed with 1 particles in it"; Table 4 run 16 at the quick
    # profile, seed 4, with the engine of f279479); as in the lab, a grain held on the
    # wall stays in the funnel and the heap is measured without it. Which seed holds a
    # grain follows the last bits of the engine (with portable bits, none of seeds 1-7 at
    # that point does), so the wall's hold is made certain here: the last two particles
    # in the funnel count as static (``_jammed``), the run's own path does the rest.
    import demcal.bench.repose as repose

    def last_two_static(sim, h_out, b_max):
        return int(np.sum(sim.state.positions[:, 2] > h_out - 0.5 * b_max)) <= 2

    monkeypatch.setattr(repose, "_jammed", last_two_static)
    out = FUNNEL.run({}, seed=1, profile="tiny")
    r = out.responses
    count = FUNNEL.settings("tiny")["particles.count"].default
    assert r["particles_held"] in (1.0, 2.0) and out.particles == count
    assert 5.0 < r["repose_angle_deg"] < 50.0
    # an arch (more than 0.5 % of the particles, at least 3) is still a jam
    from demcal.bench.repose import _held_limit
    assert _held_limit(1500) == 7 and _held_limit(100) == 3
