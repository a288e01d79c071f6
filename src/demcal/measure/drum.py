"""The dynamic angle of repose of a bed turning in a rotating drum.

The drum's axis is y, its centre the origin. In a frame, the bed is the largest cluster
of touching spheres that reaches the drum's bottom (:func:`demcal.measure.heap.heap_members`:
particles in flight in a cataracting drum are left out). The outline is taken in the bed's
own frame: a bed whose free surface is a chord of the drum has its centroid on the
chord's perpendicular through the drum's centre, so the direction from the bed's centroid
to the centre is the surface's mean normal, at any fill. Seen along the axis, the bed's
outer outline along that normal (:func:`~demcal.measure.heap.upper_envelope` in the
rotated frame) runs from wall to wall; the free surface is its central part, between
``band`` fractions of the outline's length (the ends curl against the shell), where a
least-squares line with outlier rejection (:func:`demcal.measure.flank.fit_line`, the
heaps' flank fit) gives the surface's tilt from the mean direction; the angle to the
horizontal is the two together. A steep bed (above 60 deg, as a coarse bed carried up a
rough shell stands) has no single-valued top outline seen from above, and an outline
read from above fits whichever ledge of it the band falls on; seen along its own normal,
the surface is a shallow line for any angle.

The regime is a label from the Froude number Fr = omega^2 R / g alone, after Mellmann,
"The transverse motion of solids in rotating cylinders -- forms of motion and transition
behavior", Powder Technology 118 (2001) 251-270, Table 1 (:data:`MELLMANN_FROUDE`):
slipping 0-1e-4, slumping 1e-5-1e-3, rolling 1e-4-1e-2, cascading 1e-3-0.1, cataracting
0.1-1, centrifuging from 1. His ranges overlap: within an overlap the filling degree, the
wall friction and the particle-to-drum size ratio decide, which a Froude number cannot.
:data:`REGIMES` gives rolling its whole published band (1e-4 to 1e-2), slumping what lies
below it and cascading what lies above it up to cataracting, so every label lies inside the
published range of its regime for Fr >= 1e-5 (below, Mellmann lists slumping from 1e-5 and
slipping, a bed sliding on a smooth wall, which no Froude number tells apart). A label for
the reader, not a measurement of the bed's motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from demcal.errors import DataError
from demcal.measure.flank import fit_line
from demcal.measure.heap import heap_members, upper_envelope

#: Mellmann (2001), Table 1: the Froude-number range (low, high) of each form of
#: transverse motion; the ranges overlap (module docstring).
MELLMANN_FROUDE = {"slipping": (0.0, 1e-4), "slumping": (1e-5, 1e-3), "rolling": (1e-4, 1e-2),
                   "cascading": (1e-3, 0.1), "cataracting": (0.1, 1.0), "centrifuging": (1.0, math.inf)}
#: Regimes by Froude number: (upper bound, name), in order; each label inside its
#: :data:`MELLMANN_FROUDE` range for Fr >= 1e-5.
REGIMES = ((1e-4, "slumping"), (1e-2, "rolling"), (0.1, "cascading"), (1.0, "cataracting"),
           (math.inf, "centrifuging"))
G = 9.81


def froude(rpm: float, radius: float, g: float = G) -> float:
    """Fr = omega^2 R / g of a drum of ``radius`` [m] turning at ``rpm``."""
    omega = 2.0 * math.pi * rpm / 60.0
    return omega * omega * radius / g


def regime(fr: float) -> tuple[int, str]:
    """``(index, name)`` of the regime at Froude number ``fr`` (:data:`REGIMES`)."""
    for i, (upper, name) in enumerate(REGIMES):
        if fr < upper:
            return i, name
    return len(REGIMES) - 1, REGIMES[-1][1]


@dataclass(frozen=True)
class SurfaceFit:
    """One frame's free surface: its angle [deg] to the horizontal, the band outline's R^2
    about the line (1 - squared distances across the line / squared distances from the
    band's centroid: free of the line's direction), and the outline (``x``, ``z`` [m]) and
    line (``slope``, ``intercept``, ``band``: its ends' x [m]) for a picture."""

    angle_deg: float
    r2: float
    x: np.ndarray
    z: np.ndarray
    slope: float
    intercept: float
    band: tuple[float, float]


def surface_angle(positions, radii, drum_radius: float, band=(0.25, 0.75)) -> SurfaceFit:
    """The free-surface angle of the bed in one frame (module docstring): sphere centres
    ``positions (n, 3)`` [m] and ``radii (n,)`` [m] in the drum's frame of reference."""
    positions = np.asarray(positions, float)
    radii = np.asarray(radii, float)
    if positions.shape[0] < 10:
        raise DataError(f"the drum holds only {positions.shape[0]} spheres; a surface needs at least 10.")
    bed = heap_members(positions, radii, base_z=-drum_radius)
    p, r = positions[bed][:, [0, 2]], radii[bed]
    centroid = np.average(p, axis=0, weights=r ** 3)
    off = float(np.hypot(*centroid))
    # the surface's mean normal points from the bed's centroid to the drum's centre (up
    # for a bed at rest); a bed centred on the axis (a full drum) has none: then up
    normal = -centroid / off if off > 1e-3 * drum_radius else np.array([0.0, 1.0])
    along = np.array([normal[1], -normal[0]])
    u, h = p @ along, p @ normal
    pixel = max(float(r.min()) / 4.0, 2.0 * drum_radius / 2000.0)
    s, top = upper_envelope(u, h, r, pixel)
    lo, hi = float(s.min()), float(s.max())
    ends = (lo + band[0] * (hi - lo), lo + band[1] * (hi - lo))
    keep = (s >= ends[0]) & (s <= ends[1])
    fit = fit_line(s[keep], top[keep], side="left")
    tilt = math.atan2(along[1], along[0]) + math.atan(fit.slope)
    # outline and line back in the drum's frame (x, z)
    xz = np.outer(s, along) + np.outer(top, normal)
    line = np.array([e * along + (fit.intercept + fit.slope * e) * normal for e in ends])
    slope = math.tan(tilt)
    intercept = float(line[0, 1] - slope * line[0, 0])
    # R^2 free of the line's direction: squared distances across the line against those
    # from the band outline's centroid
    sb, hb = s[keep], top[keep]
    across = float(np.sum((hb - fit.intercept - fit.slope * sb) ** 2)) / (1.0 + fit.slope ** 2)
    spread = float(np.sum((sb - sb.mean()) ** 2 + (hb - hb.mean()) ** 2))
    r2 = 1.0 - across / spread if spread > 0 else 0.0
    return SurfaceFit(angle_deg=abs(math.degrees(tilt)), r2=r2, x=xz[:, 0], z=xz[:, 1], slope=slope,
                      intercept=intercept, band=(float(line[0, 0]), float(line[1, 0])))


def plot_surface(fit: SurfaceFit, positions, radii, drum_radius: float, path, title: str | None = None) -> None:
    """The bed seen along the drum's axis with the fitted surface line, to ``path`` (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    from demcal._files import save_figure

    fig = Figure(figsize=(4.5, 4.5))
    ax = fig.add_subplot()
    ax.add_patch(Circle((0, 0), drum_radius * 1e3, fill=False, color="0.3"))
    ax.scatter(np.asarray(positions)[:, 0] * 1e3, np.asarray(positions)[:, 2] * 1e3, s=2, color="0.55")
    xs = np.array(fit.band)
    ax.plot(xs * 1e3, (fit.intercept + fit.slope * xs) * 1e3, color="C3",
            label=f"surface {fit.angle_deg:.1f}°")
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("z [mm]")
    ax.legend(loc="upper right")
    if title:
        ax.set_title(title)
    save_figure(fig, path, dpi=110)
