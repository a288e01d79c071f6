"""``demcal bench``: help lists every key, JSON as the issue specifies, bad input -> exit 2."""

import json

import pytest

from demcal.bench.registry import get_experiment
from demcal.cli import main


def test_help_lists_every_key_with_default_and_unit(capsys):
    assert main(["bench", "repose-funnel", "--help"]) == 0
    out = capsys.readouterr().out
    for key, s in get_experiment("repose-funnel").settings("quick").items():
        line = next(line for line in out.splitlines() if line.strip().startswith(key + " "))
        assert s.unit in line
    assert "particle.static_friction" in out and "0.4" in out


def test_list(capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out
    for name in ("repose-funnel", "repose-cylinder", "incline", "impact"):
        assert name in out


def test_json_output(capsys):
    assert main(["bench", "impact", "--profile", "tiny", "--json", "--seed", "2",
                 "--set", "particle.damping_factor=0"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data)[:8] == ["test", "responses", "spread", "particles", "steps", "simulated_s",
                              "wall_s", "particle_steps_per_s"]
    assert data["test"] == "impact"
    assert data["responses"]["restitution"] == pytest.approx(0.6, rel=0.01)


@pytest.mark.parametrize("argv, words", [
    (["bench", "nope"], "unknown virtual test 'nope'"),
    (["bench", "impact", "--set", "bogus.key=1"], "unknown setting 'bogus.key'"),
    (["bench", "impact", "--set", "particle.restitution=1.5"], "outside its allowed range"),
    (["bench", "impact", "--set", "particle.restitution"], "--set expects KEY=VALUE"),
    (["bench", "impact", "--profile", "huge"], "unknown profile 'huge'"),
    (["bench", "repose-funnel", "--set", "particles.count=500000"], "too small for 500000 particles"),
    (["bench", "impact", "--vtk"], "--vtk needs --out"),
])
def test_bad_input_is_one_sentence_and_exit_2(capsys, argv, words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("demcal: error: ") and words in err
    assert len(err.splitlines()) == 1
