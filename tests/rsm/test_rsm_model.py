"""Equations, aliasing, fit summary, reduction and the ``demcal analyze`` command."""

import importlib.resources
import itertools
import json
import re

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from demcal.cli import main
from demcal.doe import Factor, box_behnken
from demcal.errors import DataError
from demcal.rsm import backward_elimination, fit_response_surface, fit_summary
from demcal.rsm.terms import parse_term

DATA = importlib.resources.files("demcal") / "data"
TABLE4 = str(DATA / "paper_table4_repose_bbd.csv")
TABLE8 = str(DATA / "paper_table8_sliding_bbd.csv")
# Table 3 of the reference paper: factor levels of e, mu, gamma, zeta
LEVELS4 = ["--factor", "A=0.5:0.7", "--factor", "B=0.3:0.5", "--factor", "C=0.1:0.3",
           "--factor", "D=0.0:0.2"]


# -- independent reference computations (plain numpy/scipy, no demcal code) --------------


def _terms(k, order):
    """Exponent tuples of the intercept, linear, 2FI, quadratic and cubic terms."""
    out = [tuple([0] * k)] + [tuple(int(i == j) for i in range(k)) for j in range(k)]
    if order in ("2fi", "quadratic", "cubic"):
        out += [tuple(int(i in ab) for i in range(k)) for ab in itertools.combinations(range(k), 2)]
    if order in ("quadratic", "cubic"):
        out += [tuple(2 * int(i == j) for i in range(k)) for j in range(k)]
    if order == "cubic":
        out += [t for t in itertools.product(range(4), repeat=k) if sum(t) == 3]
    return out


def _matrix(x, terms):
    return np.column_stack([np.prod(x ** np.array(t), axis=1) for t in terms])


def _sse_rank(X, y):
    b, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ b
    return float(r @ r), int(np.linalg.matrix_rank(X))


def _json_name(t, names):
    if not any(t):
        return "Intercept"
    return "*".join(n if e == 1 else f"{n}^{e}" for n, e in zip(names, t) if e)


def _display(t, names):
    return "".join(n if e == 1 else n + "²" for n, e in zip(names, t) if e)


def _backward(x, y, terms, alpha):
    """Textbook hierarchical backward elimination (t tests of the coefficients)."""
    terms, removed = list(terms), []
    while len(terms) > 2:
        X = _matrix(x, terms)
        n, p = X.shape
        b, *_ = np.linalg.lstsq(X, y, rcond=None)
        mse = float(np.sum((y - X @ b) ** 2)) / (n - p)
        pv = 2 * stats.t.sf(np.abs(b / np.sqrt(np.diag(np.linalg.inv(X.T @ X)) * mse)), n - p)
        cand = [(pv[i], t) for i, t in enumerate(terms) if any(t) and pv[i] > alpha
                and not any(o != t and all(a >= c for a, c in zip(o, t)) for o in terms)]
        if not cand:
            break
        worst = max(cand)[1]
        removed.append(worst)
        terms.remove(worst)
    return terms, removed


@pytest.fixture(scope="module")
def repose():
    df = pd.read_csv(TABLE4)
    factors = [Factor("A", 0.5, 0.7), Factor("B", 0.3, 0.5), Factor("C", 0.1, 0.3), Factor("D", 0.0, 0.2)]
    return fit_response_surface(df[list("ABCD")].to_numpy(), df["repose_angle_deg"], factors,
                                "quadratic", "beta")


def test_actual_equation_predicts_like_coded(repose):
    rng = np.random.default_rng(0)
    coded = rng.uniform(-1, 1, (20, 4))
    actual = repose.to_actual(coded)
    coefs = repose.actual_coefficients()
    names = repose.names
    pred = np.zeros(20)
    for name, b in coefs.items():
        t = parse_term(name, names)
        pred += b * np.prod(actual ** np.array(t), axis=1)
    assert pred == pytest.approx(repose.predict(coded))
    assert repose.predict_actual(actual) == pytest.approx(repose.predict(coded))
    assert "beta = " in repose.equation("actual") and "A²" in repose.equation("coded")


