"""``demcal bench NAME``: run one virtual bench test from the command line.

::

    demcal bench NAME [--profile tiny|quick|paper|medium (incline)] [--set KEY=VALUE ...] [--seed N]
                      [--out DIR] [--vtk] [--json]
    demcal bench NAME --help      # every KEY with its default and unit
    demcal bench --list           # the tests

With ``--json`` the result is printed as one JSON object::

    {"test": .., "responses": {"repose_angle_deg": ..}, "spread": {..}, "particles": ..,
     "steps": .., "simulated_s": .., "wall_s": .., "particle_steps_per_s": ..}

(plus ``"artifacts"``: the pictures written). A bad test name, key or value, or a
geometry the particles cannot fit in, is reported in one sentence with exit status 2.
"""

from __future__ import annotations

import json
import sys

from demcal.cli._util import add_command, add_json
from demcal.errors import ConfigError

#: demcal's own tests, for the help text without importing the benches
#: (tests/bench/test_bench_cli.py checks it against the registry).
_TESTS = ("repose-funnel", "repose-cylinder", "incline", "impact", "drum")


def register(subparsers) -> None:
    parser = add_command(
        subparsers, "bench", run,
        help="run a virtual bench test (angle of repose, inclined plane, impact)",
        description="Run one virtual bench test and print its measured response. "
                    "`demcal bench NAME --help` lists the test's settings.",
        add_help=False,
    )
    parser.add_argument("name", nargs="?", metavar="NAME",
                        help=f"the test: {', '.join(_TESTS)}, a plug-in's, or several joined by + "
                             "(a joint test: repose-funnel+drum)")
    parser.add_argument("--profile", default="quick",
                        help="tiny (seconds), quick (default; 10-40 s), paper (the paper's scale), or a test's "
                             "own: the incline's medium (about 25 s; within 1 deg of paper)")
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                        help="override a setting (repeatable); see `demcal bench NAME --help`")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--backend", default="cpu", choices=("cpu", "cuda"),
                        help="compute backend (cuda: numba-cuda and an NVIDIA GPU)")
    parser.add_argument("--out", metavar="DIR", help="folder for the pictures (heap PNG) and VTK files")
    parser.add_argument("--vtk", action="store_true", help="also write VTK files of the run (needs --out)")
    add_json(parser, "print the result as JSON")
    parser.add_argument("--list", action="store_true", help="list the tests and exit")
    parser.add_argument("-h", "--help", action="store_true", help="show this help (with NAME: its settings)")
    parser.set_defaults(_parser=parser)


def parse_sets(items) -> dict:
    """``["KEY=VALUE", ...]`` -> ``{KEY: VALUE}`` (values stay strings; the test converts)."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise ConfigError(f"--set expects KEY=VALUE, got '{item}'.")
        out[key] = value
    return out


def settings_rows(experiment, profile: str) -> list[tuple[str, str, str, str, str]]:
    """``(key, default, unit, allowed, description)`` of every setting of a test, as text
    (what `demcal bench NAME --help` and docs/guide.md show)."""
    rows = []
    for key, s in experiment.settings(profile).items():
        if s.choices:
            allowed = "|".join(s.choices)
        elif s.low is not None or s.high is not None:
            allowed = f"[{'' if s.low is None else f'{s.low:g}'}, {'' if s.high is None else f'{s.high:g}'}]"
        else:
            allowed = ""
        default = f"{s.default:g}" if isinstance(s.default, float) else str(s.default)
        rows.append((key, default, s.unit, allowed, s.help))
    return rows


def settings_help(experiment, profile: str) -> str:
    """The settings table of a test: key, default, unit, allowed range, description."""
    rows = settings_rows(experiment, profile)
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    w2 = max(len(r[2]) for r in rows)
    w3 = max(len(r[3]) for r in rows)
    lines = [f"demcal bench {experiment.name}: {experiment.description}.",
             f"responses: {', '.join(experiment.responses)}; profiles: {', '.join(experiment.profiles)}",
             "",
             f"settings (--set KEY=VALUE), defaults of the '{profile}' profile:",
             f"  {'KEY'.ljust(w0)}  {'DEFAULT'.ljust(w1)}  {'UNIT'.ljust(w2)}  {'ALLOWED'.ljust(w3)}  DESCRIPTION"]
    for key, default, unit, allowed, text in rows:
        lines.append(f"  {key.ljust(w0)}  {default.ljust(w1)}  {unit.ljust(w2)}  {allowed.ljust(w3)}  {text}")
    return "\n".join(lines)


def run(args) -> int:
    from demcal.bench.registry import get_experiment, names

    if args.list or (args.name is None and not args.help):
        for name in names():
            print(f"{name:18s} {get_experiment(name).description}")
        return 0
    if args.name is None:
        args._parser.print_help()
        return 0
    experiment = get_experiment(args.name)
    if args.help:
        args._parser.print_help()
        print()
        if args.profile not in experiment.profiles:
            raise ConfigError(f"unknown profile '{args.profile}' for {experiment.name}; choose one of: "
                              f"{', '.join(experiment.profiles)}.")
        print(settings_help(experiment, args.profile))
        return 0
    if args.vtk and not args.out:
        raise ConfigError("--vtk needs --out DIR to write the files to.")
    overrides = parse_sets(args.sets)
    from demcal.bench.registry import resolve_settings

    resolve_settings(experiment, overrides, args.profile)  # fail fast on bad keys and values
    from demcal.bench.common import on_backend
    from demcal.dem.backend import BACKENDS

    BACKENDS[args.backend].prepare()  # fail fast: one sentence when cuda is missing
    with on_backend(args.backend):
        result = experiment.run(overrides, seed=args.seed, profile=args.profile,
                                out_dir=args.out, vtk=args.vtk, progress=not args.json)
    data = result.to_dict()
    if args.json:
        print(json.dumps(data))
        return 0
    print(f"{data['test']} ({args.profile}, seed {args.seed}):")
    for key, value in data["responses"].items():
        spread = data["spread"].get(key)
        extra = f"  (spread {spread:.3g})" if spread is not None else ""
        print(f"  {key:28s} {value:.4f}{extra}")
    print(f"  {data['particles']} particles, {data['steps']} steps, {data['simulated_s']:.3f} s simulated "
          f"in {data['wall_s']:.1f} s ({data['particle_steps_per_s']:.3g} particle-steps/s)")
    for key, path in data.get("artifacts", {}).items():
        print(f"  {key}: {path}")
    sys.stdout.flush()
    return 0
