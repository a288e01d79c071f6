"""Insertion refuses bad input in one sentence instead of placing overlapping particles."""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from demcal.errors import ConfigError
from demcal.particles.insertion import BoxRegion, Inserter, insert

REGION = BoxRegion((0, 0, 0), (0.05, 0.05, 0.05))


def _one_sentence(exc):
    msg = str(exc.value)
    assert "\n" not in msg and "Traceback" not in msg
    assert msg.endswith(".")
    return msg


def _overlaps(pos, rad):
    pairs = cKDTree(pos).query_pairs(2 * rad.max(), output_type="ndarray")
    if len(pairs) == 0:
        return 0
    d = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
    return int(np.sum(d < rad[pairs[:, 0]] + rad[pairs[:, 1]]))


@pytest.mark.parametrize("gap", [float("nan"), float("inf"), -0.004, "a"])
def test_insert_refuses_a_gap_that_is_not_finite_and_non_negative(gap):
    with pytest.raises(ConfigError, match="gap") as exc:
        insert(REGION, 100, template=0.002, seed=1, gap=gap)
    _one_sentence(exc)


@pytest.mark.parametrize("gap", [float("nan"), -0.004])
def test_inserter_refuses_a_bad_gap(gap):
    with pytest.raises(ConfigError, match="gap") as exc:
        Inserter(REGION, 10, template=0.002, gap=gap)
    _one_sentence(exc)


def test_zero_gap_still_allowed_and_no_overlaps():
    ins = insert(REGION, 100, template=0.002, seed=1, gap=0.0)
    assert len(ins) == 100 and _overlaps(ins.positions, ins.radii) == 0


def test_existing_positions_without_radii_are_refused():
    first = insert(REGION, 20, template=0.002, seed=1)
    with pytest.raises(ConfigError, match="existing_radii") as exc:
        insert(REGION, 20, template=0.002, seed=1, existing_positions=first.positions)
    _one_sentence(exc)
    with pytest.raises(ConfigError, match="existing_positions") as exc:
        insert(REGION, 20, template=0.002, seed=1, existing_radii=first.radii)
    _one_sentence(exc)


def test_existing_particles_with_radii_are_avoided():
    first = insert(REGION, 20, template=0.002, seed=1)
    second = insert(REGION, 20, template=0.002, seed=1, existing_positions=first.positions,
                    existing_radii=first.radii)
    both = np.vstack([first.positions, second.positions])
    assert _overlaps(both, np.concatenate([first.radii, second.radii])) == 0


@pytest.mark.parametrize(
    "positions, radii, match",
    [
        (np.zeros((4, 2)), 0.002, "existing_positions"),
        (np.full((4, 3), np.nan), 0.002, "existing_positions"),
        (np.zeros((4, 3)), np.full(3, 0.002), "existing_radii"),
        (np.zeros((4, 3)), -0.002, "existing_radii"),
        (np.zeros((4, 3)), float("nan"), "existing_radii"),
    ],
)
def test_bad_existing_particles_are_refused(positions, radii, match):
    with pytest.raises(ConfigError, match=match) as exc:
        insert(REGION, 5, template=0.002, seed=1, existing_positions=positions, existing_radii=radii)
    _one_sentence(exc)


def test_inserter_call_needs_radii_with_positions():
    inserter = Inserter(REGION, 20, template=0.002, seed=1)
    with pytest.raises(ConfigError, match="radii") as exc:
        inserter(0.0, np.full((20, 3), 0.025))
    _one_sentence(exc)
    assert inserter.inserted == 0


def test_inserter_call_refuses_a_non_finite_time():
    inserter = Inserter(REGION, 20, template=0.002, rate=100.0, seed=1)
    with pytest.raises(ConfigError, match="time") as exc:
        inserter(float("nan"))
    _one_sentence(exc)


@pytest.mark.parametrize("count", [float("nan"), float("inf"), 2.5, "ten", True, -1])
def test_insert_refuses_a_count_that_is_not_a_whole_number(count):
    with pytest.raises(ConfigError, match="count") as exc:
        insert(REGION, count, template=0.002, seed=1)
    _one_sentence(exc)


def test_insert_accepts_a_whole_float_count():
    assert len(insert(REGION, 10.0, template=0.002, seed=1)) == 10


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(total=float("nan")), "count"),
        (dict(total=10, start=float("nan")), "start"),
        (dict(total=10, start="soon"), "start"),
        (dict(total=10, rate="fast"), "rate"),
        (dict(total=10, max_attempts=0), "max_attempts"),
        (dict(total=10, max_attempts=float("nan")), "max_attempts"),
    ],
)
def test_inserter_refuses_bad_parameters(kw, match):
    with pytest.raises(ConfigError, match=match) as exc:
        Inserter(REGION, template=0.002, seed=1, **kw)
    _one_sentence(exc)


@pytest.mark.parametrize("max_attempts", [0, -5, float("nan"), 1.5])
def test_insert_refuses_bad_max_attempts(max_attempts):
    with pytest.raises(ConfigError, match="max_attempts") as exc:
        insert(REGION, 10, template=0.002, seed=1, max_attempts=max_attempts)
    _one_sentence(exc)


def test_too_full_pre_check_says_what_it_found():
    with pytest.raises(ConfigError) as exc:
        insert(REGION, 100_000, template=0.002, seed=1)
    msg = _one_sentence(exc)
    assert "only 0 fitted" not in msg
    assert "volume" in msg and "packing" in msg
    # the numbers the pre-check compared
    solid = 100_000 * 4.0 / 3.0 * math.pi * 0.002**3
    assert f"{solid:.3g}" in msg and f"{REGION.volume:.3g}" in msg


def test_too_full_after_trying_still_counts_the_placed():
    with pytest.raises(ConfigError, match=r"only \d+ fitted") as exc:
        insert(REGION, 1700, template=0.002, seed=1, max_attempts=300)
    _one_sentence(exc)
