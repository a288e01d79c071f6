"""The dynamic angle of repose of a bed turning in a rotating drum.

The drum's axis is y, its centre the origin. In a frame, the bed is the largest cluster
of touching spheres that reaches the drum's bottom (:func:`demcal.measure.heap.heap_members`:
particles in flight in a cataracting drum are left out). Seen along the axis, the bed's
top outline (:func:`~demcal.measure.heap.upper_envelope`) runs from wall to wall; the
free surface is its central part, between ``band`` fractions of the outline's width (the
ends curl up or down against the shell), where a least-squares line with outlier
rejection (:func:`demcal.measure.flank.fit_line`, the heaps' flank fit) gives the angle
to the horizontal.

The regime follows the Froude number Fr = omega^2 R / g (Mellmann, "The transverse
motion of solids in rotating cylinders -- forms of motion and transition behavior",
Powder Technology 118, 2001, 251-270, Fig. 2 and Table 1): slumping below 1e-4,
rolling 1e-4 to 1e-2, cascading 1e-2 to 0.1, cataracting 0.1 to 1, centrifuging from 1.
Mellmann's ranges overlap (the boundaries move with the fill and the wall friction);
these are the middles of his transitions, a label for the reader, not a measurement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from demcal.errors import DataError
from demcal.measure.flank import fit_line
from demcal.measure.heap import heap_members, upper_envelope

#: Regimes by Froude number: (upper bound, name), in order (Mellmann 2001).
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
    """One frame's free surface: its angle [deg] to the horizontal, the fit's R^2, and the
    outline and line for a picture."""

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
    u, z, r = positions[bed, 0], positions[bed, 2], radii[bed]
    pixel = max(float(r.min()) / 4.0, 2.0 * drum_radius / 2000.0)
    x, top = upper_envelope(u, z, r, pixel)
    lo, hi = float(x.min()), float(x.max())
    keep = (x >= lo + band[0] * (hi - lo)) & (x <= lo + band[1] * (hi - lo))
    fit = fit_line(x[keep], top[keep], side="left")
    return SurfaceFit(angle_deg=abs(fit.angle_deg), r2=fit.r2, x=x, z=top, slope=fit.slope,
                      intercept=fit.intercept, band=(lo + band[0] * (hi - lo), lo + band[1] * (hi - lo)))


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
