"""Reading run tables for ``demcal analyze`` / ``optimize``: coded or actual levels, and
malformed CSV files refused with one sentence naming the real problem."""

import importlib.resources
import json

import numpy as np
import pandas as pd
import pytest

from demcal.cli import main

DATA = importlib.resources.files("demcal") / "data"
TABLE4 = str(DATA / "paper_table4_repose_bbd.csv")
LEVELS = ["--factor", "e=0.5:0.7", "--factor", "mu=0.3:0.5"]
# y in actual units; with e = 0.6 + 0.1 E and mu = 0.4 + 0.1 M (coded E, M) it is
# 35.2 + 2.2 E + 3.3 M + 0.05 E M
TRUE_CODED = {"Intercept": 35.2, "e": 2.2, "mu": 3.3, "e*mu": 0.05}


def _y(e, mu):
    return 10 + 20 * e + 30 * mu + 5 * e * mu


def _err(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("demcal: error:")]
    assert len(lines) == 1, err
    return lines[0]


def _with_response(path, header=True, coded=False):
    """Add y to a design file written by ``demcal design``, keeping (or dropping) its
    comment lines; returns the actual levels of e and mu."""
    text = path.read_text()
    comments = [ln for ln in text.splitlines() if ln.startswith("#")]
    df = pd.read_csv(path, comment="#")
    e, mu = df["e"].to_numpy(float), df["mu"].to_numpy(float)
    if coded:
        e, mu = 0.6 + 0.1 * e, 0.4 + 0.1 * mu
    df["y"] = _y(e, mu)
    path.write_text(("\n".join(comments) + "\n" if header else "") + df.to_csv(index=False))
    return e, mu


def _numpy_coded_fit(e, mu, y):
    """Least-squares 2FI coefficients in coded units, plain numpy."""
    ce, cm = (e - 0.6) / 0.1, (mu - 0.4) / 0.1
    x = np.column_stack([np.ones_like(ce), ce, cm, ce * cm])
    b, *_ = np.linalg.lstsq(x, y, rcond=None)
    return dict(zip(TRUE_CODED, b))


def _analyze_coefs(capsys, path, *extra):
    capsys.readouterr()
    rc = main(["analyze", str(path), "--response", "y", "--model", "2fi", "--json", *extra])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    return json.loads(cap.out)["coefficients"]


@pytest.mark.parametrize("ccd_type", ["circumscribed", "face-centred", "inscribed"])
def test_ccd_design_file_round_trip_gives_true_coded_coefficients(tmp_path, capsys, ccd_type):
    path = tmp_path / "ccd.csv"
    assert main(["design", "ccd", *LEVELS, "--ccd-type", ccd_type, "-o", str(path)]) == 0
    e, mu = _with_response(path)
    ref = _numpy_coded_fit(e, mu, _y(e, mu))
    for term, v in TRUE_CODED.items():
        assert ref[term] == pytest.approx(v, abs=1e-9), term
    coefs = _analyze_coefs(capsys, path)
    assert set(coefs) == set(TRUE_CODED)
    for term, v in ref.items():
        assert coefs[term] == pytest.approx(v, abs=1e-8), (ccd_type, term)
    # the same levels on the command line change nothing
    coefs = _analyze_coefs(capsys, path, *LEVELS)
    for term, v in ref.items():
        assert coefs[term] == pytest.approx(v, abs=1e-8), (ccd_type, term)


@pytest.mark.parametrize("ccd_type", ["circumscribed", "face-centred", "inscribed"])
def test_headerless_actual_ccd_with_factor_levels(tmp_path, capsys, ccd_type):
    path = tmp_path / "ccd.csv"
    assert main(["design", "ccd", *LEVELS, "--ccd-type", ccd_type, "-o", str(path)]) == 0
    _with_response(path, header=False)
    coefs = _analyze_coefs(capsys, path, *LEVELS)
    for term, v in TRUE_CODED.items():
        assert coefs[term] == pytest.approx(v, abs=1e-8), (ccd_type, term)


def test_coded_ccd_file_still_reads_as_coded(tmp_path, capsys):
    """A file that says it is coded (``demcal design --coded -o``) keeps its +-alpha
    axial points; a headerless coded file with actual levels given reads the same."""
    path = tmp_path / "coded.csv"
    assert main(["design", "ccd", *LEVELS, "--coded", "-o", str(path)]) == 0
    assert "(coded levels)" in path.read_text().splitlines()[0]
    _with_response(path, coded=True)
    assert pd.read_csv(path, comment="#")["e"].abs().max() == pytest.approx(2 ** 0.5)
    for extra in ([], LEVELS):
        coefs = _analyze_coefs(capsys, path, *extra)
        for term, v in TRUE_CODED.items():
            assert coefs[term] == pytest.approx(v, abs=1e-8), term
    _with_response(path, header=False, coded=True)  # comment lines gone
    coefs = _analyze_coefs(capsys, path, *LEVELS)
    for term, v in TRUE_CODED.items():
        assert coefs[term] == pytest.approx(v, abs=1e-8), term


