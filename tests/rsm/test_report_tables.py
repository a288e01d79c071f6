"""Issue 19: `demcal analyze` reads the report's own design table, and the CLI and the
report print tables with one Design-Expert style formatter."""

from __future__ import annotations

import importlib.resources
import json

import numpy as np
import pandas as pd
import pytest

from demcal.cli import main
from demcal.rsm.tables import format_number, format_table, term_label

TABLE4 = str(importlib.resources.files("demcal") / "data" / "paper_table4_repose_bbd.csv")
#: The paper's repose factors (Table 3) as the test campaign names them.
LEVELS = {"A": ("particle.restitution", 0.5, 0.7), "B": ("particle.static_friction", 0.3, 0.5),
          "C": ("particle.rolling_friction", 0.1, 0.3), "D": ("particle.damping_factor", 0.0, 0.2)}


def report_design_csv(path, replicates: int = 1):
    """The paper's Table 4 written as campaign_report._design_section writes
    ``tables/design_results.csv``: run index, coded factors, the factors' actual levels
    (parameter columns renamed ``<name> actual``), responses, seed, status, wall_s."""
    df = pd.read_csv(TABLE4)
    table = pd.DataFrame({"run": np.arange(1, len(df) + 1)})
    for name, (parameter, low, high) in LEVELS.items():
        table[name] = df[name].to_numpy(float)
        table[parameter] = (low + high) / 2 + (high - low) / 2 * table[name]
    table["repose_angle_deg"] = df["repose_angle_deg"]
    table["seed"] = 7 + np.arange(len(df))
    table["status"] = "done"
    table["wall_s"] = np.linspace(0.5, 3.0, len(df))
    cols = ["run"] + list(LEVELS) + [p for p, *_ in LEVELS.values()] + ["repose_angle_deg", "seed", "status", "wall_s"]
    if replicates > 1:
        table["replicate"] = 1
        cols.insert(1, "replicate")
    shown = table[cols].set_index("run").rename(columns={p: f"{n} actual" for n, (p, *_) in LEVELS.items()})
    shown.to_csv(path)
    return path


@pytest.mark.parametrize("replicates", [1, 2])
def test_analyze_reads_the_reports_design_table(tmp_path, capsys, replicates):
    path = report_design_csv(tmp_path / "design_results.csv", replicates)
    assert main(["analyze", str(path), "--response", "repose_angle_deg", "--json"]) == 0
    fitted = json.loads(capsys.readouterr().out)
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--factors", "A,B,C,D",
                 "--factor", "A=0.5:0.7", "--factor", "B=0.3:0.5", "--factor", "C=0.1:0.3",
                 "--factor", "D=0:0.2", "--json"]) == 0
    reference = json.loads(capsys.readouterr().out)
    # the same fit as the paper's table with its levels given by hand: the factors are
    # A..D (not seed, wall_s or the actual copies), coded from the table's own columns
    assert fitted["coefficients"].keys() == reference["coefficients"].keys()
    assert "seed" not in fitted["coefficients"] and "wall_s" not in fitted["coefficients"]
    for k, v in reference["coefficients"].items():
        assert fitted["coefficients"][k] == pytest.approx(v, rel=1e-9, abs=1e-12), k

    assert main(["analyze", str(path), "--response", "repose_angle_deg"]) == 0
    out = capsys.readouterr().out
    # the levels of the actual-units equation come from the "<name> actual" columns
    assert "factors A: 0.5 (-1) .. 0.7 (+1), B: 0.3 (-1) .. 0.5 (+1), C: 0.1 (-1) .. 0.3 (+1), " \
           "D: 0 (-1) .. 0.2 (+1)" in out


def test_inconsistent_actual_copy_is_refused(tmp_path, capsys):
    path = report_design_csv(tmp_path / "design_results.csv")
    df = pd.read_csv(path)
    df.loc[3, "B actual"] += 0.05
    df.to_csv(path, index=False)
    assert main(["analyze", str(path), "--response", "repose_angle_deg"]) != 0
    assert "'B' and 'B actual'" in capsys.readouterr().err


def test_number_formats():
    assert format_number(2.11767e-09, column="p-value") == "< 0.0001"
    assert format_number(0.0176518, column="p") == "0.0177"
    assert format_number(1282.55) == "1283"
    assert format_number(44902.2) == "44902"  # whole digits kept, no 4.490e+04
    assert format_number(0.0439758) == "0.04398"
    assert format_number(-0.605477) == "-0.6055"
    assert format_number(3e-7) == "3.000e-07"
    assert format_number(12) == "12" and format_number(np.nan) == ""
    assert term_label("A*C") == "AC" and term_label("B^2") == "B²" and term_label("A^2*B") == "A²B"
    assert term_label("e*mu") == "e·mu" and term_label("Residual") == "Residual"


def test_format_table_headers_and_terms():
    df = pd.DataFrame({"sum_sq": [10.0, 2.5], "df": [1, 1], "mean_sq": [10.0, 2.5], "F": [40.0, 10.0],
                       "p": [1e-9, 0.012]}, index=pd.Index(["A*C", "B^2"], name="source"))
    text = format_table(df).splitlines()
    assert text[0].split() == ["Source", "Sum", "of", "Squares", "df", "Mean", "Square", "F-value", "p-value"]
    assert text[2].split() == ["AC", "10", "1", "10", "40", "<", "0.0001"]
    assert text[3].split() == ["B²", "2.500", "1", "2.500", "10", "0.0120"]
