"""Design generators checked against published tables.

Sources
-------
* Reference paper (IJABE 2020, DOI 10.25165/j.ijabe.20201304.5586), Table 4 (Box-Behnken,
  4 factors, Design-Expert standard order) and Table 8 (Box-Behnken, 3 factors).
* Box & Behnken (1960), Technometrics 2(4) 455-475: designs for k = 6 (48 runs, blocks
  of three factors) and k = 7 (56 runs, balanced incomplete blocks), as reprinted in
  Myers, Montgomery & Anderson-Cook, Response Surface Methodology (Wiley).
* Plackett & Burman (1946), Biometrika 33, 305-325: cyclic generator rows.
* Montgomery, Design and Analysis of Experiments, 8th ed.: Example 11.1 (steepest
  ascent), Example 11.2 (rotatable CCD, alpha = 1.414), Sec. 11.4 (rotatability).
"""

import itertools

import numpy as np
import pandas as pd
import pytest

from demcal.doe import (
    BOX_BEHNKEN_RUNS, Design, Factor, box_behnken, ccd_alpha, central_composite,
    fractional_factorial, full_factorial, parse_factor, plackett_burman, steepest_ascent,
)
from demcal.errors import ConfigError

DATA = pd.read_csv(
    __import__("importlib.resources").resources.files("demcal") / "data" / "paper_table4_repose_bbd.csv"
)
DATA8 = pd.read_csv(
    __import__("importlib.resources").resources.files("demcal") / "data" / "paper_table8_sliding_bbd.csv"
)


def _expand(pattern_rows):
    """Rows written as in the published tables: '±1' expands to -1 and +1 (first factor fastest)."""
    out = []
    for pattern in pattern_rows:
        cells = pattern.split()
        pm = [i for i, c in enumerate(cells) if c == "±1"]
        for signs in itertools.product((-1, 1), repeat=len(pm)):
            row = [0.0] * len(cells)
            for i, s in zip(pm, signs[::-1]):
                row[i] = float(s)
            out.append(tuple(row))
    return out


@pytest.mark.parametrize("k, runs", sorted(BOX_BEHNKEN_RUNS.items()))
def test_box_behnken_published_run_counts(k, runs):
    assert runs == {3: 12, 4: 24, 5: 40, 6: 48, 7: 56}[k]
    assert box_behnken(k, center=0).shape == (runs, k)
    d = box_behnken(k, center=3)
    assert d.shape == (runs + 3, k)
    assert np.all(d[-3:] == 0)
    # every factor at -1 and +1 equally often, linear columns orthogonal
    assert np.allclose(d.sum(axis=0), 0)
    assert np.allclose(d.T @ d, np.diag(np.diag(d.T @ d)))
    assert len(set(np.diag(d.T @ d))) == 1


def test_box_behnken_k4_matches_paper_table4_rows():
    d = box_behnken(4, center=5)
    assert np.array_equal(d, DATA[["A", "B", "C", "D"]].to_numpy(dtype=float))


def test_box_behnken_k3_matches_paper_table8_rows():
    d = box_behnken(3, center=5)
    assert np.array_equal(d, DATA8[["E", "F", "G"]].to_numpy(dtype=float))


#: Box & Behnken (1960) generator rows for k = 6 (blocks of three factors) and k = 7
#: (balanced incomplete blocks).
PUBLISHED_BBD = {
    6: [
        "±1 ±1 0 ±1 0 0",
        "0 ±1 ±1 0 ±1 0",
        "0 0 ±1 ±1 0 ±1",
        "±1 0 0 ±1 ±1 0",
        "0 ±1 0 0 ±1 ±1",
        "±1 0 ±1 0 0 ±1",
    ],
    7: [
        "0 0 0 ±1 ±1 ±1 0",
        "±1 0 0 0 0 ±1 ±1",
        "0 ±1 0 0 ±1 0 ±1",
        "±1 ±1 0 ±1 0 0 0",
        "0 0 ±1 ±1 0 0 ±1",
        "±1 0 ±1 0 ±1 0 0",
        "0 ±1 ±1 0 0 ±1 0",
    ],
}


@pytest.mark.parametrize("k", sorted(PUBLISHED_BBD))
def test_box_behnken_k6_k7_published_rows(k):
    d = box_behnken(k, center=0)
    assert sorted(map(tuple, d)) == sorted(_expand(PUBLISHED_BBD[k]))


def test_box_behnken_k7_balanced_incomplete_blocks():
    # every pair of factors varied together in 8 runs
    nz = box_behnken(7, center=0) != 0
    pair_counts = {(i, j): int(np.sum(nz[:, i] & nz[:, j])) for i, j in itertools.combinations(range(7), 2)}
    assert set(pair_counts.values()) == {8}


def test_box_behnken_k3_to_5_agree_with_pydoe3_and_k6_k7_do_not():
    pydoe3 = pytest.importorskip("pyDOE3")
    for k in (3, 4, 5):
        ours = sorted(map(tuple, box_behnken(k, 0)))
        theirs = sorted(map(tuple, pydoe3.bbdesign(k, center=0).astype(float)))
        assert ours == theirs
    # pyDOE3 pairs all factors for k >= 6 (60 and 84 runs, not the published 48 and 56)
    assert box_behnken(6, 0).shape[0] == 48 and box_behnken(7, 0).shape[0] == 56


