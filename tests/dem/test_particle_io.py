"""Particle files (``demcal.io.particles``): a packing written and read back is the same
packing, bitwise where the file holds the numbers (positions, velocities, sizes)."""

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.io.particles import COLUMNS, load_particles, save_particles
from demcal.errors import ConfigError, DataError
from demcal.geometry import Plane, WallSet
from demcal.particles.materials import Interaction
from demcal.particles.templates import two_sphere_paper

from dem_helpers import SOFT, SOFT_WALL


def _sim(backend):
    return Simulation([SOFT, SOFT_WALL], Interaction(),
                      walls=WallSet([Plane(name="floor", material=1)]), backend=backend)


def _packing(backend):
    sim = _sim(backend)
    tpl = two_sphere_paper()
    sim.add_particles(positions=[[0, 0, 0.01], [0.05, 0, 0.01]], radii=[0.004, 0.005],
                      velocities=[0.1, 0, 0])
    sim.add_particles(tpl, [[0.1, 0, 0.02], [0.15, 0, 0.02]], orientations="random",
                      rotation=[True, False], fixed=[False, True],
                      angular_velocities=[[1, 2, 3], [0, 0, 0]], scales=[0.9, 1.1])
    sim.add_particles(0.003, [[0.2, 0, 0.01]], material="soft_wall")
    sim.run(duration=0.01)
    return sim, tpl


def test_round_trip(tmp_path, backend):
    sim, tpl = _packing(backend)
    path = save_particles(tmp_path / "bed.csv", sim)
    assert path.read_text().splitlines()[0] == ",".join(COLUMNS)
    assert not [p for p in tmp_path.iterdir() if p.name != "bed.csv"]   # no temporary left
    loaded = load_particles(path)
    assert len(loaded) == 5
    assert list(loaded.templates) == ["sphere(1)", "sphere(1)", tpl.name, tpl.name,
                                      "sphere(0.003)"]
    again = _sim(backend)
    np.testing.assert_array_equal(loaded.add_to(again, templates={tpl.name: tpl}),
                                  np.arange(5))
    a, b = sim.state, again.state
    for name in ("positions", "velocities", "omegas", "radii", "fixed", "materials"):
        np.testing.assert_array_equal(getattr(b, name), getattr(a, name), err_msg=name)
    # the sphere added as a radius comes back as radii= (a unit sphere scaled)
    np.testing.assert_array_equal(b.scales, [*a.scales[:4], 0.003])
    np.testing.assert_allclose(b.masses, a.masses, rtol=1e-15)
    np.testing.assert_allclose(b.inertias, a.inertias, rtol=1e-15)
    np.testing.assert_allclose(b.quaternions, a.quaternions, atol=1e-15)
    np.testing.assert_allclose(b.sphere_positions, a.sphere_positions, atol=1e-15)
    np.testing.assert_allclose(b.angular_momenta, a.angular_momenta, rtol=1e-12,
                               atol=1e-24)
    assert np.isinf(b.inertias[3]).all() and not np.isinf(b.inertias[2]).any()
    again.run(steps=5)


def test_clump_needs_its_template(tmp_path, backend):
    sim, tpl = _packing(backend)
    loaded = load_particles(save_particles(tmp_path / "bed.csv", sim))
    with pytest.raises(ConfigError, match="pass the template"):
        loaded.add_to(_sim(backend))


def test_from_a_state_gives_indices(tmp_path, backend):
    sim, tpl = _packing(backend)
    loaded = load_particles(save_particles(tmp_path / "bed.csv", sim.state))
    assert list(loaded.materials) == ["0", "0", "0", "0", "1"]
    loaded.add_to(_sim(backend), templates={"1": tpl})


def test_bad_files_are_one_sentence(tmp_path):
    with pytest.raises(DataError, match="cannot read particle file"):
        load_particles(tmp_path / "none.csv")
    (tmp_path / "a.csv").write_text("x,y,z\n1,2,3\n")
    with pytest.raises(DataError, match="is not a demcal particle file"):
        load_particles(tmp_path / "a.csv")
    row = ["0", "t", "1"] + ["1.0"] * 15 + ["m", "0", "1"]
    (tmp_path / "b.csv").write_text(",".join(COLUMNS) + "\n" + ",".join(row[:-1]) + "\n")
    with pytest.raises(DataError, match="line 2 has 20 fields, not 21"):
        load_particles(tmp_path / "b.csv")
    row[4] = "high"
    (tmp_path / "c.csv").write_text(",".join(COLUMNS) + "\n" + ",".join(row) + "\n")
    with pytest.raises(DataError, match="column 'y' holds a value that is not a number"):
        load_particles(tmp_path / "c.csv")
