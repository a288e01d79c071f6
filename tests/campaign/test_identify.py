"""``demcal identify`` on analytic benches whose answer is known (identify_testbench.py):
``y1 = 10 (a + b)``, ``y2 = 8 b``, c moves nothing; ``test-c`` reads c. Every run is
answered in this process (InlineExecutor), so the whole file takes a second or two.

The verdicts rest on t-tests at 95 %: a factor with no effect is called informative in
one draw of twenty. The seeds are fixed (``[runs] seed`` below), so the draw is too;
the numbers asserted are those of these seeds.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import identify_testbench  # noqa: F401  registers test-pair and test-c
from conftest import InlineExecutor
from demcal.campaign.config import load_campaign
from demcal.campaign.identify import identify, to_dict
from demcal.cli import main

CAMPAIGN = """\
[campaign]
name = "pair"

[experiment]
test = "test-pair"
profile = "quick"
plugins = ["identify_testbench"]

[[factors]]
name = "a"
label = "Parameter a"
parameter = "test.a"
low = 0.2
high = 0.8

[[factors]]
name = "b"
label = "Parameter b"
parameter = "test.b"
low = 0.2
high = 0.8
{factor_c}
[design]
type = "{design}"

[runs]
seed = 3
{responses}
[[conditions]]
name = "only"
targets = {targets}
"""

FACTOR_C = """
[[factors]]
name = "c"
label = "Parameter c"
parameter = "test.c"
low = 0.2
high = 0.8
"""


def write(tmp_path, responses=("y1",), with_c=True, name="pair.toml"):
    tables = "".join(f'\n[[responses]]\nname = "{r}"\nunit = "mm"\n' for r in responses)
    targets = "{ " + ", ".join(f"{r} = {{ mean = 10.0, sd = 1.0 }}" for r in responses) + " }"
    path = tmp_path / name
    path.write_text(CAMPAIGN.format(factor_c=FACTOR_C if with_c else "", responses=tables, targets=targets,
                                    design="box-behnken" if with_c else "full-factorial"))
    return path


def run(path, **kwargs):
    return identify(load_campaign(path), progress=False, executor=InlineExecutor(), **kwargs)


def test_one_response_leaves_c_unpinned_and_a_b_tied(tmp_path):
    result = run(write(tmp_path))
    a = result.analysis
    assert a.unpinned == (2,)  # c
    assert a.pinned == ()
    [combo] = a.combinations
    assert combo.factors == (0, 1) and combo.free == 1
    # y1 sees a and b only through a + b: the one combination it pins is their sum
    np.testing.assert_allclose(np.abs(combo.pinned[0]), [2 ** -0.5] * 2, atol=0.05)
    assert a.rank == 1 and np.isinf(a.condition_number)
    # the effects: half the change of y1 over a's range, 10 * 0.3 = 3, within 3 se
    effects, se = result.screen.effects, result.screen.se
    assert abs(effects[0, 0] - 3.0) < 3 * se[0, 0] and abs(effects[0, 1] - 3.0) < 3 * se[0, 1]
    assert abs(effects[0, 2]) < a.t_crit * se[0, 2]
    assert 0.1 < result.screen.noise[0] < 0.3  # NOISE = 0.2
    data = json.loads((tmp_path / "pair-runs" / "identify.json").read_text())
    assert data == json.loads(json.dumps(to_dict(result)))
    assert data["unpinned"][0]["factor"] == "c"
    assert data["unpinned"][0]["benches_declared"] == ["test-c"]  # declared, not measured
    [tied] = data["not_separately_identifiable"]
    assert tied["factors"] == ["a", "b"]
    assert tied["measured_by_other_responses"] == ["y2"]  # the same runs measured y2: it separates them
    assert data["identifiable"] is False
    assert data["sensitivity"]["condition_number"] is None  # infinite


def test_two_responses_pin_a_and_b(tmp_path):
    result = run(write(tmp_path, responses=("y1", "y2")))
    a = result.analysis
    assert a.pinned == (0, 1) and a.unpinned == (2,) and a.combinations == ()
    assert a.rank == 2

    (tmp_path / "ab").mkdir()
    result = run(write(tmp_path / "ab", responses=("y1", "y2"), with_c=False))
    a = result.analysis
    assert a.pinned == (0, 1) and not a.unpinned and not a.combinations
    assert to_dict(result)["identifiable"] is True
    # S = [[2 b_y1a, 2 b_y1b], [0, 2 b_y2b]] / noise: y1 = 10 (a + b), y2 = 8 b over a, b in
    # 0.2..0.8 (half-range 0.3): the true effects per coded unit are 3, 3 and 2.4. With the
    # screen's own noise estimates the closed form is cond([[6, 6], [0, 4.8]] / s); the
    # effects' estimation error (se 0.2 / sqrt(runs) against 2.4-3) leaves it within 5 %.
    s1, s2 = a.screen.noise[:2]
    expected = np.linalg.cond(np.array([[6.0 / s1, 6.0 / s1], [0.0, 4.8 / s2]]))
    assert a.condition_number == pytest.approx(expected, rel=0.05)


def test_runs_are_cached_and_resumable(tmp_path):
    path = write(tmp_path)
    first = run(path)
    again = run(path)
    assert first.summary.ran == 16 and again.summary.ran == 0 and again.summary.skipped == 16
    np.testing.assert_array_equal(first.screen.effects, again.screen.effects)


def test_cli_prints_the_table_and_json(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("demcal.campaign.executors.make_executor", lambda *a, **k: InlineExecutor())
    path = write(tmp_path)
    assert main(["identify", str(path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "y1 [mm]: seed noise sd" in out
    assert "Parameter a [-]" in out and "test.a" not in out.split("other benches")[0]
    assert "not pinned (within the seed noise of every response): Parameter c" in out
    assert "not separately identifiable: Parameter a, Parameter b" in out
    assert "Parameter c (test.c): test-c" in out
    assert main(["identify", str(path), "--quiet", "--json", "--design", "fractional"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["design"]["points"] == 4 and data["design"]["runs"] == 8  # 2^(3-1), C = AB


def _sentence(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize("argv, words", [
    (["--runs", "2"], "cannot estimate 3 main effects"),
    (["--replicates", "1"], "--replicates must be 2 or more"),
    (["--design", "box-behnken"], "two-level design"),
    (["--design", "nonsense"], "unknown design type"),
    (["--profile", "paper"], "unknown profile 'paper'"),
    (["--condition", "wet"], "condition 'wet' is not in pair.toml"),
    (["--runs", "6", "--design", "fractional"], "a power of 2"),
])
def test_bad_options_are_one_sentence(tmp_path, capsys, argv, words):
    assert main(["identify", str(write(tmp_path)), *argv]) == 2
    assert words in _sentence(capsys)
    assert not (tmp_path / "pair-runs").exists()  # nothing run, nothing written


def test_bad_campaigns_are_one_sentence(tmp_path, capsys):
    assert main(["identify", str(tmp_path / "missing.toml")]) == 2
    assert "does not exist" in _sentence(capsys)
    path = write(tmp_path)
    path.write_text(path.read_text().replace("low = 0.2\nhigh = 0.8", "low = 0.5\nhigh = 0.5", 1))
    assert main(["identify", str(path)]) == 2
    assert "low = high = 0.5" in _sentence(capsys)


def test_a_bench_without_seed_noise_is_one_sentence(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("demcal.campaign.executors.make_executor", lambda *a, **k: InlineExecutor())
    path = write(tmp_path)
    path.write_text(path.read_text().replace('[[factors]]', '[experiment.settings]\n"test.noise" = 0.0\n\n'
                                             '[[factors]]', 1))
    assert main(["identify", str(path), "--quiet"]) == 2
    assert "no seed noise" in _sentence(capsys)


def test_the_calibration_report_carries_the_screen(tmp_path):
    """Once identify.json is in the campaign's folder, the report says what the screen
    found: c not pinned, a and b not separately identifiable."""
    from demcal.campaign.calibrate import calibrate
    from demcal.campaign.runner import run_campaign
    from demcal.report.campaign_report import write_report

    path = write(tmp_path)
    run(path)
    campaign = load_campaign(path)
    run_campaign(campaign, executor=InlineExecutor(), progress=False)
    cal = calibrate(campaign, executor=InlineExecutor(), progress=False)
    page = write_report(campaign, tmp_path / "report", calibrations=[cal]).read_text()
    assert "Identifiability before the design" in page
    assert "not pinned by any response: Parameter c" in page and "not separately identifiable: a and b" in page