def test_box_behnken_rejects_k_outside_3_to_7():
    with pytest.raises(ConfigError):
        box_behnken(8)


def test_ccd_rotatable_montgomery_example_11_2():
    # Montgomery Example 11.2: time 80..90 min, temperature 170..180 F, alpha = 1.414,
    # axial runs at 77.93 / 92.07 min and 167.93 / 182.07 F, 5 centre runs, 13 runs.
    d = central_composite(2, "circumscribed", "rotatable", center=5)
    assert d.shape == (13, 2)
    time, temp = Factor("time", 80, 90, "min"), Factor("temperature", 170, 180, "F")
    design = Design("ccd", (time, temp), d)
    actual = design.actual
    assert sorted(np.round(actual[4:8, 0], 2)) == [77.93, 85.0, 85.0, 92.07]
    assert sorted(np.round(actual[4:8, 1], 2)) == [167.93, 175.0, 175.0, 182.07]
    assert ccd_alpha(3) == pytest.approx(1.682, abs=5e-4)
    assert ccd_alpha(4) == pytest.approx(2.0)


@pytest.mark.parametrize("k", [2, 3, 4, 5])
def test_ccd_rotatable_moment_condition(k):
    # rotatability (Box & Hunter 1957): sum x_i^4 = 3 sum x_i^2 x_j^2
    d = central_composite(k, alpha="rotatable", center=4)
    assert np.sum(d[:, 0] ** 4) == pytest.approx(3 * np.sum(d[:, 0] ** 2 * d[:, 1] ** 2))


def test_ccd_orthogonal_alpha_makes_squares_uncorrelated():
    d = central_composite(3, alpha="orthogonal", center=6)
    sq = d**2 - (d**2).mean(axis=0)
    assert sq[:, 0] @ sq[:, 1] == pytest.approx(0.0, abs=1e-9)


def test_ccd_face_centred_and_inscribed():
    f = central_composite(3, "face-centred", center=1)
    assert f.shape == (15, 3) and np.abs(f).max() == 1.0
    i = central_composite(3, "inscribed", "rotatable", center=1)
    assert np.abs(i).max() == pytest.approx(1.0)
    assert np.abs(i[0]).max() == pytest.approx(1 / ccd_alpha(3))


def test_plackett_burman_published_generator_and_orthogonality():
    d = plackett_burman(11)
    assert d.shape == (12, 11)
    assert "".join("+" if v > 0 else "-" for v in d[0]) == "++-+++---+-"  # Plackett & Burman 1946
    assert np.all(d[-1] == -1)
    for n in (8, 12, 16, 20, 24):
        m = plackett_burman(n - 1, n)
        assert np.allclose(m.T @ m, n * np.eye(n - 1))
    assert plackett_burman(5).shape == (8, 5)


def test_factorials():
    assert full_factorial(3).shape == (8, 3)
    f = full_factorial([3, 2])
    assert f.shape == (6, 2) and set(f[:, 0]) == {-1.0, 0.0, 1.0}
    h = fractional_factorial(4, 1)  # 2^(4-1), D = ABC
    assert h.shape == (8, 4)
    assert np.array_equal(h[:, 3], h[:, 0] * h[:, 1] * h[:, 2])
    g = fractional_factorial(5, generators=["D=AB", "E=-AC"])
    assert np.array_equal(g[:, 4], -g[:, 0] * g[:, 2])
    with pytest.raises(ConfigError):
        fractional_factorial(4, generators=["D=AE"])


def test_steepest_ascent_montgomery_example_11_1():
    # Montgomery Example 11.1: y = 40.44 + 0.775 x1 + 0.325 x2, base step 1 in x1 gives
    # 0.42 in x2; in natural units 5 min and about 2 F per step.
    path = steepest_ascent([0.775, 0.325], step=1.0, n_steps=3)
    assert path[1] == pytest.approx([1.0, 0.4194], abs=1e-4)
    assert path[3] == pytest.approx([3.0, 1.2581], abs=1e-4)
    design = Design("sa", (Factor("time", 30, 40), Factor("temp", 150, 160)), path)
    assert design.actual[1] == pytest.approx([40.0, 157.097], abs=1e-3)
    assert steepest_ascent([0.775, 0.325], descent=True, n_steps=1)[1][0] == -1.0


def test_factor_coding_and_parsing():
    f = parse_factor("e=0.5:0.7[-]")
    assert (f.name, f.low, f.high, f.units) == ("e", 0.5, 0.7, "-")
    assert f.to_coded(0.55) == pytest.approx(-0.5)
    assert f.to_actual(f.to_coded([0.5, 0.63])) == pytest.approx([0.5, 0.63])
    for bad in ("e", "e=0.7:0.5", "e=a:b"):
        with pytest.raises(ConfigError):
            parse_factor(bad)


def test_run_order_is_reproducible_from_seed():
    d = Design("bbd", tuple(Factor(n) for n in "ABC"), box_behnken(3, 5))
    a, b = d.randomized(7), d.randomized(7)
    assert np.array_equal(a.run_order, b.run_order)
    assert sorted(a.run_order) == list(range(1, 18))
    assert not np.array_equal(a.run_order, np.arange(1, 18))
    frame = a.to_frame()
    assert list(frame["run"]) == list(range(1, 18))
    # the rows of the frame are the standard-order rows permuted
    assert np.allclose(frame[["A", "B", "C"]].to_numpy(), d.coded[frame["std_order"] - 1])
