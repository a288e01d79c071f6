"""Checkpoints: a simulation's whole run state in one ``.npz`` file, by field name.

Format 5 (this one) stores each container's arrays under ``<container>.<field>``
(``bodies.pos``, ``spheres.radius``, ``pairs.hist``, ``walls.other``, ...; the fields of
:mod:`demcal.dem.storage`) in the engine's order, the ordering's arrays (with
``user_view``), gravity, the sub-model ids and the scalars under their own names, with
``version``. Format 4 is the same with the arrays in user order (read as such: no
``user_view``); formats 1-3 (``b_pos``, ``p_nbr``, ..., a ``scalars`` row) are read too.
A restart from format 1 re-evaluates the forces (not bit-identical), 2-5 restart
bit-identically.
"""

from __future__ import annotations

import os

import numpy as np

from demcal.errors import ConfigError

from .forces import ACC_WIDTH, OUT_WIDTH
from .storage import Bodies, ContactList, Spheres, Store

VERSION = 5
_CONTAINERS = (("bodies", Bodies), ("spheres", Spheres), ("pairs", ContactList),
               ("walls", ContactList))
_SCALARS = ("time", "step", "dt", "wall_travel", "escaped", "forces_valid",
            "needs_rebuild", "last_sort")
_ORDERING = ("perm_b", "perm_s", "carry_engine", "old_of_new", "user_view")
# formats 1-3: container prefixes, renamed fields, and the scalars row's layout
_OLD_PREFIX = {"b_": "bodies", "s_": "spheres", "p_": "pairs", "q_": "walls"}
_OLD_FIELD = {"nbr": "other", "wid": "other"}


def save(path, store: Store, scalars: dict, ordering: dict, gravity, models) -> None:
    """Write a checkpoint atomically (a temporary file, then renamed)."""
    arrays = {f"{name}.{field}": value
              for name, _ in _CONTAINERS
              for field, value in zip(getattr(store, name)._fields, getattr(store, name))}
    arrays.update({k: np.asarray(float(scalars[k])) for k in _SCALARS})
    arrays["version"] = np.asarray(VERSION)
    arrays.update(ordering)
    arrays["gravity"] = gravity
    arrays["models"] = models
    tmp = str(path) + ".tmp.npz"
    np.savez(tmp, **arrays)
    os.replace(tmp, str(path))


def _old_format(z):
    """(containers' fields, scalars) of a format 1-3 file."""
    fields = {name: {} for name, _ in _CONTAINERS}
    for key in z.files:
        name = _OLD_PREFIX.get(key[:2])
        if name is not None:
            fields[name][_OLD_FIELD.get(key[2:], key[2:])] = z[key].copy()
    for key in ("rev", "rev_start"):   # written before the halo index (unused)
        fields["pairs"].pop(key, None)
    sc = z["scalars"]
    version = int(sc[7])
    scalars = dict(time=sc[0], step=sc[1], dt=sc[2], wall_travel=sc[3], escaped=sc[4],
                   forces_valid=sc[5], needs_rebuild=sc[6],
                   last_sort=sc[8] if sc.shape[0] > 8 else -1.0)
    if version < 2:
        # format 1 (before per-sphere force sums): rebuild the derived arrays; the
        # forces are evaluated again on the next step (not bit-identical)
        b, s = fields["bodies"], fields["spheres"]
        b["iso"] = (b["inertia"][:, 0] + b["inertia"][:, 1] + b["inertia"][:, 2]) / 3.0
        s["acc"] = np.zeros((s["pos"].shape[0], ACC_WIDTH))
        for d in (fields["pairs"], fields["walls"]):
            d["out"] = np.zeros((d["hist"].shape[0], OUT_WIDTH))
            if "act" not in d:
                d["act"] = d["hist"][:, 7] != 0.0   # the flag column of format 1
        scalars["forces_valid"] = 0.0
    return fields, scalars


def load(path, models):
    """Read a checkpoint: returns ``(store, scalars, ordering arrays, gravity)``.

    ConfigError (one sentence) when the file cannot be read, is not a checkpoint, or
    was written with other sub-models than ``models``."""
    try:
        z = np.load(str(path))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"cannot read checkpoint {path}: {exc}.") from None
    with z:
        if "models" not in z.files:
            raise ConfigError(f"{path} is not a demcal checkpoint (no contact model in "
                              "it); give a file written by save_checkpoint.")
        if not np.array_equal(z["models"], models):
            raise ConfigError(f"checkpoint {path} was written with another contact model.")
        if "version" in z.files:
            version = int(z["version"])
            if version > VERSION:
                raise ConfigError(f"checkpoint {path} is format {version}, newer than this "
                                  f"demcal reads ({VERSION}); update demcal.")
            fields = {name: {} for name, _ in _CONTAINERS}
            for key in z.files:
                name, _, field = key.partition(".")
                if name in fields:
                    fields[name][field] = z[key].copy()
            scalars = {k: float(z[k]) for k in _SCALARS}
        else:
            fields, scalars = _old_format(z)
        ordering = {k: z[k].copy() for k in _ORDERING if k in z.files}
        gravity = z["gravity"].copy()
    store = Store(*(cls(**fields[name]) for name, cls in _CONTAINERS))
    return store, scalars, ordering, gravity


def save_simulation(sim, path) -> None:
    """:meth:`Simulation.save_checkpoint`: the arrays in the engine's order, with the
    ordering (what was written into ``sim.state`` included)."""
    sim._view.close(sim._store, keep=True)
    o = sim._ordering
    scalars = dict(time=sim.time, step=sim.step_count, dt=sim.dt,
                   wall_travel=sim._wall_travel, escaped=sim.escaped,
                   forces_valid=sim._forces_valid, needs_rebuild=sim._needs_rebuild,
                   last_sort=-1.0 if o.last_sort is None else o.last_sort)
    save(path, sim._store, scalars, o.arrays(), sim.gravity, sim.description.models)


def restore_simulation(sim, path) -> None:
    """:meth:`Simulation.load_checkpoint`."""
    store, sc, ordering, gravity = load(path, sim.description.models)
    sim._store = store
    sim.gravity = gravity
    sim.time = float(sc["time"])
    sim.step_count = int(sc["step"])
    sim._dt = float(sc["dt"])
    sim._wall_travel = float(sc["wall_travel"])
    sim.escaped = int(sc["escaped"])
    sim._forces_valid = bool(sc["forces_valid"])
    sim._needs_rebuild = bool(sc["needs_rebuild"])
    sim._ordering.restore(ordering, int(sc["last_sort"]) if sc["last_sort"] >= 0 else None)
    sim._backend.lists_changed()
    sim._lists.forget_spare()
    if sim.walls is not None and sim._walls.moving:
        sim.walls.update(sim.time)
        sim._walls.load(sim.time)
