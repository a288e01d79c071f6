"""Sub-model registry: every declared sub-model (:mod:`.declare`) by slot and name.

A contact model is four sub-models in fixed slots (LAMMPS GRANULAR layout):
``normal``, ``damping``, ``tangential`` and ``rolling``. Each slot module lists its
sub-models in ``MODELS``; this module collects them, maps names and aliases to the
integer ids the kernels dispatch on, lays out the contact history from the declared
fields and names the presets. Adding a sub-model is one kernel branch plus one
``SubModel`` row in its slot module.
"""

from __future__ import annotations

from dataclasses import dataclass

from demcal.errors import ConfigError

from . import damping, normal, rolling, tangential
from .damping import (DAMPING_HYSTERETIC, DAMPING_NONE, DAMPING_TSUJI,  # noqa: F401
                      DAMPING_VISCOUS)
from .declare import FASTMATH, SLOTS, SubModel  # noqa: F401
from .normal import NORMAL_HERTZ, NORMAL_HYSTERETIC, NORMAL_LINEAR  # noqa: F401
from .rolling import (ROLLING_CONSTANT, ROLLING_EPSD, ROLLING_LIMITED,  # noqa: F401
                      ROLLING_NONE, ROLLING_RELATIVE, ROLLING_RVD)
from .tangential import TANGENTIAL_LINEAR, TANGENTIAL_MINDLIN, TANGENTIAL_NONE  # noqa: F401

#: every sub-model, by slot, in id order
SUBMODELS: dict[str, tuple[SubModel, ...]] = {
    "normal": normal.MODELS, "damping": damping.MODELS,
    "tangential": tangential.MODELS, "rolling": rolling.MODELS}


def _names(slot: str) -> dict:
    out = {}
    for m in SUBMODELS[slot]:
        for name in m.names:
            out[name] = m.id
    return out


NORMAL = _names("normal")
DAMPING = _names("damping")
TANGENTIAL = _names("tangential")
ROLLING = _names("rolling")


def submodel(slot: str, ident: int) -> SubModel:
    """The declaration of sub-model ``ident`` of ``slot``."""
    for m in SUBMODELS[slot]:
        if m.id == ident:
            return m
    raise KeyError(f"no {slot} sub-model with id {ident}")


def _history_layout():
    # the slots in the order their history has been laid out since checkpoint format 1
    # (tangential displacement 0:3, residual overlap 3, rolling spring torque 4:7), so
    # that old checkpoints keep their meaning; a new field goes after them
    columns, vectors, col = {}, [], 0
    for slot in ("tangential", "normal", "rolling", "damping"):
        for m in SUBMODELS[slot]:
            for f in m.history:
                if f.name in columns:
                    continue
                columns[f.name] = col
                if f.vector:
                    vectors += [col, col + 1, col + 2]
                col += f.width
    return columns, tuple(vectors), col


#: column of each declared history field; VECTOR_COLUMNS: the columns of the 3-vectors
#: (negated when a reordering swaps a pair's sides); the contact flag comes last
HISTORY_COLUMNS, VECTOR_COLUMNS, H_FLAG = _history_layout()
HIST_WIDTH = H_FLAG + 1

#: contact_model presets -> (normal, damping, tangential)
PRESETS = {
    "hertz_mindlin": ("hertz", "tsuji", "mindlin"),
    "hysteretic_spring": ("hysteretic", "hysteretic", "linear"),
    "hscm": ("hysteretic", "hysteretic", "linear"),
    "linear": ("linear", "viscous", "linear"),
    "hertz_mindlin_jkr": ("jkr", "tsuji", "mindlin"),
}
#: other spellings of presets above
PRESET_ALIASES = {"hscm": "hysteretic_spring"}


def preset_names() -> tuple:
    """The presets by their own names (no aliases)."""
    return tuple(p for p in PRESETS if p not in PRESET_ALIASES)


def rolling_names() -> tuple:
    """The rolling sub-models by their own names (no aliases)."""
    return tuple(m.name for m in SUBMODELS["rolling"])


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
    normal : {"hertz", "hysteretic", "linear", "jkr"}
    damping : {"tsuji", "hysteretic", "viscous", "none"}
    tangential : {"mindlin", "linear", "none"}
    rolling : {"none", "type_a" (= "constant"), "cdt" (= "relative"), "type_c" (= "epsd"),
               "type_a_limited" (= "constant_limited"), "rvd"}

    Each slot's names are those its module declares (``registry.SUBMODELS``).
    """

    normal: str = "hertz"
    damping: str = "tsuji"
    tangential: str = "mindlin"
    rolling: str = "type_a"

    @classmethod
    def preset(cls, contact_model: str = "hertz_mindlin",
               rolling_model: str = "type_a") -> "ContactModel":
        """Build from a preset name (``hertz_mindlin``, ``hysteretic_spring``, ``linear``,
        ``hertz_mindlin_jkr``)."""
        key = contact_model.lower() if isinstance(contact_model, str) else contact_model
        if key not in PRESETS:
            raise ConfigError(
                f"unknown contact_model {contact_model!r}; choose one of {sorted(PRESETS)}.")
        n, d, t = PRESETS[key]
        model = cls(n, d, t, rolling_model)
        model.ids()
        return model

    def ids(self) -> tuple:
        """Integer ids (normal, damping, tangential, rolling); ConfigError (one sentence)
        if a name is unknown or a sub-model does not fit with another (``requires``)."""
        ids = (_lookup(NORMAL, self.normal, "normal model"),
               _lookup(DAMPING, self.damping, "damping model"),
               _lookup(TANGENTIAL, self.tangential, "tangential model"),
               _lookup(ROLLING, self.rolling, "rolling_model"))
        chosen = {slot: submodel(slot, i) for slot, i in zip(SLOTS, ids)}
        for m in chosen.values():
            for slot, fits in m.requires:
                if chosen[slot].name not in fits:
                    raise ConfigError(
                        f"the {m.name} {m.slot} model does not fit with the "
                        f"{chosen[slot].name} {slot} model; choose {slot} from "
                        f"{list(fits)}.")
        return ids

    def submodels(self) -> tuple:
        """The four declarations (normal, damping, tangential, rolling)."""
        return tuple(submodel(slot, i) for slot, i in zip(SLOTS, self.ids()))

    def coefficients(self) -> tuple:
        """The interaction coefficients the four sub-models read, each once."""
        out = []
        for m in self.submodels():
            out += [c for c in m.coefficients if c not in out]
        return tuple(out)
