"""Impact test: the measured restitution is the set one (issue 4, acceptance 2).

Closed forms: for the Hysteretic Spring model without extra damping the restitution is
e = sqrt(K1 / K2) (Walton & Braun 1986; the paper's Eq. 3), and the EDEM Hertz-Mindlin
damping (Tsuji et al. 1992) is built so that a head-on impact rebounds with e.
"""

import pytest

from demcal.bench.registry import get_experiment

IMPACT = get_experiment("impact")


@pytest.mark.parametrize("target, key", [("particle", "particle"), ("wall", "wall"), ("film", "film")])
@pytest.mark.parametrize("e", [0.5, 0.7])
def test_hysteretic_spring_returns_set_restitution(target, key, e):
    r = IMPACT.run({"impact.target": target, f"{key}.restitution": e, f"{key}.damping_factor": 0.0},
                   seed=0, profile="quick")
    assert r.responses["restitution"] == pytest.approx(e, rel=0.01)


@pytest.mark.parametrize("e", [0.3, 0.6, 0.9])
def test_hertz_mindlin_returns_set_restitution(e):
    r = IMPACT.run({"contact.model": "hertz_mindlin", "particle.restitution": e}, seed=0, profile="quick")
    assert r.responses["restitution"] == pytest.approx(e, rel=0.01)


def test_hysteretic_damping_factor_lowers_the_rebound():
    plain = IMPACT.run({"particle.damping_factor": 0.0}, profile="quick").responses["restitution"]
    damped = IMPACT.run({"particle.damping_factor": 0.2}, profile="quick").responses["restitution"]
    assert damped < plain - 0.01


def test_result_shape():
    d = IMPACT.run({}, profile="tiny").to_dict()
    for key in ("test", "responses", "spread", "particles", "steps", "simulated_s", "wall_s",
                "particle_steps_per_s"):
        assert key in d
    assert d["test"] == "impact" and d["particles"] == 2 and d["steps"] > 0
