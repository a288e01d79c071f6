"""docs/dem.md: its example of a case of one's own runs (shortened), and its table of
defaults names every default the code has, with the code's value."""

import dataclasses
import inspect
import math
import re
from pathlib import Path

import numpy as np
import pytest

from demcal.dem import GravityRamp, GravityRotation, Simulation
from demcal.dem.threads import Workers
from demcal.particles.materials import Interaction, Material

DOC = Path(__file__).resolve().parents[2] / "docs" / "dem.md"
HEADING = "## A case of your own: a cylinder-lift heap with the public API"


def _example() -> str:
    text = DOC.read_text(encoding="utf-8")
    after = text.split(HEADING, 1)[1]
    return re.search(r"```python\n(.*?)```", after, re.S).group(1)


def test_docs_example_runs_shortened(tmp_path, monkeypatch):
    code = _example()
    # fewer particles, shorter stages (the lift still clears the fill)
    short = re.sub(r"^n = 400\b", "n = 60", code, count=1, flags=re.M)
    short = re.sub(r"^settle, lift, rest = .*?(#|$)", "settle, lift, rest = 0.08, 0.25, 0.03 \\1",
                   short, count=1, flags=re.M)
    assert short.count("n = 60") == 1 and "0.08, 0.25, 0.03" in short
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(short, str(DOC), "exec"), scope)
    sim, summary = scope["sim"], scope["summary"]
    assert set(sim.wall_forces()) == {"plate"}                   # the cylinder is gone
    assert sim.n_particles == 60
    assert summary.steps == round(0.03 / sim.dt) and summary.particle_steps_per_second > 0
    assert len((tmp_path / "heap.csv").read_text().splitlines()) == 61
    spread = np.hypot(*sim.state.positions[:, :2].T).max()
    assert spread > scope["r_cyl"]                               # the fill spread out


def _documented():
    rows = re.findall(r"^\| `([A-Za-z_.]+)` \| `([^`]*)` \|", DOC.read_text(encoding="utf-8"),
                      re.M)
    return {name: eval(value, {"__builtins__": {}, "math": math}) for name, value in rows}


def _signature_defaults(fn, skip=("self",)):
    return {k: p.default for k, p in inspect.signature(fn).parameters.items()
            if k not in skip and p.default is not inspect.Parameter.empty}


def _code_defaults():
    out = {}
    for prefix, values in (
            ("Simulation.", _signature_defaults(Simulation.__init__)),
            ("Simulation.add_particles.", _signature_defaults(Simulation.add_particles)),
            ("GravityRotation.", _signature_defaults(GravityRotation.__init__)),
            ("GravityRamp.", _signature_defaults(GravityRamp.__init__)),
            # Interaction's own constructor (it also takes the sub-models' coefficients)
            ("Interaction.", _signature_defaults(Interaction.__init__))):
        out.update({prefix + k: v for k, v in values.items()})
    out.update({f"Material.{f.name}": f.default for f in dataclasses.fields(Material)
                if f.default is not dataclasses.MISSING})
    for name in ("overlap_tolerance", "sort_threshold", "sort_interval"):
        out["Simulation." + name] = getattr(Simulation, name)
    # the threads' own default, which sim.parallel_threshold reads and sets
    out["Simulation.parallel_threshold"] = Workers.parallel_threshold
    return out


def test_defaults_table_matches_the_code():
    documented, code = _documented(), _code_defaults()
    assert sorted(set(code) - set(documented)) == []             # every default is named
    assert sorted(set(documented) - set(code)) == []             # and no stale row
    for name, value in code.items():
        assert documented[name] == value, name


@pytest.mark.parametrize("needle", [".coord/", "WALLS.md"])
def test_engine_docs_point_at_no_missing_file(needle):
    root = Path(__file__).resolve().parents[2] / "src" / "demcal"
    for folder in ("dem", "geometry", "particles"):
        for path in (root / folder).rglob("*.py"):
            assert needle not in path.read_text(encoding="utf-8"), path


def test_docs_backend_example_runs():
    # docs/dem-backends.md, "What a backend implements": a backend plugged in by name runs
    text = DOC.with_name("dem-backends.md").read_text(encoding="utf-8")
    text = text.split("### What a backend implements", 1)[1]
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    exec(compile(code, str(DOC), "exec"), {})


def test_docs_sub_model_example_runs():
    # docs/dem-contact.md, "What a contact sub-model declares"
    text = DOC.with_name("dem-contact.md").read_text(encoding="utf-8")
    text = text.split("### What a contact sub-model declares", 1)[1]
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    exec(compile(code, str(DOC), "exec"), {})


def test_docs_bench_test_example_runs():
    # docs/dem-backends.md, "What a bench test implements"
    from demcal.bench import registry
    text = DOC.with_name("dem-backends.md").read_text(encoding="utf-8")
    text = text.split("### What a bench test implements", 1)[1]
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    try:
        exec(compile(code, str(DOC), "exec"), {})
    finally:
        registry._REGISTRY.pop("rebound", None)


def test_importing_the_engine_touches_no_file():
    # the numba cache guard is an explicit call made by the first backend, not an
    # import side effect (issue 18 item 7)
    import subprocess
    import sys

    code = ("import demcal.dem, demcal.dem._cache as c; assert not c._ensured; "
            "from demcal.particles.materials import soil, soil_interaction; "
            "demcal.dem.Simulation([soil()], soil_interaction()); assert c._ensured")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_docs_first_example_runs_shortened(tmp_path, monkeypatch):
    """docs/dem.md's first example (materials by name, no interaction for a pair that
    cannot meet, insertion, VTK frames and a particle file) in at most 30 lines, run
    with fewer particles for a few steps."""
    text = DOC.read_text(encoding="utf-8")
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    assert len(code.strip().splitlines()) <= 30
    short = code.replace("), 500, unit,", "), 40, unit,").replace("duration=1.0", "duration=0.004") \
        .replace("interval=2000", "interval=20")
    assert short.count(", 40, unit,") == 1 and "duration=0.004" in short
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(compile(short, str(DOC), "exec"), scope)
    sim = scope["sim"]
    assert sim.n_particles == 40
    assert list(sim._walls.rows.material) == [1] * sim._walls.rows.n   # the walls' "steel"
    assert len((tmp_path / "bed.csv").read_text().splitlines()) == 41
    assert (tmp_path / "frames" / "particles.pvd").is_file()
