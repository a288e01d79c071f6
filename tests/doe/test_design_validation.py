"""Bad ``demcal design`` input is refused with one sentence (exit status 2), never a
traceback, an out-of-memory kill, a junk design or a silently ignored option.

Every test puts a case that fails *cheaply* on unchecked code first, so that code
without the size cap fails the test before it tries to build a huge design.
"""

import numpy as np
import pytest

from demcal.cli import main
from demcal.doe import (
    box_behnken, central_composite, fractional_factorial, full_factorial, plackett_burman,
    steepest_ascent,
)
from demcal.errors import ConfigError


def refused(capsys, argv, *words):
    """``demcal design ARGV`` exits 2 with one ``demcal: error:`` sentence holding ``words``."""
    rc = main(["design", *argv])
    captured = capsys.readouterr()
    err = captured.err
    assert rc == 2, (argv, rc, err)
    assert err.startswith("demcal: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err and captured.out == "", err
    for word in words:
        assert word in err, (word, err)
    return err


# ----------------------------------------------------------------------------------------
# 1. size cap
# ----------------------------------------------------------------------------------------


def test_huge_factorials_are_refused_with_the_run_count(capsys):
    # 400^2 = 160,000 runs: cheap to build, but above the cap
    refused(capsys, ["factorial", "-k", "2", "--levels", "400"], "160,000 runs", "100,000",
            "fewer levels", "fractional")
    refused(capsys, ["factorial", "-k", "2", "--levels", "100000"], "10,000,000,000 runs")
    refused(capsys, ["factorial", "-k", "25"], "33,554,432 runs")
    err = refused(capsys, ["factorial", "-k", "2000"], "runs")
    assert len(err) < 400  # no 600-digit count
    # the cap counts centre points
    refused(capsys, ["factorial", "-k", "2", "--center", "100000"], "100,004 runs")
    # at the cap is fine
    assert main(["design", "factorial", "-k", "2", "--center", "99996"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 1 + 100_000


def test_other_huge_designs_are_refused(capsys):
    refused(capsys, ["box-behnken", "-k", "3", "--center", "200000"], "200,012 runs")
    refused(capsys, ["ccd", "-k", "3", "--center", "200000"], "200,014 runs")
    refused(capsys, ["plackett-burman", "-k", "3", "--center", "200000"], "200,008 runs")
    refused(capsys, ["ccd", "-k", "20"], "1,048,622 runs")
    refused(capsys, ["fractional", "-k", "24", "--generators", "Y=ABC"], "8,388,608 runs")


def test_library_builders_check_the_size_before_building():
    with pytest.raises(ConfigError, match="160,000 runs"):
        full_factorial([400, 400])
    with pytest.raises(ConfigError, match=r"10,000,000,000 runs"):
        full_factorial([100_000, 100_000])
    with pytest.raises(ConfigError, match="runs"):
        full_factorial(40)
    with pytest.raises(ConfigError, match="runs"):
        central_composite(40)
    with pytest.raises(ConfigError, match="runs"):
        box_behnken(3, 10**12)
    with pytest.raises(ConfigError, match="steps"):
        steepest_ascent([1.0, 0.5], 1.0, 10**12)
    assert full_factorial([10, 10, 10, 10, 10]).shape == (100_000, 5)


# ----------------------------------------------------------------------------------------
# 2. counts
# ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["ccd", "factorial", "fractional", "plackett-burman", "box-behnken"])
def test_negative_centre_points_are_refused(capsys, kind):
    extra = ["--fraction", "1"] if kind == "fractional" else []
    refused(capsys, [kind, "-k", "3", *extra, "--center", "-2"], "--center", "-2")


def test_library_builders_refuse_negative_centre_points():
    with pytest.raises(ConfigError, match="centre"):
        central_composite(3, center=-2)
    with pytest.raises(ConfigError, match="centre"):
        box_behnken(3, -1)


def test_other_counts_are_checked(capsys):
    refused(capsys, ["fractional", "-k", "4", "--fraction", "0"], "--fraction", "at least 1")
    refused(capsys, ["fractional", "-k", "4", "--fraction", "-1"], "--fraction", "at least 1")
    refused(capsys, ["factorial", "-k", "2", "--levels", "1"], "--levels", "at least 2")
    refused(capsys, ["plackett-burman", "-k", "3", "--runs", "-8"], "-8", "12")
    refused(capsys, ["factorial", "-k", "2", "--seed", "-1"], "--seed")
    refused(capsys, ["ccd", "-k", "2", "--alpha", "nan"], "--alpha")
    refused(capsys, ["ccd", "-k", "2", "--alpha", "-1"], "--alpha")
    refused(capsys, ["ccd", "-k", "2", "--alpha", "sideways"], "rotatable")
    refused(capsys, ["factorial", "-k", "-3"], "-k", "-3")
    refused(capsys, ["box-behnken", "-k", "0"], "-k", "0")
    with pytest.raises(ConfigError, match="at least 1"):
        fractional_factorial(4, 0)
    with pytest.raises(ConfigError, match="alpha"):
        central_composite(2, alpha=float("inf"))


# ----------------------------------------------------------------------------------------
# 3. junk designs and ignored options
# ----------------------------------------------------------------------------------------


def test_generators_must_be_products_of_distinct_base_factors(capsys):
    refused(capsys, ["fractional", "-k", "4", "--generators", "D=AA"], "D=AA", "distinct")
    refused(capsys, ["fractional", "-k", "4", "--generators", "D=A"], "D=A", "alias")
    refused(capsys, ["fractional", "-k", "4", "--generators", "D=-B"], "D=-B", "alias")
    # two generators defining the same factor (C would stay all zero)
    refused(capsys, ["fractional", "-k", "4", "--generators", "D=AB,D=BA"], "D")
    # two generated factors that are the same column
    refused(capsys, ["fractional", "-k", "5", "--generators", "D=AB,E=BA"], "D=AB", "E=BA")
    refused(capsys, ["fractional", "-k", "5", "--generators", "D=AB,E=-AB"], "D=AB", "E=-AB")
    # --fraction that disagrees with the number of generators
    refused(capsys, ["fractional", "-k", "5", "--fraction", "1", "--generators", "D=AB,E=AC"],
            "--fraction 1", "2 generators")
    for bad in (["D=AA"], ["D=A"], ["C=AB", "C=AB"]):
        with pytest.raises(ConfigError):
            fractional_factorial(4, generators=bad)
    # valid ones still work, with a sign too
    assert main(["design", "fractional", "-k", "5", "--generators", "D=AB,E=-AC"]) == 0
    assert main(["design", "fractional", "-k", "5", "--fraction", "2", "--generators", "D=AB,E=AC"]) == 0
    x = fractional_factorial(5, generators=["D=AB", "E=-AC"])
    assert np.allclose(x[:, 3], x[:, 0] * x[:, 1]) and np.allclose(x[:, 4], -x[:, 0] * x[:, 2])
    assert np.linalg.matrix_rank(x) == 5


def _runs_csv(tmp_path):
    runs = tmp_path / "runs.csv"
    runs.write_text("time,temp,y\n30,150,39.3\n30,160,40.0\n40,150,40.9\n40,160,41.5\n"
                    "35,155,40.3\n35,155,40.5\n35,155,40.7\n35,155,40.2\n35,155,40.6\n")
    return str(runs)


def test_steepest_ascent_step_and_steps(tmp_path, capsys):
    runs = _runs_csv(tmp_path)
    refused(capsys, ["steepest-ascent", runs, "--response", "y", "--step", "0"], "--step", "> 0")
    refused(capsys, ["steepest-ascent", runs, "--response", "y", "--step", "-1"], "--step", "--descent")
    refused(capsys, ["steepest-ascent", runs, "--response", "y", "--step", "nan"], "--step")
    refused(capsys, ["steepest-ascent", runs, "--response", "y", "--steps", "-3"], "--steps", "at least 1")
    refused(capsys, ["steepest-ascent", runs, "--response", "y", "--steps", "0"], "--steps", "at least 1")
    with pytest.raises(ConfigError, match="step"):
        steepest_ascent([1.0, 0.5], 0.0)
    with pytest.raises(ConfigError, match="steps"):
        steepest_ascent([1.0, 0.5], 1.0, 0)
    assert main(["design", "steepest-ascent", runs, "--response", "y", "--steps", "1",
                 "--step", "0.5", "--descent"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1 + 2


@pytest.mark.parametrize("kind, option, takers", [
    ("box-behnken", ["--fraction", "1"], "fractional"),
    ("box-behnken", ["--runs", "12"], "plackett-burman"),
    ("box-behnken", ["--levels", "3"], "factorial"),
    ("box-behnken", ["--generators", "C=AB"], "fractional"),
    ("box-behnken", ["--alpha", "orthogonal"], "ccd"),
    ("box-behnken", ["--ccd-type", "inscribed"], "ccd"),
    ("box-behnken", ["--step", "2"], "steepest-ascent"),
    ("box-behnken", ["--steps", "2"], "steepest-ascent"),
    ("box-behnken", ["--descent"], "steepest-ascent"),
    ("box-behnken", ["--response", "y"], "steepest-ascent"),
    ("ccd", ["--generators", "C=AB"], "fractional"),
    ("bbd", ["--runs", "12"], "plackett-burman"),
    ("ccd", ["--levels", "3"], "factorial"),
    ("factorial", ["--runs", "8"], "plackett-burman"),
    ("factorial", ["--alpha", "1.5"], "ccd"),
    ("fractional", ["--levels", "3"], "factorial"),
    ("plackett-burman", ["--fraction", "1"], "fractional"),
])
def test_options_of_other_design_kinds_are_refused(capsys, kind, option, takers):
    refused(capsys, [kind, "-k", "3", *option], option[0], kind, takers)


def test_options_steepest_ascent_does_not_take(tmp_path, capsys):
    runs = _runs_csv(tmp_path)
    for option in (["--center", "2"], ["--seed", "1"], ["-k", "2"], ["--levels", "3"]):
        refused(capsys, ["steepest-ascent", runs, "--response", "y", *option], option[0], "steepest-ascent")
    # a runs CSV given to another design kind
    refused(capsys, ["factorial", runs, "-k", "2"], "runs.csv", "steepest-ascent")


def test_valid_designs_still_build(capsys):
    for argv, rows in ((["factorial", "-k", "2", "--levels", "3", "--center", "1"], 10),
                       (["ccd", "-k", "2", "--alpha", "1.2", "--ccd-type", "inscribed"], 14),
                       (["ccd", "-k", "2", "--alpha", "orthogonal", "--center", "0"], 8),
                       (["plackett-burman", "-k", "3", "--runs", "12", "--seed", "0"], 12),
                       (["box-behnken", "-k", "3", "--center", "0"], 12)):
        assert main(["design", *argv]) == 0, argv
        assert len(capsys.readouterr().out.strip().splitlines()) == 1 + rows, argv
    assert plackett_burman(3).shape == (8, 3)
