"""Normal-force sub-models (elastic/plastic part, without damping).

Each returns ``(fn, k, delta0)``: the spring force [N] (positive = repulsive), the
stiffness ``k`` [N/m] the damping slot uses, and the updated residual overlap [m].

* Hertz (EDEM manual, Hertz-Mindlin no slip): ``fn = 4/3 E* sqrt(R*) delta^1.5``,
  ``k = Sn = 2 E* sqrt(R* delta)``.
* Hysteretic spring (Walton & Braun 1986; EDEM HSCM; paper Eq. 1-2):
  ``K1 = 5 R* min(Y_i, Y_j)``, ``K2 = K1 / e^2``,
  ``fn = max(0, min(K1 delta, K2 (delta - delta0)))``. On the loading branch the
  residual overlap follows ``delta0 = delta (1 - K1/K2)`` (the point where the unloading
  line from the current state meets fn = 0); on unloading/reloading it stays fixed.
  ``k`` is the branch slope (K1 loading, K2 unloading), 0 once the spring is slack.
  The engine resets ``delta0`` to 0 when the contact opens.
* Linear spring (EDEM linear spring uses the yield strength too): ``k = 5 R* Y``,
  ``fn = k delta``.
"""

from numba import njit

from .registry import FASTMATH, NORMAL_HERTZ, NORMAL_HYSTERETIC, NORMAL_LINEAR


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def hertz(delta, sq, estar):
    """Hertz spring force and Sn, given ``sq = sqrt(R* delta)``."""
    return 4.0 / 3.0 * estar * sq * delta, 2.0 * estar * sq


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def hysteretic(delta, delta0, r_eff, ymin, e):
    k1 = 5.0 * r_eff * ymin
    k2 = k1 / (e * e)
    f1 = k1 * delta
    f2 = k2 * (delta - delta0)
    # one exit (no early return), so that loops over contacts can be vectorised
    if f1 <= f2:
        fn = f1
        k = k1
        d0 = delta * (1.0 - k1 / k2)
    elif f2 > 0.0:
        fn = f2
        k = k2
        d0 = delta0
    else:
        fn = 0.0
        k = 0.0
        d0 = delta0
    return fn, k, d0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def normal_force(model, delta, delta0, r_eff, sq, estar, ymin, e):
    """Dispatch on the normal slot; see the module docstring. ``sq`` is
    ``sqrt(R* delta)`` (computed once per contact by the caller when a slot needs it)."""
    fn = 0.0
    k = 0.0
    d0 = delta0
    if model == NORMAL_HERTZ:
        fn, k = hertz(delta, sq, estar)
    elif model == NORMAL_HYSTERETIC:
        fn, k, d0 = hysteretic(delta, delta0, r_eff, ymin, e)
    elif model == NORMAL_LINEAR:
        k = 5.0 * r_eff * ymin
        fn = k * delta
    return fn, k, d0


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def loading_stiffness(r_eff, ymin):
    """K1 = 5 R* min(Y_i, Y_j) [N/m] (Walton 2006, EDEM HSCM)."""
    return 5.0 * r_eff * ymin


@njit(cache=True, error_model="numpy", fastmath=FASTMATH, inline="always")
def secant_force(model, delta, fn, k1):
    """``k_n delta`` [N], the elastic normal force LIGGGHTS' rolling model ``cdt`` takes
    (``sidata.kn * sidata.deltan`` in ``rolling_model_cdt.h``, LIGGGHTS-PUBLIC 3.8.0).

    ``k_n`` is the stiffness the normal model hands on: for Hertz LIGGGHTS' ``kn =
    4/3 E* sqrt(R* delta)``, so ``k_n delta`` is the Hertz spring force ``fn``; for the
    linear spring ``k delta = fn``. LIGGGHTS 3.8 has no Walton-Braun Hysteretic Spring;
    its own hysteretic model (``hooke/hysteresis``, a different one: see docs/export.md)
    hands its loading stiffness on as ``k_n``, and we do the same: ``K1 delta`` (= ``fn``
    while loading, larger while unloading). A judgement, since no LIGGGHTS model is ours.
    """
    fe = fn
    if model == NORMAL_HYSTERETIC:
        fe = k1 * delta
    return fe
