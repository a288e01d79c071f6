"""The chosen sub-models reach the compiled loops as constants of their type.

``contact/chosen.Chosen`` puts the four sub-model ids into the numba type of the drivers'
first argument (docs/dem-contact.md, "Compiled for the chosen combination only"): inside
compiled code ``chosen.normal`` etc. are the ids, and each combination has a signature of
its own.
"""

import pickle

import numpy as np
import pytest
from numba import njit

from demcal.dem import Simulation
from demcal.dem.contact.chosen import Chosen, ChosenType
from demcal.dem.contact.registry import ContactModel
from demcal.particles.materials import soil, soil_interaction


@njit(cache=False)
def _slots(chosen):
    return chosen.normal, chosen.damping, chosen.tangential, chosen.rolling


def test_ids_are_read_from_the_type():
    assert _slots(Chosen((2, 0, 1, 5))) == (2, 0, 1, 5)
    assert _slots(Chosen((0, 1, 0, 3))) == (0, 1, 0, 3)
    # one specialisation per combination, its ids in the signature
    sigs = {s[0] for s in _slots.signatures}
    assert sigs == {ChosenType((2, 0, 1, 5)), ChosenType((0, 1, 0, 3))}


def test_value_semantics_and_one_id_per_slot():
    assert Chosen([1, 2, 3, 4]) == Chosen((1, 2, 3, 4))
    assert len({Chosen((1, 2, 3, 4)), Chosen((1, 2, 3, 4))}) == 1
    assert Chosen((1, 2, 3, 4)) != Chosen((1, 2, 3, 5))
    with pytest.raises(ValueError, match="one id per slot"):
        Chosen((1, 2, 3))
    # a campaign worker may receive a description by pickle
    back = pickle.loads(pickle.dumps(Chosen((1, 2, 0, 3))))
    assert back == Chosen((1, 2, 0, 3)) and back._numba_type_ == ChosenType((1, 2, 0, 3))


@pytest.mark.parametrize("model", [ContactModel("hertz", "tsuji", "mindlin", "cdt"),
                                   ContactModel("hysteretic", "hysteretic", "linear",
                                                "type_a")])
def test_simulation_compiles_its_own_combination(model):
    sim = Simulation([soil()], soil_interaction(), contact_model=model)
    d = sim.description
    assert d.chosen.ids == tuple(int(i) for i in d.models) == model.ids()
    sim.add_particles(0.004, [[0.0, 0.0, 0.004], [0.0, 0.0, 0.0119]])
    sim.run(steps=50)
    assert np.all(np.isfinite(sim.state.positions))
    # the drivers the simulation calls carry the combination in their signatures, whether
    # compiled here or loaded from numba's cache (pair_forces, called inside them, is
    # compiled only when they are, so a warm cache leaves it without signatures)
    from numba.core.registry import CPUDispatcher

    from demcal.dem import stepper

    drivers = [v for v in vars(stepper).values() if isinstance(v, CPUDispatcher)]
    compiled = {arg for driver in drivers for signature in driver.signatures for arg in signature}
    assert ChosenType(model.ids()) in compiled
