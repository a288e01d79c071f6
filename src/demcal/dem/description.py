"""What a simulation *is*, fixed when it is built: materials and their pair table, the
contact sub-models, the time-step policy, the skin, the domain, the threads and the
backend (OpenMM's ``System``: a description, no run state).

:func:`describe` checks every constructor argument in one place and returns a frozen
:class:`Description`; the walls and gravity, which the user may change between runs,
are checked where they are kept (:mod:`demcal.dem.walltable`, :mod:`demcal.dem.checks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from demcal.errors import ConfigError
from demcal.particles.materials import MaterialTable

from .backend import BACKENDS
from .checks import is_integer, is_real, positive
from .contact.chosen import Chosen
from .contact.registry import ContactModel
from .contact.table import pair_table


@dataclass(frozen=True)
class Description:
    """A simulation's fixed description (see :class:`~demcal.dem.Simulation` for the
    meaning of each argument). ``chosen`` holds the sub-model ids (normal, damping,
    tangential, rolling) as the compiled loops take them
    (:class:`~demcal.dem.contact.chosen.Chosen`: constants of the compiled code),
    :attr:`models` the same ids as an array, and ``table`` the material-pair constants
    the kernels read."""

    material_table: MaterialTable
    contact_model: ContactModel
    chosen: Chosen
    table: np.ndarray
    dt: float | None
    dt_fraction: float
    impact_speed: float
    skin: float | None
    domain: tuple | None
    threads: int
    backend: str

    @property
    def models(self) -> np.ndarray:
        """The sub-model ids (normal, damping, tangential, rolling) as int64 (checkpoints,
        the host's time-step and reach rules)."""
        return np.array(self.chosen.ids, dtype=np.int64)

    @property
    def materials(self):
        return self.material_table.materials


def _contact_model(contact_model, rolling_model) -> ContactModel:
    if isinstance(contact_model, ContactModel):
        contact_model.ids()
        if rolling_model is not None:
            own = contact_model.ids()[3]
            if ContactModel(rolling=rolling_model).ids()[3] != own:
                raise ConfigError(
                    f"rolling_model {rolling_model!r} conflicts with the contact_model's "
                    f"rolling {contact_model.rolling!r}; name the rolling model once: "
                    f"ContactModel(..., rolling={rolling_model!r}), or leave "
                    "rolling_model unset.")
        return contact_model
    return ContactModel.preset(contact_model,
                               "type_a" if rolling_model is None else rolling_model)


def _domain(domain):
    if domain is None:
        return None
    try:
        lo, hi = (np.asarray(v, dtype=float).reshape(3) for v in domain)
    except (TypeError, ValueError):
        raise ConfigError(f"domain must be (lo, hi), two corners of three numbers "
                          f"each [m], got {domain!r}.") from None
    if not np.all(hi > lo):
        raise ConfigError(f"domain must be (lo, hi) with hi > lo, got {domain!r}.")
    return (lo, hi)


def describe(materials, interactions, dt=None, contact_model="hertz_mindlin",
             rolling_model=None, dt_fraction=0.2, impact_speed=2.0, skin=None,
             domain=None, threads=None, backend="cpu") -> Description:
    """Check the constructor's arguments; ConfigError (one sentence) on the first bad
    one."""
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; available: {list(BACKENDS)}.")
    # before numba's threads start: asking for their number below would pick the
    # threading layer (OpenMP is asked for first, see _cache.prefer_openmp)
    BACKENDS[backend].prepare()
    table = MaterialTable(materials, interactions)
    model = _contact_model(contact_model, rolling_model)
    if dt is not None and not (is_real(dt) and math.isfinite(dt) and dt > 0):
        raise ConfigError(f"dt must be a positive number of seconds, got {dt!r}.")
    if not (is_real(dt_fraction) and 0.0 < dt_fraction <= 1.0):
        raise ConfigError(f"dt_fraction must be in (0, 1], got {dt_fraction!r}.")
    impact_speed = positive(impact_speed, "impact_speed", "m/s", optional=False)
    skin = positive(skin, "skin", "m")
    dom = _domain(domain)
    if threads is None:
        threads = BACKENDS[backend].default_threads()
    if not (is_integer(threads) and threads >= 1):
        raise ConfigError(f"threads must be a positive integer, got {threads!r}.")
    return Description(material_table=table, contact_model=model, chosen=Chosen(model.ids()),
                       table=np.ascontiguousarray(pair_table(table, model)),
                       dt=None if dt is None else float(dt),
                       dt_fraction=float(dt_fraction), impact_speed=impact_speed,
                       skin=skin, domain=dom, threads=int(threads), backend=backend)
