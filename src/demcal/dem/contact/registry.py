"""Sub-model registry: names -> integer ids, one table per slot.

A contact model is four sub-models in fixed slots (LAMMPS GRANULAR layout):
``normal``, ``damping``, ``tangential`` and ``rolling``. Each slot maps names to small
integers; the kernels dispatch once per slot on that integer, so adding a sub-model is
one kernel branch plus one row here. Presets name common combinations.
"""

from __future__ import annotations

from dataclasses import dataclass

from demcal.errors import ConfigError

#: Floating-point licences of the contact kernels when compiled on their own: fused
#: multiply-add, reciprocals, reassociation and signed zeros, but not "no NaN / no inf"
#: (a blow-up must still propagate to the positions, where the step loop detects it).
FASTMATH = {"contract", "arcp", "reassoc", "nsz"}
#: The contact loops (``dem/forces.py``), into which the kernels are inlined at numba IR
#: level and whose flags therefore apply: fused multiply-add and reciprocals only, so
#: that every sum keeps its order (results independent of the thread count).
LOOP_FASTMATH = {"contract", "arcp"}

# normal slot
NORMAL_HERTZ = 0
NORMAL_HYSTERETIC = 1
NORMAL_LINEAR = 2
# damping slot
DAMPING_NONE = 0
DAMPING_TSUJI = 1        # EDEM Hertz-Mindlin: 2 sqrt(5/6) beta sqrt(Sn m*)
DAMPING_HYSTERETIC = 2   # paper Eq. 3: 2 zeta beta sqrt(K m*)
DAMPING_VISCOUS = 3      # linear spring-dashpot: 2 beta sqrt(k m*)
# tangential slot
TANGENTIAL_NONE = 0
TANGENTIAL_MINDLIN = 1   # St = 8 G* sqrt(R* delta), EDEM no-slip
TANGENTIAL_LINEAR = 2    # kt = xi K1, paper Eq. 3
# rolling slot
ROLLING_NONE = 0
ROLLING_CONSTANT = 1     # EDEM type A: -mu_r Fn R_i w_i/|w_i|
ROLLING_RELATIVE = 2     # LIGGGHTS 3.8 cdt: -mu_r k_n delta R* w_t/|w_r|
ROLLING_EPSD = 3         # EDEM type C, Ai et al. 2011

NORMAL = {"hertz": NORMAL_HERTZ, "hysteretic": NORMAL_HYSTERETIC, "linear": NORMAL_LINEAR}
DAMPING = {"none": DAMPING_NONE, "tsuji": DAMPING_TSUJI,
           "hysteretic": DAMPING_HYSTERETIC, "viscous": DAMPING_VISCOUS}
TANGENTIAL = {"none": TANGENTIAL_NONE, "mindlin": TANGENTIAL_MINDLIN,
              "linear": TANGENTIAL_LINEAR}
ROLLING = {"none": ROLLING_NONE, "type_a": ROLLING_CONSTANT, "constant": ROLLING_CONSTANT,
           "cdt": ROLLING_RELATIVE, "relative": ROLLING_RELATIVE,
           "type_c": ROLLING_EPSD, "epsd": ROLLING_EPSD}

#: contact_model presets -> (normal, damping, tangential)
PRESETS = {
    "hertz_mindlin": ("hertz", "tsuji", "mindlin"),
    "hysteretic_spring": ("hysteretic", "hysteretic", "linear"),
    "hscm": ("hysteretic", "hysteretic", "linear"),
    "linear": ("linear", "viscous", "linear"),
}


def _lookup(table: dict, name, parameter: str) -> int:
    if isinstance(name, str) and name.lower() in table:
        return table[name.lower()]
    raise ConfigError(
        f"unknown {parameter} {name!r}; choose one of {sorted(table)}.")


@dataclass(frozen=True)
class ContactModel:
    """A contact model: one sub-model per slot, by name.

    Parameters
    ----------
    normal : {"hertz", "hysteretic", "linear"}
    damping : {"tsuji", "hysteretic", "viscous", "none"}
    tangential : {"mindlin", "linear", "none"}
    rolling : {"none", "type_a" (= "constant"), "cdt" (= "relative"), "type_c" (= "epsd")}
    """

    normal: str = "hertz"
    damping: str = "tsuji"
    tangential: str = "mindlin"
    rolling: str = "type_a"

    @classmethod
    def preset(cls, contact_model: str = "hertz_mindlin",
               rolling_model: str = "type_a") -> "ContactModel":
        """Build from a preset name (``hertz_mindlin``, ``hysteretic_spring``, ``linear``)."""
        key = contact_model.lower() if isinstance(contact_model, str) else contact_model
        if key not in PRESETS:
            raise ConfigError(
                f"unknown contact_model {contact_model!r}; choose one of {sorted(PRESETS)}.")
        n, d, t = PRESETS[key]
        model = cls(n, d, t, rolling_model)
        model.ids()
        return model

    def ids(self) -> tuple:
        """Integer ids (normal, damping, tangential, rolling); ConfigError if unknown."""
        return (_lookup(NORMAL, self.normal, "normal model"),
                _lookup(DAMPING, self.damping, "damping model"),
                _lookup(TANGENTIAL, self.tangential, "tangential model"),
                _lookup(ROLLING, self.rolling, "rolling_model"))
