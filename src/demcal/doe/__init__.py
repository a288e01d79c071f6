"""Designs of experiments and factor coding.

Generators (pure functions returning coded matrices): :func:`box_behnken`,
:func:`central_composite`, :func:`full_factorial`, :func:`fractional_factorial`,
:func:`plackett_burman`, :func:`steepest_ascent`. A :class:`Design` binds a matrix to
named :class:`Factor` objects, converts coded <-> actual levels and randomises the run
order; :mod:`demcal.doe.io` reads and writes design CSV files.
"""

from demcal._lazy import lazy_exports

__all__ = [
    "Design", "Factor", "parse_factor", "coded_factors", "default_names",
    "box_behnken", "central_composite", "ccd_alpha", "full_factorial",
    "fractional_factorial", "plackett_burman", "steepest_ascent",
    "BOX_BEHNKEN_BLOCKS", "BOX_BEHNKEN_RUNS", "read_design_csv", "write_design_csv",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "design": ["Design"],
    "designs": ["BOX_BEHNKEN_BLOCKS", "BOX_BEHNKEN_RUNS", "box_behnken", "ccd_alpha",
                "central_composite", "fractional_factorial", "full_factorial", "plackett_burman",
                "steepest_ascent"],
    "factors": ["Factor", "coded_factors", "default_names", "parse_factor"],
    "io": ["read_design_csv", "write_design_csv"],
})
