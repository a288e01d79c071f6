"""Small builders shared by the engine tests."""

import math

import numpy as np
import pytest

from demcal.dem import Simulation
from demcal.dem.cuda.backend import numba_cuda_installed
from demcal.dem.reporters import Reporter
from demcal.geometry import Plane, WallSet
from demcal.particles.materials import Interaction, Material

RADIUS = 0.005          # [m]
GLASS = Material(density=2500.0, shear_modulus=1.0e8, poisson_ratio=0.3,
                 yield_strength=1.0e7, name="glass")
WALL = Material(density=2500.0, shear_modulus=1.0e8, poisson_ratio=0.3,
                yield_strength=1.0e7, name="wall")


def sphere_mass(r=RADIUS, rho=GLASS.density):
    return 4.0 / 3.0 * math.pi * r ** 3 * rho


class Trace(Reporter):
    """Record a function of the simulation every step."""

    def __init__(self, fn, interval=1):
        super().__init__(interval)
        self.fn = fn
        self.rows = []

    def report(self, sim):
        self.rows.append(self.fn(sim))


def floor(material=1, **kw):
    return WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), material=material, name="floor",
                          **kw)])


SOFT = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3,
                yield_strength=1.0e6, name="soft")
SOFT_WALL = Material(density=2500.0, shear_modulus=1.0e7, poisson_ratio=0.3,
                     yield_strength=1.0e6, name="soft_wall")


def tilted_gravity(theta, g=9.81):
    """Gravity of a plane z = 0 tilted by theta about the y axis: exact and cheap."""
    return np.array([g * math.sin(theta), 0.0, -g * math.cos(theta)])


#: Marks a test that needs numba-cuda (its simulator runs the cuda backend without a GPU).
needs_numba_cuda = pytest.mark.skipif(not numba_cuda_installed(),
                                      reason="numba-cuda not installed (demcal[cuda])")
