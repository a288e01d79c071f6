"""Drawing of flank fits, shared by the heap and photo pictures."""

from __future__ import annotations

import numpy as np

from demcal.measure.flank import OutlineFit

_COLOURS = {"left": "tab:blue", "right": "tab:red"}


def draw_flanks(ax, fit: OutlineFit, scale: float = 1.0, base: float = 0.0,
                z_sign: float = 1.0, z_origin: float = 0.0, x_origin: float = 0.0) -> None:
    """Draw the band's edge points (inliers filled, rejected as crosses) and each fitted
    line from the base to the apex height, labelled with its angle.

    Plot coordinates are ``x_origin + scale * x`` and ``z_origin + z_sign * scale * z``
    (``z_sign = -1`` for image rows, which grow downwards).
    """
    for flank in (fit.left, fit.right):
        colour = _COLOURS[flank.side]
        px = x_origin + scale * flank.x
        pz = z_origin + z_sign * scale * flank.z
        ax.plot(px[flank.inlier], pz[flank.inlier], ".", ms=2.5, color=colour)
        if not flank.inlier.all():
            ax.plot(px[~flank.inlier], pz[~flank.inlier], "x", ms=3, color="orange")
        # the fitted line from the base line to the top of the heap
        z_lo, z_hi = base / scale, base / scale + fit.height
        if flank.slope != 0:
            x_line = (np.array([z_lo, z_hi]) - flank.intercept) / flank.slope
        else:
            x_line = np.array([flank.x.min(), flank.x.max()])
        ax.plot(x_origin + scale * x_line, z_origin + z_sign * scale * np.array([z_lo, z_hi]),
                "-", lw=1.3, color=colour)
        ax.annotate(f"{flank.side} {flank.angle_deg:.2f}°\nR² {flank.r2:.3f}",
                    (x_origin + scale * x_line[0], z_origin + z_sign * scale * z_lo),
                    textcoords="offset points", xytext=(-40 if flank.side == "left" else 5, 8),
                    fontsize=8, color=colour)
