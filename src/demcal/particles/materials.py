"""Materials and material-pair interactions, laid out as in EDEM.

A :class:`Material` holds the per-material bulk properties (density, shear modulus,
Poisson ratio, yield strength); an :class:`Interaction` holds the per-pair contact
properties (restitution, static and rolling friction, and the Hysteretic Spring
model's damping and stiffness factors). Walls have materials too: a wall made of
steel uses the (particle material, steel) interaction.

The defaults of :func:`soil` are the paper's Table 2 (Xie et al., IJABE 13(4), 2020,
DOI 10.25165/j.ijabe.20201304.5586): Poisson ratio 0.46, density 1687.85 kg/m3,
shear modulus 1e6 Pa; restitution 0.6, static friction 0.4, rolling ("dynamic")
friction 0.2, damping factor 0.1 (centres of the Table 2 ranges), stiffness factor
0.95. The paper does not state a yield strength; :data:`SOIL_YIELD_STRENGTH` = 1e6 Pa
is our choice (equal to the shear modulus) and is documented as such.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from demcal.errors import ConfigError

#: Yield strength [Pa] used for the paper's soil (the paper does not state one).
SOIL_YIELD_STRENGTH = 1.0e6


def _finite(value, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number, got {value!r}.") from None
    if not math.isfinite(x):
        raise ConfigError(f"{name} must be a finite number, got {value!r}.")
    return x


@dataclass(frozen=True)
class Material:
    """Bulk properties of one material (particle or wall).

    Parameters
    ----------
    density : float
        Density [kg/m3], > 0.
    shear_modulus : float
        Shear modulus G [Pa], > 0. Young's modulus is ``E = 2 G (1 + poisson_ratio)``.
    poisson_ratio : float
        Poisson ratio, in [0, 0.5).
    yield_strength : float
        Yield strength [Pa] used by the Hysteretic Spring and linear spring models
        (loading stiffness ``K1 = 5 R* min(Y_i, Y_j)``, Walton 2006), > 0.
    name : str
        Label used in error messages and outputs.
    """

    density: float
    shear_modulus: float
    poisson_ratio: float
    yield_strength: float = SOIL_YIELD_STRENGTH
    name: str = "material"

    def __post_init__(self):
        d = _finite(self.density, f"{self.name}.density")
        g = _finite(self.shear_modulus, f"{self.name}.shear_modulus")
        nu = _finite(self.poisson_ratio, f"{self.name}.poisson_ratio")
        y = _finite(self.yield_strength, f"{self.name}.yield_strength")
        if d <= 0:
            raise ConfigError(f"{self.name}.density must be > 0 kg/m3, got {d}.")
        if g <= 0:
            raise ConfigError(f"{self.name}.shear_modulus must be > 0 Pa, got {g}.")
        if not 0.0 <= nu < 0.5:
            raise ConfigError(f"{self.name}.poisson_ratio must be in [0, 0.5), got {nu}.")
        if y <= 0:
            raise ConfigError(f"{self.name}.yield_strength must be > 0 Pa, got {y}.")
        object.__setattr__(self, "density", d)
        object.__setattr__(self, "shear_modulus", g)
        object.__setattr__(self, "poisson_ratio", nu)
        object.__setattr__(self, "yield_strength", y)

    @property
    def youngs_modulus(self) -> float:
        """Young's modulus E = 2 G (1 + nu) [Pa]."""
        return 2.0 * self.shear_modulus * (1.0 + self.poisson_ratio)

    @classmethod
    def from_youngs_modulus(cls, youngs_modulus, poisson_ratio, density,
                            yield_strength=SOIL_YIELD_STRENGTH,
                            name: str = "material") -> "Material":
        """A material given by Young's modulus E [Pa] instead of the shear modulus.

        The engine keeps G (EDEM's material table does), here G = E / (2 (1 + nu)),
        the isotropic elastic relation (e.g. Timoshenko & Goodier, Theory of
        Elasticity, 3rd ed., 1970, section 4). ``poisson_ratio`` in [0, 0.5),
        ``density`` [kg/m3], ``yield_strength`` [Pa] and ``name`` as for
        :class:`Material`.

        >>> Material.from_youngs_modulus(2.6e6, 0.3, 1500.0).shear_modulus
        1000000.0
        """
        e = _finite(youngs_modulus, f"{name}.youngs_modulus")
        if e <= 0:
            raise ConfigError(f"{name}.youngs_modulus must be > 0 Pa, got {e}.")
        nu = _finite(poisson_ratio, f"{name}.poisson_ratio")
        return cls(density=density, shear_modulus=e / (2.0 * (1.0 + nu)),
                   poisson_ratio=nu, yield_strength=yield_strength, name=name)


