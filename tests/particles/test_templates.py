"""Mass properties of multi-sphere templates against closed forms.

References
----------
* Volume of the lens (intersection) of two spheres of radii R, r at distance d, and the
  height of the plane of intersection: E. W. Weisstein, "Sphere-Sphere Intersection",
  MathWorld, https://mathworld.wolfram.com/Sphere-SphereIntersection.html (eqs. 8, 16).
* Volume pi h^2 (3R - h) / 3 of a spherical cap of height h and the distance
  3 (2R - h)^2 / (4 (3R - h)) of its centroid from the sphere centre: standard results,
  e.g. MathWorld "Spherical Cap" and Beer & Johnston, Vector Mechanics for Engineers,
  Appendix (centroids of common volumes).
* Inertia of the union of two spheres: the union is a solid of revolution whose cross
  section at axial position z is the disc of radius max(rho_1(z), rho_2(z)); with
  rho_i^2 polynomial in z, the axial moment int pi rho^4 / 2 dz and the transverse
  moment int (pi rho^4 / 4 + pi rho^2 z^2) dz are integrated exactly (numpy polynomials).
"""

import math
import re

import numpy as np
import pytest
from numpy.polynomial import Polynomial as P

from demcal.errors import ConfigError
from demcal.particles.templates import (
    PAPER_OFFSET,
    PAPER_RADII,
    ParticleTemplate,
    mass_properties,
    sphere,
    two_sphere_paper,
)

from sentences import one_sentence


def lens_volume(R, r, d):
    """MathWorld Sphere-Sphere Intersection, eq. (16)."""
    return math.pi * (R + r - d) ** 2 * (d * d + 2 * d * r - 3 * r * r + 2 * d * R + 6 * r * R - 3 * R * R) / (12 * d)


def cap(R, h):
    """Volume and centroid distance from the sphere centre of a cap of height h."""
    return math.pi * h * h * (3 * R - h) / 3, 3 * (2 * R - h) ** 2 / (4 * (3 * R - h))


def two_sphere_reference(R, r, d):
    """Union volume and centroid (on the axis, sphere R at 0, sphere r at d) by caps."""
    x = (d * d - r * r + R * R) / (2 * d)  # MathWorld eq. (8): plane of intersection
    v1, c1 = cap(R, R - x)  # cap of sphere R beyond the plane, centroid at +c1
    v2, c2 = cap(r, r - (d - x))  # cap of sphere r before the plane, centroid at d - c2
    lens = v1 + v2
    assert lens == pytest.approx(lens_volume(R, r, d), rel=1e-12)
    vs1 = 4 / 3 * math.pi * R**3
    vs2 = 4 / 3 * math.pi * r**3
    vol = vs1 + vs2 - lens
    com = (vs2 * d - (v1 * c1 + v2 * (d - c2))) / vol
    return vol, com


def two_sphere_inertia(R, r, d):
    """Exact (axial, transverse) inertia per unit density about the centroid."""
    x = (d * d - r * r + R * R) / (2 * d)
    rho1 = P([R * R, 0, -1])  # rho^2 of sphere R: R^2 - z^2
    rho2 = P([r * r - d * d, 2 * d, -1])  # r^2 - (z - d)^2
    z = P([0, 1])
    pieces = [(rho1, -R, x), (rho2, x, d + r)]
    vol = sum((math.pi * q).integ()(b) - (math.pi * q).integ()(a) for q, a, b in pieces)
    mz = sum((math.pi * q * z).integ()(b) - (math.pi * q * z).integ()(a) for q, a, b in pieces)
    com = mz / vol
    axial = sum((math.pi / 2 * q * q).integ()(b) - (math.pi / 2 * q * q).integ()(a) for q, a, b in pieces)
    zc = z - com
    transverse = sum(
        (math.pi / 4 * q * q + math.pi * q * zc * zc).integ()(b) - (math.pi / 4 * q * q + math.pi * q * zc * zc).integ()(a)
        for q, a, b in pieces
    )
    return vol, com, axial, transverse


def test_references_agree_with_each_other():
    R, r = PAPER_RADII
    vol, com = two_sphere_reference(R, r, PAPER_OFFSET)
    vol2, com2, _, _ = two_sphere_inertia(R, r, PAPER_OFFSET)
    assert vol2 == pytest.approx(vol, rel=1e-12) and com2 == pytest.approx(com, rel=1e-12)


def test_single_sphere_exact():
    t = sphere(0.003)
    assert t.volume == pytest.approx(4 / 3 * math.pi * 0.003**3, rel=1e-14)
    assert t.inertia_per_density == pytest.approx(np.full(3, 8 / 15 * math.pi * 0.003**5), rel=1e-14)
    assert t.centers == pytest.approx(np.zeros((1, 3))) and t.bounding_radius == pytest.approx(0.003)


