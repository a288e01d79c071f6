"""Time-step selection and the stability check.

* Rayleigh time (EDEM manual; Li, Xu & Thornton 2005, Powder Technol. 160, 219-228):
  ``T_R = pi R sqrt(rho / G) / (0.1631 nu + 0.8766)`` for the smallest sphere.
* Hertz contact duration of an elastic impact at speed v (Johnson 1985, Contact
  Mechanics, section 11.4, Eq. 11.24): ``t_H = 2.9432 (15 m* / (16 E* sqrt(R*)))^(2/5)
  v^(-1/5)`` where 2.9432 = 2 sqrt(pi) Gamma(7/5) / Gamma(9/10).
* Linear / hysteretic spring: the contact lasts half a period of the stiffest branch,
  ``t_s = pi sqrt(m* / K2)`` with ``K2 = K1 / e^2``, ``K1 = 5 R* Y_min``.

The automatic step is ``min(fraction * T_R, t_c / 10)``, with t_c the shortest contact
duration over all particle-particle and particle-wall material pairs, for the smallest
particle, at the characteristic impact speed. A step is refused when it exceeds
``min(T_R, t_c / 5)`` (Hertz) or ``t_c / 5`` (springs): fewer than five steps per
contact is where velocity Verlet stops resolving a collision (it is unstable beyond
``t_c / (pi/2)`` for a linear spring).
"""

import math

import numpy as np

from demcal.errors import ConfigError

from .contact.registry import NORMAL_HERTZ

GAMMA_FACTOR = 2.0 * math.sqrt(math.pi) * math.gamma(1.4) / math.gamma(0.9)  # 2.9432


def rayleigh_time(radius, density, shear_modulus, poisson_ratio):
    """Rayleigh time step [s] of a sphere (EDEM manual; Li et al. 2005)."""
    return (math.pi * radius * math.sqrt(density / shear_modulus)
            / (0.1631 * poisson_ratio + 0.8766))


def hertz_contact_time(m_eff, r_eff, estar, speed):
    """Duration [s] of an elastic Hertz impact at relative speed ``speed`` (Johnson 1985)."""
    return GAMMA_FACTOR * (15.0 * m_eff / (16.0 * estar * math.sqrt(r_eff))) ** 0.4 \
        * speed ** -0.2


def spring_contact_time(m_eff, stiffness):
    """Half period pi sqrt(m*/k) [s] of a linear spring."""
    return math.pi * math.sqrt(m_eff / stiffness)


def contact_times(normal_model, table, particle_pairs, wall_pairs, speed):
    """Shortest contact duration over the given material pairs.

    ``particle_pairs`` / ``wall_pairs``: iterables of ``(mi, mj, r_eff, m_eff)``.
    """
    from demcal.particles.materials import P_E, P_ESTAR, P_YMIN
    t = math.inf
    for mi, mj, r_eff, m_eff in list(particle_pairs) + list(wall_pairs):
        p = table[mi, mj]
        if normal_model == NORMAL_HERTZ:
            tc = hertz_contact_time(m_eff, r_eff, p[P_ESTAR], speed)
        else:
            k2 = 5.0 * r_eff * p[P_YMIN] / p[P_E] ** 2
            tc = spring_contact_time(m_eff, k2)
        t = min(t, tc)
    return t


def choose_dt(normal_model, t_rayleigh, t_contact, fraction):
    """Automatic time step [s]."""
    if not 0.0 < fraction <= 1.0:
        raise ConfigError(f"dt_fraction must be in (0, 1], got {fraction}.")
    return min(fraction * t_rayleigh, t_contact / 10.0)


def stable_limit(normal_model, t_rayleigh, t_contact):
    """Largest accepted time step [s]."""
    if normal_model == NORMAL_HERTZ:
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