def test_cubic_on_box_behnken_reports_aliases():
    df = pd.read_csv(TABLE4)
    m = fit_response_surface(df[list("ABCD")].to_numpy(), df["repose_angle_deg"], list("ABCD"), "cubic")
    assert m.aliased["A^3"] == "A"
    assert m.aliased["A*B*C"] == "0"
    assert "aliased" in m.notes[0]
    assert m.df_residual > 0


def test_fit_summary_sequence(repose):
    s = fit_summary(repose.x, repose.y, repose.factors)
    seq = s.sequential
    assert list(seq.index) == ["Mean vs Total", "Linear vs Mean", "2FI vs Linear", "Quadratic vs 2FI",
                               "Cubic vs Quadratic", "Residual", "Total"]
    # sequential sums add up to the total sum of squares
    assert seq["sum_sq"].iloc[:-1].sum() == pytest.approx(seq.loc["Total", "sum_sq"])
    assert seq.loc["Quadratic vs 2FI", "df"] == 4
    assert s.lack_of_fit.loc["Quadratic", "F"] == pytest.approx(5.46, abs=0.005)
    assert s.model_stats.loc["Quadratic", "pred_r2"] == pytest.approx(0.7755, abs=5e-5)
    assert s.aliased == ("cubic",)

    # independent sequential (extra sum of squares) F tests on Table 4 with numpy/scipy:
    # each F = [(SSE_smaller - SSE_larger) / added df] / MSE_larger
    df = pd.read_csv(TABLE4)
    x, y = df[list("ABCD")].to_numpy(float), df["repose_angle_deg"].to_numpy(float)
    n = y.size
    prev_sse, prev_p = float(np.sum((y - y.mean()) ** 2)), 1
    ref, aliased = {}, {}
    for order, key in (("linear", "Linear vs Mean"), ("2fi", "2FI vs Linear"),
                       ("quadratic", "Quadratic vs 2FI"), ("cubic", "Cubic vs Quadratic")):
        X = _matrix(x, _terms(4, order))
        sse, p = _sse_rank(X, y)
        aliased[key] = p < X.shape[1]
        F = (prev_sse - sse) / (p - prev_p) / (sse / (n - p))
        ref[key] = (p - prev_p, F, stats.f.sf(F, p - prev_p, n - p))
        prev_sse, prev_p = sse, p
    for key, (dfk, F, pv) in ref.items():
        assert seq.loc[key, "df"] == dfk, key
        assert seq.loc[key, "F"] == pytest.approx(F, rel=1e-9), key
        assert seq.loc[key, "p"] == pytest.approx(pv, rel=1e-7), key
    # highest non-aliased order adding significantly at 0.05: 2FI (p 0.025); the quadratic
    # step is not significant (p 0.103) and the cubic model is aliased
    expected = [k.split(" vs ")[0] for k, (_, _, pv) in ref.items() if pv < 0.05 and not aliased[k]][-1]
    assert expected == "2FI"
    assert ref["Quadratic vs 2FI"][2] > 0.05 and aliased["Cubic vs Quadratic"]
    assert s.suggested == expected


def test_backward_elimination_keeps_hierarchy(repose):
    red = backward_elimination(repose, 0.05)
    m = red.model
    assert red.removed and red.removed[0][0] == "D^2"
    for parent in m.terms:  # every divisor of a kept term is kept
        for j, e in enumerate(parent):
            if e:
                child = list(parent)
                child[j] -= 1
                assert tuple(child) in m.terms
    kept = set(m.term_names)
    assert {"B*C", "C*D", "A*D", "C^2"} <= kept
    assert all(p > 0.05 for _, p in red.removed)


def test_analyze_json_format(capsys):
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"anova", "fit", "coefficients"}
    sources = [r["source"] for r in out["anova"]]
    assert sources[0] == "Model" and sources[-4:] == ["Residual", "Lack of Fit", "Pure Error", "Cor Total"]
    assert "A*B" in sources and "A^2" in sources
    assert set(out["anova"][0]) == {"source", "sum_sq", "df", "mean_sq", "F", "p"}
    assert set(out["fit"]) == {"std_dev", "mean", "cv_percent", "press", "r2", "adj_r2", "pred_r2",
                               "adeq_precision"}
    assert round(out["anova"][0]["F"], 2) == 23.38
    assert round(out["coefficients"]["Intercept"], 2) == 40.03
    assert list(out["coefficients"])[:2] == ["Intercept", "A"]


