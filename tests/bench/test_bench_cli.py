"""``demcal bench``: help lists every key, JSON as the issue specifies, bad input -> exit 2."""

import json

import pytest

from demcal.bench.registry import get_experiment
from demcal.cli import main


def _settings_table(out: str) -> list[dict[str, str]]:
    """The rows of the settings table of ``bench NAME --help``, cut at the header's columns."""
    lines = out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.split()[:2] == ["KEY", "DEFAULT"])
    header = lines[at]
    names = ["KEY", "DEFAULT", "UNIT", "ALLOWED", "DESCRIPTION"]
    starts = [header.index(name) for name in names]
    assert starts == sorted(starts) and header[:starts[0]] == "  "
    rows = []
    for line in lines[at + 1:]:
        if not line.strip():
            break
        cells = [line[a:b].strip() for a, b in zip(starts, starts[1:] + [None])]
        rows.append(dict(zip(names, cells)))
    return rows


def _expected_default(value) -> str:
    """A default as the help documents it: floats with ``:g``, everything else ``str``."""
    return f"{value:g}" if isinstance(value, float) else str(value)


@pytest.mark.parametrize("name, profile", [("repose-funnel", "quick"), ("repose-funnel", "tiny"),
                                           ("repose-cylinder", "quick"), ("incline", "quick"),
                                           ("impact", "paper")])
def test_help_lists_every_key_with_default_and_unit(capsys, name, profile):
    assert main(["bench", name, "--profile", profile, "--help"]) == 0
    out = capsys.readouterr().out
    settings = get_experiment(name).settings(profile)
    rows = _settings_table(out)
    assert [row["KEY"] for row in rows] == list(settings)
    for row, s in zip(rows, settings.values()):
        assert row["DEFAULT"] == _expected_default(s.default), s.key
        assert row["UNIT"] == s.unit, s.key
        if s.choices:
            assert row["ALLOWED"] == "|".join(s.choices), s.key
        assert row["DESCRIPTION"] == s.help, s.key


def test_help_shows_the_papers_defaults(capsys):
    """Known values (paper Tables 2 and 3, centre point) in the DEFAULT column."""
    assert main(["bench", "repose-funnel", "--help"]) == 0
    rows = {row["KEY"]: row for row in _settings_table(capsys.readouterr().out)}
    assert rows["particle.static_friction"]["DEFAULT"] == "0.4"
    assert rows["particle.rolling_friction"]["DEFAULT"] == "0.2"
    assert rows["particle.restitution"]["DEFAULT"] == "0.6"
    assert rows["particle.poisson_ratio"]["DEFAULT"] == "0.46"
    assert rows["geometry.scale"]["DEFAULT"] == "4"
    assert rows["particle.density"]["UNIT"] == "kg/m3"


def test_list(capsys):
    assert main(["bench", "--list"]) == 0
    out = capsys.readouterr().out
    for name in ("repose-funnel", "repose-cylinder", "incline", "impact", "drum"):
        assert name in out


def test_the_help_names_every_test_of_demcals_own(capsys):
    from demcal.bench.registry import names
    from demcal.cli.bench import _TESTS

    own = [n for n in names() if type(get_experiment(n)).__module__.startswith("demcal.")]
    assert sorted(_TESTS) == sorted(own)
    assert main(["bench", "--help"]) == 0
    assert "drum" in capsys.readouterr().out


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
    (["bench", "incline", "--profile", "tiny", "--set", "incline.container=free"],
     "needs incline.container_mass above 0"),
    (["bench", "incline", "--profile", "tiny", "--set", "incline.container=rigid",
      "--set", "incline.container_wall_friction=0.6"], "use incline.container = \"free\""),
])
def test_bad_input_is_one_sentence_and_exit_2(capsys, argv, words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("demcal: error: ") and words in err
    assert len(err.splitlines()) == 1
