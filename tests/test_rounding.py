"""Numbers as a reader wants them (issue 40, item 6): :mod:`demcal.rounding`.

The rule is the GUM's (JCGM 100:2008 §7.2.6): an uncertainty to at most two significant
digits, the value to the same decimal place. The expected strings are worked by hand
from that rule.
"""

from __future__ import annotations

import math

import pytest

from demcal.rounding import decimals, measured, ranged, rounded, with_unit

NAN = float("nan")


@pytest.mark.parametrize("value, sd, unit, text", [
    (33.2085, 2.02636, "°", "33.2 ± 2.0°"),  # the example
    (39.88, 2.2, "°", "39.9 ± 2.2°"),
    (41.59, 1.88, "°", "41.6 ± 1.9°"),
    (39.82, 0.5912, "°", "39.82 ± 0.59°"),  # a smaller sd keeps more of the mean
    (35.74, 12.6, "°", "36 ± 13°"),  # a larger one keeps less
    (0.03, 2.5, "°", "0.0 ± 2.5°"),
    (-0.004, 0.0996, None, "0.00 ± 0.10"),  # 0.0996 rounds up to 0.10: one digit fewer; no "-0.00"
    (10.04, 9.96, "%", "10 ± 10 %"),  # a unit other than an angle's takes a space
    (12345.6, 234.0, "Pa", "12350 ± 230 Pa"),  # to tens
    (1.234e9, 5.0e7, "Pa", "(1.234 ± 0.050) × 10⁹ Pa"),  # large: one power of ten for both
    (2.5e-5, 3e-6, "m", "(2.50 ± 0.30) × 10⁻⁵ m"),  # small
    (33.2085, -2.02636, "°", "33.2 ± 2.0°"),  # an sd's sign is no part of it
])
def test_a_value_is_rounded_to_two_digits_of_its_uncertainty(value, sd, unit, text):
    assert measured(value, sd, unit) == text


def test_no_usable_uncertainty():
    assert measured(33.2085, 0.0, "°") == "33.2 ± 0°"  # sd 0: the value keeps three significant digits
    assert measured(33.2085, NAN, "°") == "33.2°"  # no sd: the value alone
    assert measured(33.2085, math.inf, "°") == "33.2°"  # no interval (no degrees of freedom)
    assert measured(33.2085, None, "°") == "33.2°"
    assert measured(NAN, 2.0, "°") == "n/a°"
    assert rounded(NAN) == "n/a" and rounded(math.inf) == "∞" and rounded(-math.inf) == "−∞"
    assert rounded(0.0) == "0" and rounded(1234.5) == "1230" and rounded(1.0e9) == "1.00 × 10⁹"


def test_a_value_alone_to_its_uncertainty():
    assert rounded(33.2085, 2.02636, "°") == "33.2°"
    assert rounded(38.2466, 2.2, "°") == "38.2°"
    assert rounded(0.4567, unit="-") == "0.457"  # a dimensionless unit is not written
    assert with_unit("12", "%") == "12 %" and with_unit("33.2", "°") == "33.2°" and with_unit("1", "") == "1"


@pytest.mark.parametrize("uncertainty, places", [
    (2.02636, 1), (0.59, 2), (12.6, 0), (234.0, -1), (0.0996, 2), (9.96, 0), (1.0, 1),
    (0.0, None), (NAN, None), (math.inf, None), ("x", None)])
def test_decimals(uncertainty, places):
    assert decimals(uncertainty) == places


@pytest.mark.parametrize("value, low, high, text", [
    (0.3837, 0.35, 0.42, ("0.384", "0.350", "0.420")),  # two digits of the width 0.07: three places
    (0.39, 0.32, 0.50, ("0.39", "0.32", "0.50")),
    (0.6, 0.5, 0.7, ("0.60", "0.50", "0.70")),  # at least two significant digits
    (0.05, 0.01, 0.3, ("0.050", "0.010", "0.300")),
    (0.184, 0.1833, 0.1846, ("0.184", "0.183", "0.185")),  # at most three, however narrow the set
    (0.676, NAN, NAN, ("0.676", "", "")),  # no solution set (a point on the path): three digits
    (0.6, 0.6, 0.6, ("0.600", "0.600", "0.600")),  # a set of one point
    (2.6e9, 2.0e9, 3.0e9, ("2.6 × 10⁹", "2.0 × 10⁹", "3.0 × 10⁹")),  # a shear modulus [Pa]: one power of ten
])
def test_a_parameter_to_the_width_of_its_solution_set(value, low, high, text):
    assert ranged(value, low, high) == text
