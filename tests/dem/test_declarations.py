"""Contact sub-models declare themselves; the engine's tables come from the declarations.

The pair table, the history layout, the name tables, the time-step rule and the bench
settings are read from ``SubModel`` rows (``demcal.dem.contact.declare``), so these tests
check the derived tables against the layout and values the kernels were written for.
"""

import math

import numpy as np
import pytest

from demcal.bench.registry import get_experiment
from demcal.dem import Simulation
from demcal.dem.contact import registry
from demcal.dem.contact.declare import COLUMNS, Coefficient
from demcal.dem.contact.normal import hertz_contact_time, spring_contact_time
from demcal.dem.contact.pairs import (P_BETA, P_E, P_ESTAR, P_ETA_R, P_GSTAR, P_MU_R,
                                      P_MU_S, P_SQ_ST_SN, P_XI, P_YMIN, P_ZETA)
from demcal.dem.contact.table import coefficient_names, pair_table
from demcal.dem.timestep import contact_times, stable_limit
from demcal.errors import ConfigError
from demcal.particles.materials import Interaction, MaterialTable, soil, steel
from demcal.particles.templates import sphere


def test_each_slot_maps_its_names_to_distinct_ids():
    for slot, models in registry.SUBMODELS.items():
        ids = [m.id for m in models]
        assert ids == sorted(set(ids)), slot
        for m in models:
            assert m.slot == slot
            for name in m.names:
                assert getattr(registry, slot.upper())[name] == m.id


def test_history_layout_is_the_one_checkpoints_have_kept_since_format_1():
    assert registry.HISTORY_COLUMNS["tangential_displacement"] == 0
    assert registry.HISTORY_COLUMNS["residual_overlap"] == 3
    assert registry.HISTORY_COLUMNS["rolling_spring_torque"] == 4
    assert registry.VECTOR_COLUMNS == (0, 1, 2, 4, 5, 6)
    assert registry.H_FLAG == 7 and registry.HIST_WIDTH == 8


def test_every_declared_history_field_and_coefficient_has_its_place():
    for models in registry.SUBMODELS.values():
        for m in models:
            for f in m.history:
                assert f.name in registry.HISTORY_COLUMNS
            for c in m.coefficients + m.constants:
                assert COLUMNS[c.column] is c


def test_pair_table_holds_the_mixing_rules_by_hand():
    soil_, steel_ = soil(), steel()
    it = Interaction(restitution=0.5, static_friction=0.3, rolling_friction=0.1,
                     damping_factor=0.2, stiffness_factor=0.8, rolling_damping=0.25)
    row = pair_table(MaterialTable([soil_, steel_], it))[0, 1]
    e1, e2 = soil_.youngs_modulus, steel_.youngs_modulus
    n1, n2 = soil_.poisson_ratio, steel_.poisson_ratio
    estar = 1.0 / ((1 - n1 ** 2) / e1 + (1 - n2 ** 2) / e2)
    gstar = 1.0 / ((2 - n1) / soil_.shear_modulus + (2 - n2) / steel_.shear_modulus)
    le = math.log(0.5)
    assert row[P_ESTAR] == pytest.approx(estar, rel=1e-15)
    assert row[P_GSTAR] == pytest.approx(gstar, rel=1e-15)
    assert row[P_BETA] == pytest.approx(le / math.sqrt(le * le + math.pi ** 2), rel=1e-15)
    assert row[P_SQ_ST_SN] == pytest.approx(math.sqrt(4 * gstar / estar), rel=1e-15)
    assert row[P_YMIN] == min(soil_.yield_strength, steel_.yield_strength)
    assert (row[P_E], row[P_MU_S], row[P_MU_R], row[P_ZETA], row[P_XI], row[P_ETA_R]) == \
        (0.5, 0.3, 0.1, 0.2, 0.8, 0.25)


@pytest.mark.parametrize("name", ["restitution", "static_friction", "rolling_friction",
                                  "damping_factor", "stiffness_factor", "rolling_damping"])
def test_declared_ranges_agree_with_what_interaction_accepts(name):
    c = next(c for c in COLUMNS if isinstance(c, Coefficient) and c.name == name)
    for x in (c.low - 1e-9, c.low, c.low + 1e-9, 0.5, 1.0, 1.0 + 1e-9, 3.0):
        try:
            Interaction(**{name: x})
            accepted = True
        except ConfigError:
            accepted = False
        try:
            c.check(x)
            declared = True
        except ConfigError:
            declared = False
        assert accepted == declared, (name, x)


def test_an_unknown_coefficient_is_one_sentence_when_the_engine_builds_its_table():
    it = Interaction(surface_energi=0.1)
    with pytest.raises(ConfigError, match=r"unknown interaction coefficient 'surface_energi'"):
        Simulation([soil()], it)


def test_interaction_keeps_other_coefficients_by_name():
    it = Interaction(restitution=0.5, some_coefficient=2.0)
    assert it.value("restitution") == 0.5
    assert it.value("some_coefficient") == 2.0 and it.some_coefficient == 2.0
    assert it.value("absent", 7.0) == 7.0
    with pytest.raises(AttributeError):
        it.absent
    assert Interaction(some_coefficient=2.0, restitution=0.5) == it


def test_time_step_rules_are_the_declared_ones():
    tab = pair_table(MaterialTable([soil()], Interaction(restitution=0.5)))
    r, m, v = 0.002, 1e-4, 2.0
    hertz = registry.NORMAL["hertz"]
    hyst = registry.NORMAL["hysteretic"]
    assert contact_times(hertz, tab, [(0, 0, r, m)], [], v) == \
        hertz_contact_time(m, r, tab[0, 0, P_ESTAR], v)
    k2 = 5.0 * r * tab[0, 0, P_YMIN] / 0.25
    assert contact_times(hyst, tab, [(0, 0, r, m)], [], v) == spring_contact_time(m, k2)
    assert stable_limit(hertz, 1e-5, 1e-3) == 1e-5      # the Rayleigh time bounds Hertz
    assert stable_limit(hyst, 1e-5, 1e-3) == 1e-3 / 5.0


def test_every_declared_coefficient_is_a_bench_setting_of_every_pair():
    for bench in ("repose-funnel", "repose-cylinder", "incline", "impact"):
        keys = set(get_experiment(bench).settings("quick"))
        prefixes = {k.split(".")[0] for k in keys} & {"particle", "wall", "film"}
        for prefix in prefixes:
            for name in coefficient_names():
                if name == "stiffness_factor" and prefix == "wall":
                    continue      # the steel walls take the particles' (bench.common)
                assert f"{prefix}.{name}" in keys, (bench, prefix, name)


def test_rolling_damping_reaches_the_engine_from_bench_settings():
    from demcal.bench import common
    s = {f"particle.{k}": v for k, v in dict(restitution=0.6, static_friction=0.4,
                                             rolling_friction=0.2, damping_factor=0.1,
                                             stiffness_factor=0.95,
                                             rolling_damping=0.45).items()}
    it = common.interaction(s, "particle")
    assert it.rolling_damping == 0.45
    sim = Simulation([soil()], it, rolling_model="type_c")
    sim.add_particles(sphere(0.002), np.zeros((1, 3)))
    assert sim.description.table[0, 0, P_ETA_R] == 0.45