@dataclass(frozen=True, init=False)
class Interaction:
    """Contact properties of one material pair (EDEM's interaction table).

    Parameters
    ----------
    restitution : float
        Coefficient of restitution e, in (0, 1].
    static_friction : float
        Coefficient of static (sliding) friction mu_s, >= 0.
    rolling_friction : float
        Coefficient of rolling friction mu_r, >= 0 (the paper's "dynamic friction").
    damping_factor : float
        Hysteretic Spring damping factor zeta (paper Eq. 3), >= 0: extra viscous
        normal damping ``c = 2 zeta |beta| sqrt(m* K)`` with K the branch stiffness.
    stiffness_factor : float
        Hysteretic Spring / linear model stiffness factor xi (paper Eq. 3), > 0:
        tangential stiffness ``k_t = xi K1``.
    rolling_damping : float
        Viscous damping ratio eta_r of the elastic-plastic spring-dashpot rolling model
        (Ai et al. 2011, their Eq. 14), in [0, 1]; 0.3 as in their tests.
    **coefficients : float
        Coefficients of other contact sub-models, by the name the sub-model declares
        (``surface_energy=0.05`` for JKR cohesion, say; the engine checks the name and
        the range when it builds its pair table, :mod:`demcal.dem.contact.table`). A
        sub-model's declared default applies where one is not given.

    Notes
    -----
    ``Interaction()`` with no arguments is the paper's soil-soil pair (Xie et al. 2020,
    Table 2) except for the damping factor: restitution 0.6, static friction 0.4 and
    rolling friction 0.2 are the centres of the Table 2 ranges, stiffness factor 0.95
    the paper's default xi, but ``damping_factor`` defaults to 0 (no extra damping: the
    restitution is then exactly ``e``), where :func:`soil_interaction` takes the
    Table 2 centre 0.1. ``rolling_damping`` 0.3 is Ai et al.'s (2011), used only by
    the ``type_c`` rolling model. Name every value for another material pair; the
    table of defaults is in docs/dem.md.
    """

    restitution: float
    static_friction: float
    rolling_friction: float
    damping_factor: float
    stiffness_factor: float
    rolling_damping: float
    #: the other sub-models' coefficients, as sorted (name, value) pairs
    coefficients: tuple

    def __init__(self, restitution=0.6, static_friction=0.4, rolling_friction=0.2,
                 damping_factor=0.0, stiffness_factor=0.95, rolling_damping=0.3,
                 **coefficients):
        e = _finite(restitution, "restitution")
        if not 0.0 < e <= 1.0:
            raise ConfigError(f"restitution must be in (0, 1], got {e}.")
        values = {"restitution": e}
        for nm, v in (("static_friction", static_friction),
                      ("rolling_friction", rolling_friction),
                      ("damping_factor", damping_factor)):
            v = _finite(v, nm)
            if v < 0:
                raise ConfigError(f"{nm} must be >= 0, got {v}.")
            values[nm] = v
        xi = _finite(stiffness_factor, "stiffness_factor")
        if xi <= 0:
            raise ConfigError(f"stiffness_factor must be > 0, got {xi}.")
        eta = _finite(rolling_damping, "rolling_damping")
        if not 0.0 <= eta <= 1.0:
            raise ConfigError(f"rolling_damping must be in [0, 1], got {eta}.")
        values.update(stiffness_factor=xi, rolling_damping=eta)
        for nm, v in values.items():
            object.__setattr__(self, nm, v)
        extra = tuple(sorted((str(k), _finite(v, str(k))) for k, v in coefficients.items()))
        object.__setattr__(self, "coefficients", extra)

    def value(self, name: str, default=None):
        """The coefficient called ``name`` (a field above or one of ``coefficients``),
        ``default`` where this interaction does not give it."""
        if name in _FIELDS:
            return getattr(self, name)
        return dict(self.coefficients).get(name, default)

    def __getattr__(self, name):
        # the other sub-models' coefficients read as attributes (it.surface_energy)
        if name != "coefficients" and not name.startswith("__"):
            for k, v in self.__dict__.get("coefficients", ()):
                if k == name:
                    return v
        raise AttributeError(f"Interaction has no coefficient {name!r}")


_FIELDS = ("restitution", "static_friction", "rolling_friction", "damping_factor",
           "stiffness_factor", "rolling_damping")


