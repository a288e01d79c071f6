"""``demcal measure repose|incline``: lab measurements from the command line."""

from __future__ import annotations

import json
import math
import sys

from demcal.cli._util import add_command, add_json
from demcal.errors import ConfigError, DataError


def _no_what(parser) -> int:
    """``demcal measure`` alone: the help on stderr and one sentence (exit status 2)."""
    parser.print_help(sys.stderr)
    raise ConfigError("say what to measure: demcal measure repose PHOTO... or demcal measure incline --H ...; "
                      "see demcal measure --help.")


def register(subparsers) -> None:
    measure = add_command(
        subparsers, "measure", lambda args: _no_what(measure),
        help="angle of repose from heap photos; sliding angle from incline readings",
        description="Lab measurements: angle of repose from heap photos, sliding angle from "
                    "inclined-plane readings.")
    sub = measure.add_subparsers(dest="measure_command", metavar="WHAT")

    repose = add_command(
        sub, "repose", _repose, help="angle of repose from heap photos",
        description="Segment each heap photo, trace the heap's outline, fit both flanks by "
                    "robust least squares and report left, right and mean angle; many "
                    "photos give mean +- sd with outliers flagged. A bad photo is reported "
                    "and the others are measured.")
    repose.add_argument("photos", nargs="+", metavar="PHOTO")
    repose.add_argument("--roi", help="region of interest x0,y0,x1,y1 [px] (default: the whole photo)")
    repose.add_argument("--base-y", type=float,
                        help="row of the base line [px] (default: the lowest point of the heap's "
                             "outline away from the photo's side edges)")
    repose.add_argument("--mm-per-px", type=float,
                        help="scale for heights and widths [mm/px] (default: none, so they are in px)")
    repose.add_argument("--band", default="0.1,0.9",
                        help="fit each flank between these fractions of the heap height "
                             "(default 0.1,0.9)")
    repose.add_argument("--out", help="folder for the annotated pictures (<photo>_fit.png, "
                                      "never over a photo) and table.csv")
    repose.add_argument("--workers", type=int, default=1,
                        help="processes (default 1: two threads of one process; 0: one per core)")
    repose.add_argument("--min-r2", type=float, default=None, metavar="R2",
                        help="a photo whose flank fits have a mean R² below this is an error, not an angle "
                             "(default 0.9: a heap's flank is a straight line over most of its height)")
    add_json(repose, "print JSON")

    incline = add_command(
        sub, "incline", _incline, help="sliding angle theta = arcsin(H/L) from ruler readings",
        description="theta = arcsin(H / L) for each reading, and mean +- sd "
                    "(over group means with --repeats).")
    incline.add_argument("--H", dest="H", type=float, nargs="+", required=True, metavar="MM",
                         help="heights of the container's starting point [mm]")
    incline.add_argument("--L", dest="L", type=float, default=300.0, metavar="MM",
                         help="distance from that point to the spindle [mm] (default 300)")
    incline.add_argument("--H0", dest="H0", type=float, default=0.0, metavar="MM",
                         help="height of that point above the base with the plate level [mm] "
                              "(default 0, the paper's Eq. 5: theta = arcsin((H - H0) / L))")
    incline.add_argument("--repeats", type=int, help="readings per group, in order")
    add_json(incline, "print JSON")


def _floats(text: str, count: int, what: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{what} must be {count} comma-separated finite numbers, got '{text}'.")
    return values


def _positive(value: float | None, option: str, unit: str) -> None:
    """Refuse an option's value that is not a positive, finite number of ``unit``."""
    if value is not None and not (math.isfinite(value) and value > 0):
        raise ConfigError(f"{option} must be a positive, finite number of {unit}, got {value}.")


def _repose(args) -> int:
    from pathlib import Path

    from demcal.measure.photo import MIN_R2, measure_photos

    roi = _floats(args.roi, 4, "--roi") if args.roi else None
    band = tuple(_floats(args.band, 2, "--band"))
    if not 0 <= band[0] < band[1] <= 1:
        raise ConfigError(f"--band must be two fractions LOW,HIGH of the heap height with 0 <= LOW < HIGH <= 1 "
                          f"(e.g. 0.1,0.9), got '{args.band}'.")
    _positive(args.mm_per_px, "--mm-per-px", "mm per pixel")
    if args.base_y is not None and not (math.isfinite(args.base_y) and args.base_y >= 0):
        raise ConfigError(f"--base-y must be a row of the photo, a number of pixels >= 0, got {args.base_y}.")
    if args.min_r2 is not None and not 0 <= args.min_r2 < 1:
        raise ConfigError(f"--min-r2 must lie in 0 .. 1 (e.g. 0.9), got {args.min_r2}.")
    workers = args.workers or _cores()
    min_r2 = MIN_R2 if args.min_r2 is None else args.min_r2
    batch = measure_photos(args.photos, roi=roi, base_y=args.base_y, mm_per_px=args.mm_per_px,
                           band=band, out_dir=args.out, workers=workers, min_r2=min_r2)
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        batch.write_csv(Path(args.out) / "table.csv")
    if len(args.photos) == 1 and batch.failures:
        raise DataError(batch.failures[0][1])
    if args.json:
        print(json.dumps(batch.to_dict(), indent=2))
    else:
        for row in batch.rows:
            if row["error"] is None:
                flag = "  OUTLIER" if row["outlier"] else ""
                print(f"{row['photo']}: {row['angle_deg']:.2f} deg (left {row['left_deg']:.2f}, "
                      f"right {row['right_deg']:.2f}, R2 {row['r2']:.3f}){flag}")
            else:
                print(f"{row['photo']}: not measured: {row['error']}")
        s = batch.summary
        if s is not None and s.n > 1:
            print(f"angle of repose {s.mean:.2f} +- {s.sd:.2f} deg over {s.n} photos "
                  f"(95 % CI {s.ci_low:.2f}..{s.ci_high:.2f})")
    for photo, sentence in batch.failures:
        print(f"demcal: warning: {sentence}", file=sys.stderr)
    if batch.summary is None:
        raise DataError(f"none of the {len(args.photos)} photos could be measured.")
    return 0


def _cores() -> int:
    import os

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _incline(args) -> int:
    from demcal.measure.incline import measure_incline

    _positive(args.L, "--L", "mm (the distance from the starting point to the spindle)")
    if not (math.isfinite(args.H0) and args.H0 >= 0):
        raise ConfigError(f"--H0 must be a finite number of mm >= 0 (0: the paper's Eq. 5), got {args.H0}.")
    if args.repeats is not None and args.repeats < 1:
        raise ConfigError(f"--repeats must be at least 1 reading per group, got {args.repeats}.")
    m = measure_incline(args.H, args.L, args.repeats, args.H0)
    if args.json:
        print(json.dumps(m.to_dict(), indent=2))
        return 0
    for i, (h, a) in enumerate(zip(args.H, m.angles_deg), 1):
        print(f"reading {i}: H = {h:g} mm -> theta = {a:.2f} deg")
    over = "group means" if m.group_means_deg is not None else "readings"
    sd = f" +- {m.sd_deg:.2f}" if m.n > 1 else ""
    level = f", H0 = {args.H0:g} mm" if args.H0 else ""
    print(f"sliding angle {m.mean_deg:.2f}{sd} deg over {m.n} {over} (L = {args.L:g} mm{level})")
    return 0