def test_optimize_on_ccd_file_reports_the_design_box_range(tmp_path, capsys):
    path = tmp_path / "ccd.csv"
    assert main(["design", "ccd", *LEVELS, "-o", str(path)]) == 0
    _with_response(path)
    capsys.readouterr()
    assert main(["optimize", str(path), "--response", "y", "--target", "36", "--model", "2fi"]) == 0
    out = capsys.readouterr().out
    # y over the coded box [-1, 1]^2: 35.2 -+ 2.2 -+ 3.3 + 0.05
    assert "y reaches 29.75 .. 40.75 inside the design box" in out


def test_ccd_without_levels_is_refused_not_guessed(tmp_path, capsys):
    """Actual CCD levels with no '# factor' lines and no --factor: the low and high
    levels cannot be told from five levels, so the reader asks for them."""
    path = tmp_path / "ccd.csv"
    assert main(["design", "ccd", *LEVELS, "-o", str(path)]) == 0
    _with_response(path, header=False)
    assert main(["analyze", str(path), "--response", "y", "--model", "2fi"]) == 2
    msg = _err(capsys)
    assert "column 'e'" in msg and "--factor e=LOW:HIGH" in msg
    assert main(["optimize", str(path), "--response", "y", "--target", "36", "--model", "2fi"]) == 2
    assert "--factor e=LOW:HIGH" in _err(capsys)


def test_coded_ccd_without_levels_is_refused_then_reads_with_unit_levels(tmp_path, capsys):
    path = tmp_path / "ccd.csv"
    assert main(["design", "ccd", *LEVELS, "--coded", "-o", str(path)]) == 0
    _with_response(path, header=False, coded=True)
    assert main(["analyze", str(path), "--response", "y", "--model", "2fi"]) == 2
    assert "--factor e=LOW:HIGH" in _err(capsys)
    coefs = _analyze_coefs(capsys, path, "--factor", "e=-1:1", "--factor", "mu=-1:1")
    for term, v in TRUE_CODED.items():
        assert coefs[term] == pytest.approx(v, abs=1e-8), term


def test_values_that_read_both_as_coded_and_as_actual_are_refused(tmp_path, capsys):
    path = tmp_path / "ccd.csv"
    assert main(["design", "ccd", *LEVELS, "--coded", "-o", str(path)]) == 0
    _with_response(path, header=False, coded=True)
    # +-1.414 is coded, or actual levels outside -0.5..0.5 (coded +-2.83): refuse
    assert main(["analyze", str(path), "--response", "y", "--model", "2fi",
                 "--factor", "e=-0.5:0.5", "--factor", "mu=0.3:0.5"]) == 2
    msg = _err(capsys)
    assert "column 'e'" in msg and "coded" in msg and "actual" in msg


def test_two_and_three_level_actual_columns_still_code_by_their_range(tmp_path, capsys):
    """A Box-Behnken table in actual units without levels: three evenly spaced levels
    per factor are the low, centre and high levels."""
    df = pd.read_csv(TABLE4)
    df["A"] = 0.6 + 0.1 * df["A"]
    path = tmp_path / "t4.csv"
    df.to_csv(path, index=False)
    capsys.readouterr()
    assert main(["analyze", str(path), "--response", "repose_angle_deg", "--json"]) == 0
    mine = json.loads(capsys.readouterr().out)["coefficients"]
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--json"]) == 0
    ref = json.loads(capsys.readouterr().out)["coefficients"]
    assert mine == pytest.approx(ref, abs=1e-9)


# -- malformed CSV input -------------------------------------------------------------------


def test_duplicate_header_is_refused(tmp_path, capsys):
    path = tmp_path / "dup.csv"
    path.write_text("A,A,y\n1,2,3\n-1,2,4\n1,-2,5\n-1,-2,6\n0,0,7\n")
    assert main(["analyze", str(path), "--response", "y", "--model", "linear"]) == 2
    msg = _err(capsys)
    assert "'A'" in msg and "twice" in msg and "A.1" not in msg


def test_repeated_factor_in_factors_option_is_refused(capsys):
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--factors", "A,A,B",
                 "--model", "linear"]) == 2
    msg = _err(capsys)
    assert "'A'" in msg and "twice" in msg and "--factors" in msg
    assert main(["optimize", TABLE4, "--response", "repose_angle_deg", "--target", "35",
                 "--factors", "A,A,B", "--model", "linear"]) == 2
    assert "'A'" in _err(capsys)


@pytest.mark.parametrize("row", [1, 2, 5])
def test_row_with_an_extra_field_is_reported_as_such(tmp_path, capsys, row):
    lines = open(TABLE4).read().splitlines()
    lines[row] += ",5"
    path = tmp_path / "extra.csv"
    path.write_text("\n".join(lines) + "\n")
    assert main(["analyze", str(path), "--response", "repose_angle_deg"]) == 2
    msg = _err(capsys)
    assert f"row {row} " in msg and "7 fields" in msg and "header has 6" in msg
    assert "empty cell" not in msg


def test_folder_instead_of_csv_is_named_a_folder(tmp_path, capsys):
    assert main(["analyze", str(tmp_path), "--response", "y"]) == 2
    msg = _err(capsys)
    assert "folder" in msg and "CSV file" in msg and "cannot find" not in msg
