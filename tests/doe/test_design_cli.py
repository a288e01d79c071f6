"""``demcal design`` and design CSV files."""

import numpy as np
import pytest
import pandas as pd

from demcal.cli import main
from demcal.doe import read_design_csv


def test_design_box_behnken_cli_writes_actual_levels(tmp_path, capsys):
    out = tmp_path / "design.csv"
    rc = main(["design", "box-behnken", "--factor", "e=0.5:0.7", "--factor", "mu=0.3:0.5",
               "--factor", "gamma=0.1:0.3", "--factor", "zeta=0:0.2", "--center", "5",
               "--seed", "3", "-o", str(out)])
    assert rc == 0
    df = pd.read_csv(out, comment="#")
    assert len(df) == 29 and list(df.columns) == ["run", "std_order", "e", "mu", "gamma", "zeta"]
    assert set(np.round(df["e"], 9)) == {0.5, 0.6, 0.7}
    back = read_design_csv(out)
    assert back.names == ["e", "mu", "gamma", "zeta"]
    assert np.allclose(back.coded[:24], __import__("demcal.doe", fromlist=["x"]).box_behnken(4, 0))


def _coded(out):
    import io

    df = pd.read_csv(io.StringIO(out), comment="#")
    return df[[c for c in df.columns if c not in ("run", "std_order")]].to_numpy(float)


def test_design_cli_other_kinds(capsys):
    assert main(["design", "ccd", "-k", "3", "--ccd-type", "face-centred", "--center", "2"]) == 0
    out = capsys.readouterr().out
    assert len(out.strip().splitlines()) == 1 + 8 + 6 + 2
    x = _coded(out)
    # face-centred: axial points on the faces, every level in {-1, 0, 1}
    assert np.abs(x).max() == 1.0 and set(np.round(x, 12).ravel()) == {-1.0, 0.0, 1.0}
    assert (np.count_nonzero(x, axis=1) == 1).sum() == 6
    # circumscribed (rotatable): axial distance alpha = (2^3)^(1/4) = 1.6818
    alpha = 8 ** 0.25
    assert main(["design", "ccd", "-k", "3", "--ccd-type", "circumscribed", "--center", "2"]) == 0
    x = _coded(capsys.readouterr().out)
    assert len(x) == 16 and np.abs(x).max() == pytest.approx(alpha) and np.abs(x).max() > 1
    axial = x[np.count_nonzero(x, axis=1) == 1]
    assert len(axial) == 6 and np.abs(axial).max(axis=1) == pytest.approx(np.full(6, alpha))
    # inscribed: the circumscribed design scaled by 1/alpha, axial points at +-1
    assert main(["design", "ccd", "-k", "3", "--ccd-type", "inscribed", "--center", "2"]) == 0
    x = _coded(capsys.readouterr().out)
    assert np.abs(x).max() == pytest.approx(1.0)
    cube = x[np.count_nonzero(x, axis=1) == 3]
    assert len(cube) == 8 and np.abs(cube) == pytest.approx(np.full((8, 3), 1 / alpha))
    assert main(["design", "plackett-burman", "-k", "7"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1 + 8
    assert main(["design", "fractional", "-k", "5", "--fraction", "2"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1 + 8


def test_design_steepest_ascent_from_runs(tmp_path, capsys):
    # Montgomery Example 11.1 data (time 30..40 min, temperature 150..160 F)
    runs = tmp_path / "runs.csv"
    runs.write_text("time,temp,y\n30,150,39.3\n30,160,40.0\n40,150,40.9\n40,160,41.5\n"
                    "35,155,40.3\n35,155,40.5\n35,155,40.7\n35,155,40.2\n35,155,40.6\n")
    assert main(["design", "steepest-ascent", str(runs), "--response", "y", "--steps", "2"]) == 0
    rows = capsys.readouterr().out.strip().splitlines()
    assert rows[0] == "run,std_order,time,temp"
    t, T = map(float, rows[2].split(",")[2:])
    assert (t, round(T, 2)) == (40.0, 157.1)


def test_design_cli_bad_input_one_sentence(capsys):
    assert main(["design", "box-behnken", "--factor", "e=0.7:0.5", "--factor", "m=1:2",
                 "--factor", "g=1:2"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("demcal: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert main(["design", "box-behnken", "--factor", "e=0.5:0.7", "--factor", "m=1:2"]) == 2
    assert "3 to 7 factors" in capsys.readouterr().err


def test_design_file_round_trip_through_analyze(tmp_path, capsys):
    """A design written by `demcal design`, with responses added, analyses in coded units."""
    import json

    out = tmp_path / "d.csv"
    assert main(["design", "box-behnken", "--factor", "e=0.5:0.7", "--factor", "mu=0.3:0.5",
                 "--factor", "g=0.1:0.3", "--seed", "5", "-o", str(out)]) == 0
    header = [ln for ln in out.read_text().splitlines() if ln.startswith("#")]
    df = pd.read_csv(out, comment="#")
    x = np.column_stack([(df["e"] - 0.6) / 0.1, (df["mu"] - 0.4) / 0.1, (df["g"] - 0.2) / 0.1])
    df["angle"] = 30 + 2 * x[:, 0] - x[:, 1] + 0.5 * x[:, 0] * x[:, 2] + 0.01 * np.sin(np.arange(len(df)))
    out.write_text("\n".join(header) + "\n" + df.to_csv(index=False))
    capsys.readouterr()
    assert main(["analyze", str(out), "--response", "angle", "--json"]) == 0
    coefs = json.loads(capsys.readouterr().out)["coefficients"]
    assert list(coefs)[:4] == ["Intercept", "e", "mu", "g"]
    assert coefs["e"] == pytest.approx(2.0, abs=0.02) and coefs["e*g"] == pytest.approx(0.5, abs=0.02)


def test_design_cli_takes_every_spelling_and_the_ccd_fraction(capsys):
    """The catalogue's spellings and options (demcal.doe.catalog), as campaigns take them."""
    for kind in ("bbd", "central-composite", "full-factorial", "fractional-factorial"):
        assert main(["design", kind, "-k", "3"]) == 0, kind
        capsys.readouterr()
    # a half-fraction factorial part: 8 + 2 * 4 axial + 6 centre runs
    assert main(["design", "ccd", "-k", "4", "--fraction", "1"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1 + 22
    # a fractional factorial without --fraction or --generators is a half fraction
    assert main(["design", "fractional", "-k", "4"]) == 0
    assert len(capsys.readouterr().out.strip().splitlines()) == 1 + 8


def test_design_cli_unknown_kind_is_one_sentence(capsys):
    assert main(["design", "box-benken", "-k", "3"]) == 2
    err = capsys.readouterr().err
    assert err == "demcal: error: unknown design type 'box-benken'; did you mean 'box-behnken'?\n"
    assert main(["design", "latin-square", "-k", "3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("demcal: error: unknown design type 'latin-square'; choose one of: ")
    assert "steepest-ascent" in err and err.count("\n") == 1
