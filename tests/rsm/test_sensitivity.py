"""Main effects, scaled sensitivities and null directions of a screen, against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from demcal.doe.designs import plackett_burman
from demcal.errors import DataError
from demcal.rsm.sensitivity import (describe_combination, identifiability, main_effects, pins_more,
                                    t_quantile)


def _values(coded, responses, noise):
    """(points, 2, m): each response, plus and minus ``noise`` on its two replicates."""
    clean = np.column_stack([f(coded) for f in responses])  # (points, m)
    return np.stack([clean + noise, clean - noise], axis=1)


def test_effects_and_noise_by_hand():
    coded = plackett_burman(3)  # 8 points
    values = _values(coded, [lambda x: 5 + 2 * x[:, 0] - 1 * x[:, 2]], 0.1)
    screen = main_effects(coded, values)
    np.testing.assert_allclose(screen.effects[0], [2.0, 0.0, -1.0], atol=1e-12)
    # replicates y +- 0.1: each point's sd is 0.1 sqrt(2), pooled over 8 points, 8 dof
    assert screen.dof == 8
    np.testing.assert_allclose(screen.noise, [0.1 * np.sqrt(2)])
    # se = s sqrt(1/8 + 1/8) / 2 = s / 4 with 16 runs, 8 at each level
    np.testing.assert_allclose(screen.se[0], [0.1 * np.sqrt(2) / 4] * 3)
    np.testing.assert_allclose(screen.sensitivity[0], [4 / (0.1 * np.sqrt(2)), 0, -2 / (0.1 * np.sqrt(2))])


def test_t_quantile_is_students():
    assert t_quantile(8) == pytest.approx(2.306004, abs=1e-6)  # tables: t_0.975,8 = 2.306


def test_one_response_of_a_sum_ties_its_factors():
    coded = plackett_burman(3)
    values = _values(coded, [lambda x: 3 * x[:, 0] + 3 * x[:, 1]], 0.1)
    a = identifiability(main_effects(coded, values))
    assert a.unpinned == (2,) and a.pinned == ()
    [combo] = a.combinations
    assert combo.factors == (0, 1) and combo.free == 1
    np.testing.assert_allclose(combo.pinned[0], [2 ** -0.5, 2 ** -0.5])
    assert np.isinf(a.condition_number) and a.rank == 1
    assert describe_combination(combo.pinned[0], ["a", "b"]) == "0.71 a + 0.71 b"


def test_two_responses_pin_two_factors():
    coded = plackett_burman(2)
    values = _values(coded, [lambda x: 3 * x[:, 0] + 3 * x[:, 1], lambda x: 2 * x[:, 1]], 0.1)
    a = identifiability(main_effects(coded, values))
    assert a.pinned == (0, 1) and a.combinations == () and a.rank == 2
    s = main_effects(coded, values).sensitivity
    sv = np.linalg.svd(s, compute_uv=False)
    assert a.condition_number == pytest.approx(sv[0] / sv[1])
    # a second response separates what the first ties together
    assert pins_more(s[:1], s[1], a.threshold)
    assert not pins_more(s[:1], 2 * s[0], a.threshold)


def test_a_design_that_cannot_give_the_effects_is_refused():
    with pytest.raises(DataError, match="cannot estimate 3 main effects"):
        main_effects(np.array([[1, 1, 1], [-1, -1, -1], [1, -1, 1.0]]), np.zeros((3, 2, 1)))
    with pytest.raises(DataError, match="confounds"):
        coded = np.array([[1, 1], [-1, -1], [1, 1], [-1, -1.0]])
        main_effects(coded, np.zeros((4, 2, 1)))
    with pytest.raises(DataError, match="at least 2 seeds"):
        main_effects(plackett_burman(2), np.zeros((8, 1, 1)))
