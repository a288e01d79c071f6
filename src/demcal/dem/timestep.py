"""Time-step selection and the stability check.

* Rayleigh time (EDEM manual; Li, Xu & Thornton 2005, Powder Technol. 160, 219-228):
  ``T_R = pi R sqrt(rho / G) / (0.1631 nu + 0.8766)`` for the smallest sphere.
* The contact duration t_c is the normal sub-model's declared rule
  (``SubModel.contact_time``; :mod:`demcal.dem.contact.normal` gives each with its
  source: Hertz impact duration, half a period of a spring's stiffest branch).

The automatic step is ``min(fraction * T_R, t_c / 10)``, with t_c the shortest contact
duration over all particle-particle and particle-wall material pairs, for the smallest
particle, at the characteristic impact speed. A step is refused when it exceeds
``min(T_R, t_c / 5)`` (sub-models declared ``rayleigh_bound``, Hertz) or ``t_c / 5``
(springs): fewer than five steps per contact is where velocity Verlet stops resolving a
collision (it is unstable beyond ``t_c / (pi/2)`` for a linear spring).
"""

import math

import numpy as np

from demcal.errors import ConfigError

from .contact.normal import hertz_contact_time, spring_contact_time  # noqa: F401
from .contact.registry import submodel


def rayleigh_time(radius, density, shear_modulus, poisson_ratio):
    """Rayleigh time step [s] of a sphere (EDEM manual; Li et al. 2005)."""
    return (math.pi * radius * math.sqrt(density / shear_modulus)
            / (0.1631 * poisson_ratio + 0.8766))


def contact_times(normal_model, table, particle_pairs, wall_pairs, speed):
    """Shortest contact duration over the given material pairs, by the normal
    sub-model's declared rule.

    ``particle_pairs`` / ``wall_pairs``: iterables of ``(mi, mj, r_eff, m_eff)``.
    """
    rule = submodel("normal", normal_model).contact_time
    t = math.inf
    for mi, mj, r_eff, m_eff in list(particle_pairs) + list(wall_pairs):
        t = min(t, rule(table[mi, mj], r_eff, m_eff, speed))
    return t


def choose_dt(normal_model, t_rayleigh, t_contact, fraction, contact_fraction=None):
    """The time-step policy [s]: ``min(fraction * T_R, contact_fraction * t_c)``, with
    ``t_c / 10`` when ``contact_fraction`` is None (the engine's automatic step).

    It is demcal's one policy: the engine's automatic step uses it with ``dt_fraction``
    for the particles present, and the bench tests with ``fraction`` 0.2 and their
    ``time.step_fraction`` for the smallest particle of their size distribution
    (:func:`demcal.bench.common.time_step`), which they give the engine as ``dt``
    because their particles arrive during the run."""
    if not 0.0 < fraction <= 1.0:
        raise ConfigError(f"dt_fraction must be in (0, 1], got {fraction}.")
    if contact_fraction is None:
        return min(fraction * t_rayleigh, t_contact / 10.0)
    return min(fraction * t_rayleigh, contact_fraction * t_contact)


def stable_limit(normal_model, t_rayleigh, t_contact):
    """Largest accepted time step [s]."""
    if submodel("normal", normal_model).rayleigh_bound:
        return min(t_rayleigh, t_contact / 5.0)
    return t_contact / 5.0


def check_dt(dt, normal_model, t_rayleigh, t_contact):
    """ConfigError naming ``dt`` when it is not positive or above the stable limit."""
    if not (isinstance(dt, (int, float)) and math.isfinite(dt) and dt > 0):
        raise ConfigError(f"dt must be a positive number of seconds, got {dt!r}.")
    limit = stable_limit(normal_model, t_rayleigh, t_contact)
    if dt > limit:
        raise ConfigError(
            f"dt = {dt:.3g} s is above the stable limit {limit:.3g} s for these "
            f"stiffnesses (Rayleigh time {t_rayleigh:.3g} s, shortest contact "
            f"{t_contact:.3g} s); use dt <= {limit:.3g} s or leave dt unset.")


def time_scales(description, body_mat, body_mass, sphere_radius, sphere_body, wall_mat):
    """(Rayleigh time, shortest contact duration) [s] of the particles present: per
    material, its smallest sphere and lightest body against every material present and
    every wall material (``description``: a :class:`~demcal.dem.description.Description`).
    """
    mats = np.unique(body_mat)
    t_r = math.inf
    pp, pw = [], []
    wmats = np.unique(wall_mat)
    for m in mats:
        sel = body_mat == m
        smask = np.isin(sphere_body, np.nonzero(sel)[0])
        rmin = sphere_radius[smask].min()
        mmin = body_mass[sel].min()
        mat = description.materials[m]
        t_r = min(t_r, rayleigh_time(rmin, mat.density, mat.shear_modulus,
                                     mat.poisson_ratio))
        for m2 in mats:
            pp.append((m, m2, rmin / 2.0, mmin / 2.0))
        for wm in wmats:
            pw.append((m, wm, rmin, mmin))
    t_c = contact_times(int(description.models[0]), description.table, pp, pw,
                        description.impact_speed)
    return t_r, t_c


def resolve_dt(description, t_rayleigh, t_contact) -> float:
    """The step of a simulation: the user's ``dt`` checked against the stable limit, or
    the automatic one (:func:`choose_dt`)."""
    model = int(description.models[0])
    if description.dt is not None:
        check_dt(description.dt, model, t_rayleigh, t_contact)
        return description.dt
    return choose_dt(model, t_rayleigh, t_contact, description.dt_fraction)