def test_paper_two_sphere_unit_against_closed_form():
    R, r = PAPER_RADII
    d = PAPER_OFFSET
    t = two_sphere_paper()
    vol, com = two_sphere_reference(R, r, d)
    _, _, axial, transverse = two_sphere_inertia(R, r, d)
    # acceptance: within 1 %; the method does far better (documented 2e-5)
    assert t.volume == pytest.approx(vol, rel=2e-5)
    assert t.centre_of_mass == pytest.approx([com, 0.0, 0.0], abs=2e-5 * d)
    assert t.inertia_per_density == pytest.approx([axial, transverse, transverse], rel=2e-5)
    # principal frame: the symmetry axis (smallest moment) is x, COM at the origin
    assert abs(t.rotation[0, 0]) == pytest.approx(1.0)
    assert t.centers[:, 1:] == pytest.approx(np.zeros((2, 2)), abs=1e-12)
    assert abs(t.centers[1, 0] - t.centers[0, 0]) == pytest.approx(d)
    weights = t.radii**3  # the COM lies between the centres, nearer the big sphere
    assert np.sign(t.centers[np.argmax(weights), 0]) != np.sign(t.centers[np.argmin(weights), 0])
    assert t.bounding_radius == pytest.approx(max(abs(t.centers[0, 0]) + R, abs(t.centers[1, 0]) + r))


def test_overlap_is_not_double_counted():
    R, r = PAPER_RADII
    t = two_sphere_paper()
    naive = 4 / 3 * math.pi * (R**3 + r**3)
    assert t.volume < naive - 0.9 * lens_volume(R, r, PAPER_OFFSET)


@pytest.mark.parametrize("offset", [0.0015, 0.003, 0.0085])
def test_other_offsets(offset):
    R, r = PAPER_RADII
    t = two_sphere_paper(offset=offset)
    vol, com, axial, transverse = two_sphere_inertia(R, r, offset)
    assert t.volume == pytest.approx(vol, rel=1e-4)
    assert t.inertia_per_density == pytest.approx(sorted([axial, transverse, transverse]), rel=1e-4)


def test_separate_spheres_parallel_axis():
    """Two disjoint spheres: exact by the parallel-axis theorem."""
    r = 0.5
    props = mass_properties([[-1, 0, 0, r], [1, 0, 0, r]], resolution=512)
    v1 = 4 / 3 * math.pi * r**3
    assert props.volume == pytest.approx(2 * v1, rel=1e-4)
    i0 = 0.4 * v1 * r * r
    assert props.principal_moments == pytest.approx([2 * i0, 2 * (i0 + v1), 2 * (i0 + v1)], rel=1e-4)


def test_rotated_input_gives_same_principal_moments():
    rng = np.random.default_rng(3)
    spheres = np.column_stack([rng.uniform(-1, 1, (4, 3)), rng.uniform(0.4, 0.8, 4)])
    a = ParticleTemplate.from_spheres(spheres)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    rotated = spheres.copy()
    rotated[:, :3] = spheres[:, :3] @ q.T + [3.0, -2.0, 1.0]
    b = ParticleTemplate.from_spheres(rotated)
    assert b.volume == pytest.approx(a.volume, rel=5e-4)
    assert b.inertia_per_density == pytest.approx(a.inertia_per_density, rel=2e-3)
    assert np.linalg.det(b.rotation) == pytest.approx(1.0)
    # in the principal frame the template's own inertia tensor is diagonal, COM at 0
    again = mass_properties(b.spheres)
    assert again.centre_of_mass == pytest.approx(np.zeros(3), abs=1e-3)
    off = again.inertia_tensor - np.diag(np.diag(again.inertia_tensor))
    assert np.abs(off).max() < 2e-3 * again.principal_moments.max()


def test_scaling_laws():
    t = two_sphere_paper()
    s = t.scaled(1.5)
    assert s.volume == pytest.approx(t.volume * 1.5**3)
    assert s.inertia_per_density == pytest.approx(t.inertia_per_density * 1.5**5)
    assert s.radii == pytest.approx(t.radii * 1.5) and s.bounding_radius == pytest.approx(1.5 * t.bounding_radius)
    assert t.mass(2650.0) == pytest.approx(2650.0 * t.volume)
    direct = two_sphere_paper(radii=(0.006, 0.0075), offset=0.0105)
    assert direct.inertia_per_density == pytest.approx(s.inertia_per_density, rel=1e-4)


def test_bad_templates_are_explained():
    assert one_sentence(lambda: ParticleTemplate.from_spheres([[0, 0, 0, -1.0]])) == (
        "every sphere of a particle template needs a radius > 0 [m].")
    assert one_sentence(lambda: ParticleTemplate.from_spheres([[0, 0, 0]])) == (
        "a particle template needs spheres as a (k, 4) array of x, y, z, radius.")
    # the upper bound r1 + r2 = 9 mm is printed as a float sum (0.009000000000000001)
    assert re.fullmatch(r"two-sphere offset must be in \[0, 0\.009\d*\) m so the spheres overlap, "
                        r"got 0\.01\.", one_sentence(lambda: two_sphere_paper(offset=0.01)))
    assert one_sentence(lambda: sphere(0.001).scaled(0.0)) == "a template scale factor must be > 0, got 0.0."


def test_sphere_inside_another_counts_once():
    props = mass_properties([[0, 0, 0, 0.005], [0.0005, 0, 0, 0.004]])
    assert props.volume == pytest.approx(4 / 3 * math.pi * 0.005**3, rel=1e-4)