def _parse_equation(line):
    """``{display term: coefficient}`` of a printed ``y = b0 + b1 A - ...`` equation."""
    rhs = line.split(" = ", 1)[1]
    first, *rest = re.split(r" (?=[+-] )", rhs)
    out = {"Intercept": float(first)}
    for part in rest:
        sign, value, name = part.split(" ")
        out[name] = float(value) * (-1 if sign == "-" else 1)
    return out


def test_analyze_text_with_levels_and_reduction(capsys):
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", *LEVELS4, "--reduce", "0.05"]) == 0
    cap = capsys.readouterr()
    assert "Equation in actual factors" in cap.out and "Lack of Fit" in cap.out
    assert "backward elimination removed" in cap.err
    lines = cap.out.splitlines()
    names = list("ABCD")

    # independent hierarchical backward elimination at 0.05 on the same runs. D² goes
    # first: it has the largest p of all terms in Table 5 (0.9956)
    df = pd.read_csv(TABLE4)
    x, y = df[names].to_numpy(float), df["repose_angle_deg"].to_numpy(float)
    kept, removed = _backward(x, y, _terms(4, "quadratic"), 0.05)
    assert removed[0] == (0, 0, 0, 2)
    assert "backward elimination removed D² (p = 0.9956)" in cap.err

    # (b) the printed ANOVA is the reduced model's: no D², exactly the kept terms
    i, j = lines.index("ANOVA (partial sums of squares)"), lines.index("Fit statistics")
    rows = [ln.split()[0] for ln in lines[i + 3:j] if ln.strip()]
    assert rows[0] == "Model" and rows[-4:] == ["Residual", "Lack", "Pure", "Cor"]
    assert "D²" not in rows
    assert set(rows[1:-4]) == {_display(t, names) for t in kept if any(t)}

    # (a, c) the actual-units equation: the reduced model refitted by least squares in the
    # actual levels of Table 3 (A 0.5..0.7, B 0.3..0.5, C 0.1..0.3, D 0..0.2), printed to
    # 4 significant digits; it is not the coded equation
    coded_eq = lines[lines.index("Equation in coded factors") + 1].strip()
    actual_eq = lines[lines.index("Equation in actual factors") + 1].strip()
    assert actual_eq.startswith("repose_angle_deg = ") and actual_eq != coded_eq
    printed = _parse_equation(actual_eq)
    centre, half = np.array([0.6, 0.4, 0.2, 0.1]), 0.1
    b, *_ = np.linalg.lstsq(_matrix(centre + half * x, kept), y, rcond=None)
    ref = {("Intercept" if not any(t) else _display(t, names)): v for t, v in zip(kept, b)}
    assert set(printed) == set(ref)
    for term, v in ref.items():
        assert printed[term] == pytest.approx(v, rel=1e-3), term
    # BC is orthogonal to every other column of a Box-Behnken design, so its coefficient
    # is Eq. (4)'s 1.88 in any submodel: 1.88 / (0.1 * 0.1) = 188 in actual units
    assert printed["BC"] == pytest.approx(188.0, abs=0.5)
    assert _parse_equation(coded_eq)["BC"] == pytest.approx(1.88, abs=0.005)

    # (d) the fit summary is printed, with the order test_fit_summary_sequence derives
    # after --reduce it does not call its order "the suggested model" of the reduced fit
    # (issue 19): it names the reduced model's terms instead
    assert not any(ln.startswith("Suggested model") for ln in lines)
    said = [ln for ln in lines if ln.startswith("Fit summary's suggested order: 2FI")]
    assert len(said) == 1 and "reduced quadratic model" in said[0]
    assert set(said[0].rstrip(")").split("terms ")[1].split(", ")) == {_display(t, names) for t in kept if any(t)}


