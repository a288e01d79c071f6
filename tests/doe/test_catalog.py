"""The design catalogue (:mod:`demcal.doe.catalog`): one table of names and options,
one :func:`design_matrix`, the same matrices from ``demcal design`` and a campaign's
``[design]`` table."""

import numpy as np
import pytest

from demcal.campaign.config import DesignConfig
from demcal.cli import build_parser
from demcal.cli.doe import KIND_OPTIONS, build_design
from demcal.doe import designs
from demcal.doe.catalog import (
    DESIGN_KINDS, DESIGN_NAMES, DESIGN_OPTIONS, OPTION_NAMES, design_kind, design_matrix,
)
from demcal.errors import ConfigError

#: Both spellings of every kind that has two.
SPELLINGS = [("box-behnken", "bbd"), ("central-composite", "ccd"), ("full-factorial", "factorial"),
             ("fractional-factorial", "fractional")]


def test_the_alias_table_maps_every_spelling_to_its_kind():
    assert DESIGN_KINDS == {
        "box-behnken": "box-behnken", "bbd": "box-behnken",
        "central-composite": "central-composite", "ccd": "central-composite",
        "full-factorial": "full-factorial", "factorial": "full-factorial",
        "fractional-factorial": "fractional-factorial", "fractional": "fractional-factorial",
        "plackett-burman": "plackett-burman",
    }
    assert set(DESIGN_OPTIONS) == set(DESIGN_NAMES) == set(DESIGN_KINDS.values())
    for spelling, name in DESIGN_KINDS.items():
        assert design_kind(spelling) == name


@pytest.mark.parametrize("long, short", SPELLINGS)
def test_both_spellings_build_the_same_design(long, short):
    k = 4
    assert np.array_equal(design_matrix(long, k), design_matrix(short, k))
    assert np.array_equal(DesignConfig(long).matrix(k), DesignConfig(short).matrix(k))
    cli = build_design(build_parser().parse_args(["design", short, "-k", str(k)]))
    assert np.array_equal(cli.coded, design_matrix(long, k))


def test_the_matrices_are_the_generators_own():
    """Defaults as before: 5 centre points for Box-Behnken, 6 for a CCD, p = 1 for a
    fractional factorial without generators."""
    same = np.array_equal
    assert same(design_matrix("bbd", 3), designs.box_behnken(3, 5))
    assert same(design_matrix("ccd", 4, fraction=1, alpha="orthogonal"),
                designs.central_composite(4, "circumscribed", "orthogonal", 6, 1))
    assert same(design_matrix("ccd", 3, alpha="1.5", variant="inscribed"),
                designs.central_composite(3, "inscribed", 1.5, 6))
    assert same(design_matrix("factorial", 2, levels=3, center=2),
                np.vstack([designs.full_factorial([3, 3]), np.zeros((2, 2))]))
    assert same(design_matrix("fractional", 4), designs.fractional_factorial(4, 1))
    assert same(design_matrix("fractional", 5, generators=["D=AB", "E=-AC"]),
                designs.fractional_factorial(5, None, ["D=AB", "E=-AC"]))
    assert same(design_matrix("fractional", 5, generators="D=AB,E=-AC", fraction=2),
                designs.fractional_factorial(5, 2, ["D=AB", "E=-AC"]))
    assert same(design_matrix("plackett-burman", 3, runs=12), designs.plackett_burman(3, 12))
    # factors given as a sequence count as their number
    assert same(design_matrix("bbd", ["a", "b", "c"]), design_matrix("bbd", 3))


#: (``demcal design`` arguments, the campaign's [design] table as DesignConfig fields).
AGREEING = [
    (["box-behnken", "-k", "3"], dict(type="box-behnken")),
    (["bbd", "-k", "4", "--center", "3"], dict(type="box-behnken", center=3)),
    (["ccd", "-k", "3", "--ccd-type", "face-centred", "--center", "2"],
     dict(type="central-composite", center=2, options={"variant": "face-centred"})),
    (["central-composite", "-k", "4", "--fraction", "1", "--alpha", "orthogonal"],
     dict(type="ccd", options={"fraction": 1, "alpha": "orthogonal"})),
    (["ccd", "-k", "2", "--variant", "inscribed", "--alpha", "1.2"],
     dict(type="ccd", options={"variant": "inscribed", "alpha": 1.2})),
    (["factorial", "-k", "3", "--levels", "3", "--center", "1"],
     dict(type="full-factorial", center=1, options={"levels": 3})),
    (["fractional", "-k", "5", "--fraction", "2"], dict(type="fractional-factorial", options={"fraction": 2})),
    (["fractional-factorial", "-k", "5", "--generators", "D=AB,E=-AC"],
     dict(type="fractional", options={"generators": ["D=AB", "E=-AC"]})),
    (["fractional", "-k", "4"], dict(type="fractional-factorial")),
    (["plackett-burman", "-k", "5", "--runs", "12", "--center", "2"],
     dict(type="plackett-burman", center=2, options={"runs": 12})),
]


@pytest.mark.parametrize("argv, config", AGREEING, ids=[" ".join(a) for a, _ in AGREEING])
def test_the_command_line_and_campaigns_agree(argv, config):
    cli = build_design(build_parser().parse_args(["design", *argv]))
    campaign = DesignConfig(**config).matrix(cli.coded.shape[1])
    assert cli.coded.dtype == campaign.dtype == np.float64
    assert np.array_equal(cli.coded, campaign)


def test_every_catalogue_option_is_an_option_of_the_command():
    assert set(OPTION_NAMES) <= {attr for attr, _, _ in KIND_OPTIONS}
    args = build_parser().parse_args(["design", "ccd", "-k", "2"])
    assert set(OPTION_NAMES) <= set(vars(args))


@pytest.mark.parametrize("call, words", [
    (lambda: design_matrix("box-benken", 3), ["unknown design type 'box-benken'", "did you mean 'box-behnken'?"]),
    (lambda: design_matrix("latin-square", 3), ["unknown design type 'latin-square'", "choose one of",
                                                "central-composite (ccd)"]),
    (lambda: design_matrix("bbd", 3, levels=3), ["option 'levels' does not apply to a box-behnken design",
                                                 "full-factorial (factorial)"]),
    (lambda: design_matrix("ccd", 3, generators="C=AB"), ["'generators'", "central-composite",
                                                          "fractional-factorial (fractional)"]),
    (lambda: design_matrix("ccd", 3, colour="red"), ["unknown design option 'colour'", "variant"]),
    (lambda: design_matrix("factorial", 2, levels=2.5), ["whole number of at least 2", "got 2.5;"]),
    (lambda: design_matrix("fractional", 4, generators=5), ["'generators'", "D=ABC"]),
])
def test_bad_input_is_one_sentence(call, words):
    with pytest.raises(ConfigError) as info:
        call()
    message = str(info.value)
    assert "\n" not in message and message[-1] in ".?", message
    for word in words:
        assert word in message, (word, message)
