"""A cylinder of infinite length (``Cylinder(..., length=math.inf)``).

The distance kernel clamps the axial coordinate to [0, length]; with an infinite length
nothing clamps above the base, so the distance is |rho - R| (rho the distance from the
axis) at any height, and below the base it is the distance to the base rim, as for a
finite cylinder. A sphere resting in a horizontal pipe of that kind loads it with its
weight m g however far along the axis it lies (statics).
"""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.errors import ConfigError
from demcal.geometry import Cylinder, Disk, Translation, WallSet
from demcal.geometry.kernels import wall_distance
from demcal.geometry.walls import aabb_rows
from demcal.particles.materials import Interaction, Material

R = 0.02
SOFT = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3,
                yield_strength=1.0e6, name="soft")


def test_distance_has_no_far_end():
    kinds, params = Cylinder(base=(0, 0, 0), axis=(0, 0, 1), radius=R,
                             length=math.inf).rows()
    p = np.ascontiguousarray(params[0])
    for z in (0.0, 0.3, 1e3, 1e9):
        d, nx, ny, nz = wall_distance(int(kinds[0]), p, 0.005, 0.0, z)
        assert d == pytest.approx(R - 0.005, rel=1e-12)
        assert (nx, ny, nz) == pytest.approx((-1.0, 0.0, 0.0))
    # below the base: the rim, as for a finite cylinder
    d, *_ = wall_distance(int(kinds[0]), p, R, 0.0, -0.01)
    assert d == pytest.approx(0.01, rel=1e-12)


def test_bounding_box_and_drawing_stay_finite_across_the_axis():
    walls = WallSet([Cylinder(base=(0.1, 0.2, 0), axis=(1, 0, 0), radius=R,
                              length=math.inf, bottom=True)])
    box = aabb_rows(walls.kind, walls.params)[0]
    assert box[0] == pytest.approx(0.1) and box[3] == math.inf      # along the axis
    np.testing.assert_allclose(box[[1, 2, 4, 5]], [0.2 - R, -R, 0.2 + R, R])
    points, triangles, _ = walls.triangulate()
    assert np.all(np.isfinite(points)) and len(triangles)


def test_sphere_rests_in_an_endless_pipe_far_along_it():
    pipe = Cylinder(base=(-1.0, 0, 0), axis=(1, 0, 0), radius=R, length=math.inf,
                    material=0, name="pipe")
    sim = Simulation([SOFT], Interaction(restitution=0.3), walls=WallSet([pipe]))
    r = 0.005
    sim.add_particles(positions=[[50.0, 0, -R + r], [0.0, 0, -R + r]], radii=r)
    sim.run(duration=0.1)
    m = sim.state.masses.sum()
    force, _ = sim.wall_forces()["pipe"]
    assert force == pytest.approx([0, 0, -m * 9.81], abs=1e-4 * m * 9.81)
    assert sim.state.positions[0, 2] == pytest.approx(-R + r, abs=0.01 * r)


def test_lifted_endless_cylinder_frees_the_fill():
    # a cylinder open at its base, endless upwards, lifted by its base height
    walls = WallSet([Disk(radius=0.1, name="plate"),
                     Cylinder(base=(0, 0, 1e-4), radius=R, length=math.inf,
                              name="cylinder")])
    sim = Simulation([SOFT], Interaction(restitution=0.3), walls=walls)
    sim.add_particles(positions=[[R - 0.004, 0, 0.0041]], radii=0.004, velocities=[0.2, 0, 0])
    sim.run(duration=0.02)
    assert sim.state.positions[0, 0] < R - 0.0039        # held in
    walls.set_motion("cylinder", Translation(velocity=(0, 0, 1.0), start=sim.time))
    sim.run(duration=0.05)
    sim.state.velocities[0, 0] = 0.2
    sim.run(duration=0.05)
    assert sim.state.positions[0, 0] > R                  # rolled out under it


def test_infinite_cylinder_input():
    with pytest.raises(ConfigError, match="infinite length has no top"):
        Cylinder(length=math.inf, top=True)
    for bad in (-1.0, 0.0, math.nan, "long"):
        with pytest.raises(ConfigError, match="cylinder length must be a number > 0"):
            Cylinder(length=bad)