def test_analyze_fit_summary_errors(monkeypatch, capsys):
    import demcal.rsm.summary as summary

    def too_few(*a, **k):
        raise DataError("too few runs")

    monkeypatch.setattr(summary, "fit_summary", too_few)
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg"]) == 0
    cap = capsys.readouterr()
    assert "Equation in actual factors" in cap.out and "Suggested model" not in cap.out
    assert "too few runs" in cap.err

    def broken(*a, **k):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(summary, "fit_summary", broken)
    # a real failure is not hidden: not a warning and a result, but demcal's bug sentence
    monkeypatch.delenv("DEMCAL_DEBUG", raising=False)
    assert main(["analyze", TABLE4, "--response", "repose_angle_deg"]) == 70
    assert "demcal: internal error: ZeroDivisionError: a bug" in capsys.readouterr().err
    monkeypatch.setenv("DEMCAL_DEBUG", "1")
    with pytest.raises(ZeroDivisionError):
        main(["analyze", TABLE4, "--response", "repose_angle_deg"])


def test_analyze_factor_columns_default_and_explicit(tmp_path, capsys):
    assert main(["analyze", TABLE8, "--response", "sliding_angle_deg", "--factors", "E,F,G",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert round(out["anova"][0]["F"], 2) == 363.67

    # Table 4: by default all of A, B, C, D are factors; --factors A,B,C leaves D out
    df = pd.read_csv(TABLE4)
    y = df["repose_angle_deg"].to_numpy(float)
    for arg, names in (([], list("ABCD")), (["--factors", "A,B,C"], list("ABC"))):
        assert main(["analyze", TABLE4, "--response", "repose_angle_deg", *arg, "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        terms = _terms(len(names), "quadratic")
        assert set(out["coefficients"]) == {_json_name(t, names) for t in terms}, arg
        assert out["anova"][0]["df"] == len(terms) - 1
        sse, _ = _sse_rank(_matrix(df[names].to_numpy(float), terms), y)
        assert out["fit"]["r2"] == pytest.approx(1 - sse / np.sum((y - y.mean()) ** 2), rel=1e-9)


def _err(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("demcal: error:")]
    assert len(lines) == 1
    return lines[0]


def test_analyze_bad_inputs(tmp_path, capsys):
    assert main(["analyze", TABLE4, "--response", "nope"]) == 2
    assert "no column 'nope'" in _err(capsys)

    bad = tmp_path / "bad.csv"
    df = pd.read_csv(TABLE4)
    df["B"] = df["B"].astype(object)
    df.loc[3, "B"] = "high"
    df.to_csv(bad, index=False)
    assert main(["analyze", str(bad), "--response", "repose_angle_deg"]) == 2
    assert "'B'" in _err(capsys)

    few = tmp_path / "few.csv"
    pd.read_csv(TABLE4).head(12).to_csv(few, index=False)
    assert main(["analyze", str(few), "--response", "repose_angle_deg"]) == 2
    assert "15 coefficients" in _err(capsys)

    assert main(["analyze", str(tmp_path / "missing.csv"), "--response", "y"]) == 2
    assert "cannot find" in _err(capsys)

    assert main(["analyze", TABLE4, "--response", "repose_angle_deg", "--model", "quartic"]) == 2
    assert "unknown model" in _err(capsys)


def test_analyze_without_replicates_says_so_and_carries_on(tmp_path, capsys):
    norep = tmp_path / "norep.csv"
    pd.read_csv(TABLE4).head(25).to_csv(norep, index=False)  # one centre run only
    assert main(["analyze", str(norep), "--response", "repose_angle_deg", "--json"]) == 0
    cap = capsys.readouterr()
    assert "lack of fit cannot be tested" in cap.err
    sources = [r["source"] for r in json.loads(cap.out)["anova"]]
    assert "Lack of Fit" not in sources and "Cor Total" in sources


def test_fit_rejects_mismatched_input():
    with pytest.raises(DataError):
        fit_response_surface(box_behnken(3, 1), np.ones(5))
    with pytest.raises(DataError):
        fit_response_surface(box_behnken(3, 3), np.r_[np.ones(14), np.nan])
