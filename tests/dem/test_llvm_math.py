"""The contact kernels' square root (LLVM's intrinsic) gives numba's ``math.sqrt`` bits."""

import math

import numpy as np
from numba import njit

from demcal.dem.contact.llvm_math import sqrt


@njit
def _both(x):
    return sqrt(x), math.sqrt(x)


def test_sqrt_matches_math_sqrt_bit_for_bit():
    rng = np.random.default_rng(3)
    values = np.concatenate([rng.uniform(0.0, 1.0, 200) * 10.0 ** rng.integers(-30, 30, 200),
                             [0.0, -0.0, 1.0, 2.0, np.inf, 5e-324]])
    for x in values:
        ours, ref = _both(float(x))
        assert np.float64(ours).tobytes() == np.float64(ref).tobytes(), x


def test_sqrt_of_a_negative_number_is_nan_not_an_error():
    ours, _ = _both(-1.0)
    assert math.isnan(ours)
    assert math.isnan(_both(float("nan"))[0])
