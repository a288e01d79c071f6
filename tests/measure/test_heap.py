"""Heap measurement: synthetic particle cones of known angle (issue 4, acceptance 4)."""

import numpy as np
import pytest

from demcal.errors import DemcalError
from demcal.measure.heap import measure_heap
from demcal.measure.synthetic import particle_cone


@pytest.mark.parametrize("angle", [20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0])
def test_cone_of_known_angle_is_recovered_within_half_a_degree(angle):
    positions, radii = particle_cone(angle, base_radius=0.1, radius=0.0025, seed=int(angle))
    m = measure_heap(positions, radii, base_z=0.0, views=8)
    assert m.angle_deg == pytest.approx(angle, abs=0.5)
    assert m.spread_deg < 0.5
    assert m.r2 > 0.99
    # views phi = k * 180 deg / views (module docstring)
    assert [v.view_deg for v in m.views] == pytest.approx([k * 22.5 for k in range(8)])
    # the comparison measures, recomputed from all the particles (the few left out are
    # lone lattice spheres deep inside, which change none of H, D and z_com noticeably);
    # per view the silhouette's width is max(u + r) - min(u - r), u = x cos(phi) + y sin(phi)
    assert m.n_particles + m.n_dropped == len(radii) and m.n_dropped <= 0.001 * len(radii)
    height = (positions[:, 2] + radii).max()
    assert m.height == pytest.approx(height, rel=1e-12)
    pixel = radii.min() / 4  # PIXELS_PER_RADIUS: the width is rounded out to whole columns
    widths = []
    for k, view in enumerate(m.views):
        phi = np.pi * k / 8
        u = positions[:, 0] * np.cos(phi) + positions[:, 1] * np.sin(phi)
        widths.append((u + radii).max() - (u - radii).min())
        assert widths[-1] - 1e-12 <= view.diameter <= widths[-1] + 2 * pixel + 1e-12
    mass = radii**3
    z_com = (mass * positions[:, 2]).sum() / mass.sum()
    # atan(2 H / D) and atan(4 z_com / R), R = D / 2, for D between the exact mean width
    # and that plus the column rounding (0.02 deg for the lone spheres' share of z_com)
    for measured, tan_of_d in ((m.h_over_d_angle_deg, lambda d: 2 * height / d),
                               (m.com_cone_angle_deg, lambda d: 4 * z_com / (d / 2))):
        low, high = (np.degrees(np.arctan(tan_of_d(d))) for d in (np.mean(widths) + 2 * pixel, np.mean(widths)))
        assert low - 0.02 <= measured <= high + 0.02
    # and they are in the neighbourhood of the true angle, not exact
    assert abs(m.h_over_d_angle_deg - angle) < 4.0
    assert abs(m.com_cone_angle_deg - angle) < 6.0


def test_offset_cone_on_raised_base_and_png(tmp_path):
    positions, radii = particle_cone(32.0, base_radius=0.08, radius=0.002, seed=1,
                                     base_z=0.05, centre_xy=(0.3, -0.2))
    png = tmp_path / "heap.png"
    m = measure_heap(positions, radii, base_z=0.05, views=4, png=png)
    assert m.angle_deg == pytest.approx(32.0, abs=0.5)
    assert png.stat().st_size > 10_000
    assert m.png == str(png)
    assert m.to_dict()["views"][0]["left"]["angle_deg"] == m.views[0].left.angle_deg


def test_same_heap_same_angle_to_the_last_digit():
    positions, radii = particle_cone(38.0, base_radius=0.06, radius=0.002, seed=5)
    a = measure_heap(positions, radii, views=3).angle_deg
    b = measure_heap(positions.copy(), radii.copy(), views=3).angle_deg
    assert a == b


def test_particles_in_flight_or_fallen_off_are_left_out():
    positions, radii = particle_cone(30.0, base_radius=0.06, radius=0.002, seed=2)
    clean = measure_heap(positions, radii, views=4)
    top = positions[:, 2].max()
    extra = np.array([[0.0, 0.0, top + 0.05],     # in flight above the apex
                      [0.2, 0.0, 0.002],          # rolled away on the plate
                      [0.5, 0.0, -0.3]])          # fallen off the plate
    m = measure_heap(np.vstack([positions, extra]), np.r_[radii, [0.002] * 3], views=4)
    assert m.angle_deg == clean.angle_deg
    assert m.height == clean.height
    assert m.n_dropped == clean.n_dropped + 3


def test_no_particles_is_refused():
    with pytest.raises(DemcalError, match="no heap"):
        measure_heap(np.zeros((0, 3)), np.zeros(0))
    with pytest.raises(DemcalError, match="none of the 2 particles lies on the base"):
        measure_heap([[0, 0, -1.0], [0, 0, -2.0]], [0.01, 0.01])


def test_flat_layer_is_refused():
    g = np.arange(-0.1, 0.1, 0.0036)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    positions = np.column_stack([x, y, np.full(x.size, 0.002)])
    with pytest.raises(DemcalError, match="flat layer"):
        measure_heap(positions, np.full(x.size, 0.002))


def test_heap_reaching_the_plate_edge_is_refused():
    positions, radii = particle_cone(30.0, base_radius=0.06, radius=0.002, seed=2)
    measure_heap(positions, radii, views=2, plate_radius=0.08)  # fits on the plate
    with pytest.raises(DemcalError, match="edge of the base plate"):
        measure_heap(positions, radii, views=2, plate_radius=0.04)