def soil(name: str = "soil") -> Material:
    """The paper's particulate material (Table 2 defaults; yield strength our choice)."""
    return Material(density=1687.85, shear_modulus=1.0e6, poisson_ratio=0.46,
                    yield_strength=SOIL_YIELD_STRENGTH, name=name)


def soil_interaction() -> Interaction:
    """The paper's soil-soil interaction: Table 2 range centres, stiffness factor 0.95."""
    return Interaction(restitution=0.6, static_friction=0.4, rolling_friction=0.2,
                       damping_factor=0.1, stiffness_factor=0.95)


def steel(name: str = "steel") -> Material:
    """A generic steel wall material (density 7800 kg/m3, G 7e10 Pa, nu 0.3)."""
    return Material(density=7800.0, shear_modulus=7.0e10, poisson_ratio=0.3,
                    yield_strength=2.5e8, name=name)


# --------------------------------------------------------------------------------------
# Which interaction acts between which two materials (the engine lays the pair table
# out from it: demcal.dem.contact.table).
# --------------------------------------------------------------------------------------
@dataclass
class MaterialTable:
    """Materials plus a complete interaction table: :meth:`interaction` of every pair.

    Parameters
    ----------
    materials : list of Material
    interactions : Interaction or dict
        One :class:`Interaction` for every pair, or a dict keyed by pairs of material
        indices or names ``(a, b)`` (order irrelevant); the key ``"default"`` covers
        pairs not listed. A pair may be left out when its materials never meet (two wall
        materials, or a material no particle is made of): the simulation checks each
        pair when particles of a material are added (:meth:`check_meets`), and a pair
        that meets with no interaction is a :class:`ConfigError` then.
    """

    materials: list
    interactions: object
    pairs: list = field(init=False)

    def __post_init__(self):
        mats = self.materials
        if isinstance(mats, Material):
            mats = [mats]
        mats = list(mats)
        if not mats:
            raise ConfigError("materials must list at least one Material.")
        for m in mats:
            if not isinstance(m, Material):
                raise ConfigError(f"materials must be Material objects, got {m!r}.")
        self.materials = mats
        n = len(mats)
        inter = self.interactions
        pairs: dict = {}
        default = None
        if isinstance(inter, Interaction):
            default = inter
        elif isinstance(inter, dict):
            for key, val in inter.items():
                if not isinstance(val, Interaction):
                    raise ConfigError(f"interaction {key!r} must be an Interaction, got {val!r}.")
                if key == "default":
                    default = val
                    continue
                try:
                    a, b = key
                except (TypeError, ValueError):
                    raise ConfigError(
                        f"interaction keys must be pairs of materials, got {key!r}.") from None
                ia, ib = self.index(a), self.index(b)
                pairs[(ia, ib)] = val
                pairs[(ib, ia)] = val
        else:
            raise ConfigError("interactions must be an Interaction or a dict of them.")
        self.pairs = [[pairs.get((i, j), default) for j in range(n)] for i in range(n)]

    def interaction(self, i: int, j: int) -> Interaction | None:
        """The interaction between materials ``i`` and ``j`` (indices); None for a pair
        left out (:meth:`check_meets` refuses it where it meets)."""
        return self.pairs[i][j]

    def check_meets(self, new: int, particles, walls) -> None:
        """ConfigError when particles of material ``new`` would meet, with no interaction,
        particles of a material in ``particles`` (itself included) or a wall of a
        material in ``walls`` (indices)."""
        for other, what in [(int(m), "particles") for m in sorted({new, *map(int, particles)})] + \
                           [(int(m), "walls") for m in sorted(set(map(int, walls)))]:
            if self.pairs[new][other] is None:
                a, b = self.materials[new].name, self.materials[other].name
                raise ConfigError(
                    f"no interaction defined between materials {a!r} and {b!r}, and {a} particles "
                    f"would meet {b} {what}; add one or a 'default' interaction.")

    def index(self, ref) -> int:
        """Index of a material given by index or name."""
        if isinstance(ref, (int, np.integer)) and not isinstance(ref, bool):
            if 0 <= int(ref) < len(self.materials):
                return int(ref)
            raise ConfigError(
                f"material index {ref} out of range (there are {len(self.materials)}).")
        for k, m in enumerate(self.materials):
            if m.name == ref:
                return k
        if isinstance(ref, Material):
            for k, m in enumerate(self.materials):
                if m == ref:
                    return k
        names = [m.name for m in self.materials]
        raise ConfigError(f"unknown material {ref!r}; known materials are {names}.")
