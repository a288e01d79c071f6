"""The designs built with pyDOE3 are the ones demcal built before, run for run, and
pyDOE3 is not used where it gives another design.

A campaign's run keys depend on the design matrix (its row order and values), so every
design must stay identical: ``frozen_designs.json`` holds the SHA-256 (first 16 hex
digits) of the float64 matrices that demcal's own generators produced for 408 calls
before pyDOE3 was used (commit 3f67132), with the shape in the hash. The values are
hashed at 12 significant digits, the precision a run key keeps
(``campaign.store.run_key``): the CCD's alpha is a power (``f ** 0.25``) that the C
library may round differently in the last bit on another CPU. The digests were rehashed
this way from the matrices that matched the full-precision ones (2026-11-28).

Published tables: Design-Expert's Box-Behnken order as printed in the reference paper's
Tables 4 and 8 (``test_designs.py``); Montgomery, Design and Analysis of Experiments,
8th ed., Sec. 8.2, the 2^(4-1) design with I = ABCD in standard order.
"""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from demcal.doe import designs

pyDOE3 = pytest.importorskip("pyDOE3")

FROZEN = json.loads((Path(__file__).with_name("frozen_designs.json")).read_text())


def _digest(matrix) -> str:
    m = np.ascontiguousarray(matrix, dtype=np.float64)
    m = np.array([float(f"{v:.12g}") for v in m.ravel()]).reshape(m.shape)
    return hashlib.sha256(repr(m.shape).encode() + m.tobytes()).hexdigest()[:16]


def _label(row) -> str:
    kwargs = "".join(f", {k}={v}" for k, v in row["kwargs"].items())
    return f"{row['design']}({', '.join(map(repr, row['args']))}{kwargs})"


@pytest.mark.parametrize("row", FROZEN, ids=_label)
def test_design_is_identical_run_for_run(row):
    kwargs = {k: tuple(v) for k, v in row["kwargs"].items()}
    matrix = getattr(designs, row["design"])(*row["args"], **kwargs)
    assert matrix.dtype == np.float64
    assert _digest(matrix) == row["sha256_16"]


def _yates(m):
    return ((m > 0) * (1 << np.arange(m.shape[1]))).sum(axis=1)


@pytest.mark.parametrize("k", [3, 4, 5])
@pytest.mark.parametrize("center", [0, 5])
def test_box_behnken_k3_to_5_is_pydoe3s_in_design_expert_order(k, center):
    ours = designs.box_behnken(k, center)
    theirs = pyDOE3.bbdesign(k, center=center)
    assert sorted(map(tuple, ours)) == sorted(map(tuple, theirs))
    # blocks in the order of BOX_BEHNKEN_BLOCKS, Yates order within a block
    for b, block in enumerate(designs.BOX_BEHNKEN_BLOCKS[k]):
        rows = ours[4 * b:4 * b + 4]
        cols = [i - 1 for i in block]
        assert np.all(rows[:, [c for c in range(k) if c not in cols]] == 0)
        assert list(_yates(rows[:, cols])) == [0, 1, 2, 3]


@pytest.mark.parametrize("k, runs", [(6, 48), (7, 56)])
def test_pydoe3_box_behnken_k6_k7_is_not_the_published_design(k, runs):
    """pyDOE3 pairs every two factors (k(k-1)/2 blocks of 4 runs: 60 and 84), so demcal
    keeps the published blocks of three factors (Box & Behnken 1960: 48 and 56 runs)."""
    assert pyDOE3.bbdesign(k, center=0).shape[0] == 2 * k * (k - 1)
    assert designs.box_behnken(k, 0).shape[0] == runs


@pytest.mark.parametrize("levels", [[2, 2, 2], [3, 2], [2, 3, 4], [5]])
def test_full_factorial_is_pydoe3s_fullfact(levels):
    index = pyDOE3.fullfact(levels)
    expected = np.column_stack([np.linspace(-1, 1, n)[index[:, j].astype(int)]
                                for j, n in enumerate(levels)])
    assert np.array_equal(designs.full_factorial(levels), expected)


def test_fractional_factorial_montgomery_2_4_1():
    # Montgomery 2013, Sec. 8.2: the 2^(4-1) design, I = ABCD (D = ABC), standard order
    table = """- - - -
               + - - +
               - + - +
               + + - -
               - - + +
               + - + -
               - + + -
               + + + +"""
    expected = np.array([[1.0 if c == "+" else -1.0 for c in line.split()]
                         for line in table.splitlines()])
    assert np.array_equal(designs.fractional_factorial(4, 1), expected)


@pytest.mark.parametrize("k, p", sorted(designs.FRACTION_GENERATORS))
def test_fractional_factorial_is_pydoe3s_fracfact_in_yates_order(k, p):
    ours = designs.fractional_factorial(k, p)
    letters = "ABCDEFGHJK"[:k]
    spec = list("abcdefghij"[:k - p]) + [
        "".join("abcdefghij"[letters.index(c)] for c in g.split("=")[1])
        for g in designs.FRACTION_GENERATORS[(k, p)]]
    theirs = pyDOE3.fracfact(" ".join(spec))
    assert sorted(map(tuple, ours)) == sorted(map(tuple, theirs))
    assert list(_yates(ours[:, :k - p])) == list(range(2 ** (k - p)))


@pytest.mark.parametrize("k", [2, 3, 4, 5])
@pytest.mark.parametrize("face", ["ccc", "cci", "ccf"])
def test_ccd_is_pydoe3s_ccdesign_where_it_has_the_design(k, face):
    """Full factorial part, rotatable (or face-centred) alpha: pyDOE3's ccdesign with the
    factorial rows (its ff2n order, last factor fastest) in Yates order."""
    center = 4
    ours = designs.central_composite(k, face, "rotatable", center)
    theirs = pyDOE3.ccdesign(k, center=(0, center), alpha="rotatable", face=face)
    f = 2 ** k
    fact = theirs[:f]
    fact = fact[np.argsort(_yates(np.sign(fact)))]
    assert np.array_equal(ours, np.vstack([fact, theirs[f:]]))


def test_pydoe3s_orthogonal_alpha_is_another_one():
    """pyDOE3's "orthogonal" alpha is for orthogonal blocking; demcal's makes the
    quadratic columns uncorrelated (Montgomery 2013, Sec. 11.4.2), so demcal keeps its own."""
    _, theirs = pyDOE3.doe_star.star(3, alpha="orthogonal", center=(0, 6))
    assert theirs != pytest.approx(designs.ccd_alpha(3, "orthogonal", center=6))
    d = designs.central_composite(3, alpha="orthogonal", center=6)
    sq = d ** 2 - (d ** 2).mean(axis=0)
    assert sq[:, 0] @ sq[:, 1] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("n_factors", [7, 11, 15, 19, 23])
def test_pydoe3s_plackett_burman_is_not_the_published_table(n_factors):
    """pyDOE3's pbdesign builds other Hadamard matrices (not one has the rows of the
    cyclic tables of Plackett & Burman 1946), so demcal keeps the published ones."""
    ours = designs.plackett_burman(n_factors)
    theirs = pyDOE3.pbdesign(n_factors)
    assert theirs.shape == ours.shape
    assert sorted(map(tuple, theirs)) != sorted(map(tuple, ours))
    # every run of the published design, cyclic: row i is the generator shifted by i
    gen = ours[0]
    for i in range(1, ours.shape[0] - 1):
        assert np.array_equal(ours[i], np.roll(gen, i))

