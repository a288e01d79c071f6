"""What the virtual bench tests share: settings tables, materials, progress, the watch.

The shape of a test (build, phases, measure) is :mod:`demcal.bench.experiment`.

Settings
--------
Every test reads one flat table of dotted keys (:class:`~demcal.bench.registry.Setting`,
SI units). The keys that describe the material are the same in every test, so a
campaign factor such as ``particle.static_friction`` means the same thing everywhere:

=============================  ===========  ==============================================
key                            default      source
=============================  ===========  ==============================================
``particle.density``           1687.85      paper Table 2 [kg/m3]
``particle.shear_modulus``     1e6          paper Table 2 [Pa]
``particle.poisson_ratio``     0.46         paper Table 2 [-]
``particle.yield_strength``    2e5          our choice (the paper gives none) [Pa]
``particle.restitution``       0.6          paper Table 3 centre point (e, factor A)
``particle.static_friction``   0.4          paper Table 3 centre point (mu, factor B)
``particle.rolling_friction``  0.2          paper Table 3 centre point (gamma, factor C)
``particle.damping_factor``    0.1          paper Table 3 centre point (zeta, factor D)
``particle.stiffness_factor``  0.95         paper Table 2 (xi)
``film.restitution``           0.6          paper Table 7 centre point (e', factor E)
``film.static_friction``       0.5          paper Table 7 centre point (mu', factor F)
``film.rolling_friction``      0.15         paper Table 7 centre point (gamma', factor G)
``wall.*``                     see below    our choice (the paper gives none)
=============================  ===========  ==============================================

Yield strength. The Hysteretic Spring model's loading stiffness is
``K1 = 5 R* min(Y_i, Y_j)`` (paper Eq. 2; Walton & Braun 1986). The paper gives no
yield strength; we use 0.2 MPa: K1 is then about 2 kN/m for two 4.5 mm spheres (still
stiffer than a Hertz contact with the paper's G = 1 MPa at heap overlaps), a particle
under ten layers of heap overlaps its neighbours by about 1 % of its radius, and the
contact lasts 2.2 times longer than with 1 MPa (the value
:data:`demcal.particles.materials.SOIL_YIELD_STRENGTH` uses), which allows a 2.2 times
larger step.

Walls (funnel, base plate, lifted cylinder) are steel (:func:`demcal.particles.materials.steel`);
the particle-plate interaction is ``wall.restitution`` 0.5, ``wall.static_friction`` 0.6,
``wall.rolling_friction`` 0.3, ``wall.damping_factor`` 0.1 -- a rough plate, so that the
foot of a small heap does not run out; our choice, not from the paper. The agricultural film is a
material of its own (polyethylene: density 920 kg/m3, shear modulus 1e8 Pa, Poisson ratio
0.4, yield strength 1e7 Pa; ``film.*`` keys); with the Hysteretic Spring model the softer
particle sets the stiffness (``min(Y_i, Y_j)``), so the film's bulk values barely matter.

Time step. ``time.step_fraction`` is the step as a fraction of the shortest contact
duration ``t_c`` (smallest particle, stiffest branch; :mod:`demcal.dem.timestep`), and
never more than 0.2 of the Rayleigh time. The engine's automatic step is ``0.1 t_c``
(ten steps per contact); the engine refuses more than ``0.2 t_c``.

Profiles. ``tiny`` (one or two hundred particles: seconds, for tests of the campaign
machinery), ``quick`` (250-1000 particles: under two minutes on two cores, for demos and
the example campaigns) and ``paper`` (the paper's scale) differ only in their
defaults; every setting can be overridden in every profile.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import time
from collections import deque
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from demcal.bench.registry import Setting, listed_numbers
from demcal.dem.contact.registry import preset_names, rolling_names
from demcal.dem.contact.table import coefficient_names, declared_coefficient
from demcal.errors import ConfigError, DataError
from demcal.geometry.motion import Motion

PROFILES = ("tiny", "quick", "paper")
#: a profile some tests add between quick and paper (the incline's: its response within
#: 1 deg of the paper profile's at a tenth of the cost, docs/validation-incline.md)
MEDIUM = "medium"
#: the contact-model presets and rolling models the engine declares
CONTACT_MODELS = preset_names()
ROLLING_MODELS = rolling_names()
SHAPES = ("two-sphere", "sphere", "clump")
#: How particle sizes are drawn: scale factors on the template, or a sieve table.
SIZES = ("scale", "sieve")

#: Gravitational acceleration [m/s2].
G = 9.81


def per_profile(profile: str, tiny, quick, paper, medium=None):
    """Pick a default by profile; ``medium`` only for a test that declares that profile
    (None: the quick value)."""
    if profile == MEDIUM:
        return quick if medium is None else medium
    return {"tiny": tiny, "quick": quick, "paper": paper}[profile]


#: Unit and allowed range of each material and interaction property; the same for the
#: particles (``particle.*``), the steel walls (``wall.*``) and the film (``film.*``).
#: The interaction coefficients' come from the contact sub-models' declarations
#: (:mod:`demcal.dem.contact.declare`, ``Coefficient.bench``).
PROPERTY_RANGES = {
    "density": ("kg/m3", 100.0, 20000.0),
    "shear_modulus": ("Pa", 1.0e4, 1.0e11),
    "poisson_ratio": ("-", 0.0, 0.499),
    "yield_strength": ("Pa", 1.0e3, 1.0e10),
    **{name: (declared_coefficient(name).unit, *declared_coefficient(name).bench_range)
       for name in coefficient_names()},
}


#: the interaction coefficients every test sets out itself (a pair without its own
#: stiffness factor takes the particles', see :func:`interaction`)
OWN_COEFFICIENTS = ("restitution", "static_friction", "rolling_friction", "damping_factor",
                    "stiffness_factor")


def declared_settings(prefix: str, who: str) -> list[Setting]:
    """``prefix.<name>`` for every other interaction coefficient a contact sub-model
    declares, at the declared default: a sub-model added to the engine is a bench
    setting at once."""
    out = []
    for name in coefficient_names():
        if name in OWN_COEFFICIENTS:
            continue
        c = declared_coefficient(name)
        unit, low, high = PROPERTY_RANGES[name]
        out.append(Setting(f"{prefix}.{name}", c.default, unit,
                           f"{who} {c.doc} (the sub-model's default)", low, high))
    return out


def property_settings(prefix: str, rows, who: str | None = None) -> list[Setting]:
    """Settings ``prefix.<property>`` from ``(property, default, help)`` rows, with the
    unit and range of :data:`PROPERTY_RANGES`; with ``who`` (the pair, in words), also
    the other declared interaction coefficients (:func:`declared_settings`)."""
    out = []
    for prop, default, text in rows:
        unit, low, high = PROPERTY_RANGES[prop]
        out.append(Setting(f"{prefix}.{prop}", default, unit, text, low, high))
    if who is not None:
        out += declared_settings(prefix, who)
    return out


def material_settings(film: bool = False) -> list[Setting]:
    """The particle (and, for the incline, film) material and interaction keys."""
    s = property_settings("particle", [
        ("density", 1687.85, "particle density (paper Table 2)"),
        ("shear_modulus", 1.0e6, "particle shear modulus G (paper Table 2)"),
        ("poisson_ratio", 0.46, "particle Poisson ratio (paper Table 2)"),
        ("yield_strength", 2.0e5, "particle yield strength Y for the Hysteretic Spring model, "
         "K1 = 5 R* Y (our choice; the paper gives none)"),
        ("restitution", 0.6, "particle-particle coefficient of restitution e (paper Table 3 centre)"),
        ("static_friction", 0.4, "particle-particle static friction mu (paper Table 3 centre)"),
        ("rolling_friction", 0.2, "particle-particle rolling ('dynamic') friction gamma "
         "(paper Table 3 centre)"),
        ("damping_factor", 0.1, "Hysteretic Spring damping factor zeta (paper Table 3 centre)"),
        ("stiffness_factor", 0.95, "Hysteretic Spring stiffness factor xi, k_t = xi K1 (paper Table 2)"),
    ], who="particle-particle") + property_settings("wall", [
        ("restitution", 0.5, "particle-steel restitution (our choice)"),
        ("static_friction", 0.6, "particle-plate static friction (our choice: a rough plate)"),
        ("rolling_friction", 0.3, "particle-plate rolling friction (our choice: a rough plate)"),
        ("damping_factor", 0.1, "particle-steel damping factor (our choice)"),
    ], who="particle-steel") + [
        Setting("contact.model", "hysteretic_spring", "-", "contact model", choices=CONTACT_MODELS),
        Setting("rolling.model", "type_a", "-", "rolling resistance model", choices=ROLLING_MODELS),
    ]
    if film:
        s += property_settings("film", [
            ("restitution", 0.6, "particle-film restitution e' (paper Table 7 centre)"),
            ("static_friction", 0.5, "particle-film static friction mu' (paper Table 7 centre)"),
            ("rolling_friction", 0.15, "particle-film rolling friction gamma' (paper Table 7 centre)"),
            ("damping_factor", 0.1, "particle-film damping factor (our choice)"),
            ("stiffness_factor", 0.95, "particle-film stiffness factor (as Table 2)"),
            ("density", 920.0, "film density (polyethylene)"),
            ("shear_modulus", 1.0e8, "film shear modulus (polyethylene)"),
            ("poisson_ratio", 0.4, "film Poisson ratio (polyethylene)"),
            ("yield_strength", 1.0e7, "film yield strength (polyethylene)"),
        ], who="particle-film")
    return s


def particle_settings(profile: str, count: int) -> list[Setting]:
    """Particle population keys."""
    return [
        Setting("particles.count", count, "-", "number of particles", 1, 1_000_000),
        Setting("particles.shape", "two-sphere", "-",
                "particle shape: the paper's 4 mm + 5 mm two-sphere unit, a 4.5 mm sphere, or a clump "
                "(particles.clump_mm)",
                choices=SHAPES),
        Setting("particles.centre_distance", 0.007, "m",
                "distance between the two spheres' centres of the two-sphere unit (our choice; the "
                "paper gives none: 7 mm, aspect ratio 1.6)", 0.0, 0.0085),
        Setting("particles.clump_mm", "", "mm",
                "a clump's spheres for particles.shape = clump: x, y, z, radius of each [mm] at "
                "scale 1", listed=True, inert=True),
        Setting("particles.scale_min", 0.5, "-", "smallest size factor (paper: 0.5)", 0.05, 10.0),
        Setting("particles.scale_max", 1.5, "-", "largest size factor (paper: 1.5)", 0.05, 10.0),
        Setting("particles.sizes", "scale", "-",
                "how sizes are drawn: scale (a factor uniform in particles.scale_min..scale_max, "
                "the paper's) or sieve (particles.sieve_mm and sieve_percent, coarse-grained)",
                choices=SIZES, inert=True),
        Setting("particles.sieve_mm", "", "mm",
                "sieve class bounds [mm] as the lab file gives them (the first may be 0, the last "
                "inf)", listed=True, inert=True),
        Setting("particles.sieve_percent", "", "%", "mass of each sieve class [%], summing to 100",
                listed=True, inert=True),
        Setting("particles.count_by", "number", "-",
                "number: particles.count particles; volume: as many particles as fill the solid "
                "volume of particles.count of the paper's units (a heap keeps its size when the "
                "sizes change)", choices=("number", "volume"), inert=True),
        Setting("particles.coarse_grain", 1.0, "-",
                "coarse-graining factor c: a lab particle of size D is simulated at c D (sieve "
                "sizes)", 0.01, 1000.0, inert=True),
        Setting("particles.size_min_mm", 0.0, "mm",
                "smallest lab size simulated, finer mass left out (0: the sieve's first bound "
                "above 0)", 0.0, 1e4, inert=True),
        Setting("particles.size_max_mm", 0.0, "mm",
                "largest lab size simulated (0: the sieve's top bound; an open top class >= d "
                "counts as d to 2 d)", 0.0, 1e4, inert=True),
    ]


def time_settings(profile: str, step_fraction: float, max_time: float,
                  rest_speed: float = 0.005) -> list[Setting]:
    return [
        Setting("time.step_fraction", step_fraction, "-",
                "time step as a fraction of the shortest contact duration (engine refuses > 0.2)",
                0.001, 0.2),
        Setting("time.max_time", max_time, "s", "give up after this much simulated time", 0.01, 1000.0),
        Setting("time.rest_speed", rest_speed, "m/s",
                "at rest when the root-mean-square particle speed sqrt(2 KE / M) is below this",
                1e-6, 1.0),
    ]


def standard_settings(profile: str, counts, own: list[Setting], step_fraction, max_time,
                      film: bool = False) -> list[Setting]:
    """The table of a test that simulates a population of particles: the material keys,
    the particle keys with ``particles.count`` from ``counts``, the test's ``own`` keys and
    the time keys; ``counts``, ``step_fraction`` and ``max_time`` are (tiny, quick, paper)
    defaults, with a fourth for a test's medium profile (else the quick one)."""
    return (material_settings(film=film)
            + particle_settings(profile, per_profile(profile, *counts))
            + own
            + time_settings(profile, per_profile(profile, *step_fraction),
                            per_profile(profile, *max_time)))


def table(settings: list[Setting]) -> dict[str, Setting]:
    return {s.key: s for s in settings}


# --------------------------------------------------------------------------- materials --

def template_for(s: Mapping[str, Any]):
    """The particle template at scale 1 (the engine scales it per particle)."""
    from demcal.particles.templates import ParticleTemplate, sphere, two_sphere_paper

    shape = s["particles.shape"]
    if shape == "sphere":
        return sphere(0.0045, name="sphere")
    if shape == "clump":
        numbers = listed_numbers(s.get("particles.clump_mm", ""))
        if not numbers or len(numbers) % 4:
            raise ConfigError("particles.shape = clump needs particles.clump_mm: x, y, z, radius [mm] "
                              f"of each sphere, four numbers a sphere (got {len(numbers)} numbers).")
        return ParticleTemplate.from_spheres(np.reshape(numbers, (-1, 4)) * 1e-3, name="clump")
    return two_sphere_paper(offset=float(s.get("particles.centre_distance", 0.007)))


def sizes_for(s: Mapping[str, Any], template=None):
    """The size distribution of the settings ``s`` as scale factors on ``template`` (the
    settings' own when None): the paper's uniform factors, or a coarse-grained sieve
    table (:func:`sieve_for`)."""
    from demcal.particles.sizes import Uniform

    if s.get("particles.sizes", "scale") == "sieve":
        return sieve_for(s, template if template is not None else template_for(s)).distribution
    lo, hi = float(s["particles.scale_min"]), float(s["particles.scale_max"])
    if hi < lo:
        raise ConfigError(f"particles.scale_max ({hi}) must be >= particles.scale_min ({lo}).")
    return Uniform(lo, hi)


def sieve_for(s: Mapping[str, Any], template):
    """The settings' sieve table as simulated sizes
    (:class:`~demcal.particles.sizes.ScaledSieve`): a lab particle of sieve size D is the
    ``template`` scaled so that its volume-equivalent diameter is ``particles.coarse_grain``
    x D."""
    from demcal.measure.lab import SieveTable
    from demcal.particles.sizes import scaled_sieve

    edges = listed_numbers(s.get("particles.sieve_mm", ""))
    percent = listed_numbers(s.get("particles.sieve_percent", ""))
    if not edges or not percent:
        raise ConfigError("particles.sizes = sieve needs particles.sieve_mm and "
                          "particles.sieve_percent (a lab file's sieve edges_mm and mass_percent), "
                          "or a campaign's [experiment] sieve = SAMPLE.")
    try:
        table = SieveTable(edges, percent)
    except DataError as exc:
        raise ConfigError(f"particles.sieve_mm / particles.sieve_percent: {exc}") from None
    return scaled_sieve(table.edges_mm, table.mass_percent, 2.0 * template.equivalent_radius,
                        float(s.get("particles.coarse_grain", 1.0)),
                        float(s.get("particles.size_min_mm", 0.0)), float(s.get("particles.size_max_mm", 0.0)))


def size_advice(s: Mapping[str, Any], shrink: float | None = None) -> str:
    """What to lower when the largest particle is too big for an opening, and to what when
    the largest must shrink by the factor ``shrink`` (< 1)."""
    if s.get("particles.sizes", "scale") == "sieve":
        c = float(s.get("particles.coarse_grain", 1.0))
        to = f" to {c * shrink:.3g} or less" if shrink else ""
        return f"lower particles.coarse_grain{to} (now {c:g}) or particles.size_max_mm"
    to = f" to {float(s['particles.scale_max']) * shrink:.3g} or less" if shrink else ""
    return f"lower particles.scale_max{to}"


def bounding_radius(template) -> float:
    """The radius [m] of the sphere about its centre of mass that holds ``template`` at
    scale 1 (its largest sphere's radius where it gives none)."""
    return float(getattr(template, "bounding_radius", np.max(template.radii)))


def insert_due(sim, inserter, template, seed) -> None:
    """Add to ``sim`` the particles of ``template`` that ``inserter`` (a
    :class:`~demcal.particles.insertion.Inserter`) has due now and finds room for among
    the particles present (their bounding spheres)."""
    if inserter.done:
        return
    st = sim.state
    body_r = bounding_radius(template) * st.scales if st.n else np.zeros(0)
    ins = inserter(sim.time, st.positions.copy(), body_r)
    if len(ins):
        sim.add_particles(template, ins.positions, orientations=ins.orientations, scales=ins.scales,
                          velocities=ins.velocities, seed=seed)


def fill_height(n: int, template, sizes, radius: float, b_max: float) -> float:
    """Height [m] to insert ``n`` particles into at random in a cylinder of ``radius`` [m]:
    their bounding spheres (``sizes`` scale factors) at 25 % solids (random insertion
    reaches about 30 %), plus two largest bounding radii ``b_max`` [m]."""
    b_vol = n * 4.0 / 3.0 * math.pi * float(template.bounding_radius) ** 3 * sizes.mean_cube()
    return b_vol / (0.25 * math.pi * radius ** 2) + 2 * b_max


def material_of(s: Mapping[str, Any], prefix: str = "particle"):
    """The Material of ``prefix`` (``particle`` or ``film``) from settings."""
    from demcal.particles.materials import Material

    return Material(density=s[f"{prefix}.density"], shear_modulus=s[f"{prefix}.shear_modulus"],
                    poisson_ratio=s[f"{prefix}.poisson_ratio"],
                    yield_strength=s[f"{prefix}.yield_strength"], name=prefix)


def interaction(s: Mapping[str, Any], prefix: str, stiffness_key: str | None = None):
    """The Interaction of ``prefix`` (``particle``, ``wall``, ``film``) from settings."""
    from demcal.particles.materials import Interaction

    xi = s.get(f"{prefix}.stiffness_factor", s["particle.stiffness_factor"])
    # the other coefficients the sub-models declare (rolling damping, ...)
    others = {name: s[f"{prefix}.{name}"] for name in coefficient_names()
              if name not in OWN_COEFFICIENTS and f"{prefix}.{name}" in s}
    return Interaction(restitution=s[f"{prefix}.restitution"],
                       static_friction=s[f"{prefix}.static_friction"],
                       rolling_friction=s[f"{prefix}.rolling_friction"],
                       damping_factor=s[f"{prefix}.damping_factor"],
                       stiffness_factor=xi, **others)


def count_of(s: Mapping[str, Any], template=None, sizes=None) -> int:
    """The number of particles to simulate: ``particles.count``, or with
    ``particles.count_by = volume`` as many ``template`` particles of ``sizes`` as fill the
    solid volume of ``particles.count`` of the paper's units at its sizes
    (:func:`paper_volume`), so that a bed or heap keeps its size when the sizes change."""
    n = s["particles.count"]
    if float(n) != int(n):
        raise ConfigError(f"particles.count must be a whole number, got {n}.")
    if s.get("particles.count_by", "number") != "volume":
        return int(n)
    if template is None or sizes is None:
        template, sizes = template_for(s), sizes_for(s)
    return max(1, int(round(int(n) * paper_volume() / (template.volume * sizes.mean_cube()))))


def paper_volume() -> float:
    """Mean solid volume [m3] of the paper's particle: its two-sphere unit at scale
    factors uniform in 0.5-1.5."""
    from demcal.particles.sizes import paper_sizes
    from demcal.particles.templates import two_sphere_paper

    return float(two_sphere_paper().volume * paper_sizes().mean_cube())


# ------------------------------------------------------------------------- simulation --

def time_step(s: Mapping[str, Any], materials, interactions, walls, template, smallest_scale: float,
              fraction: float | None = None) -> float:
    """The step [s]: the engine's time-step policy (:func:`demcal.dem.timestep.choose_dt`)
    with ``time.step_fraction`` of the shortest contact duration of the smallest
    particle (``template`` at ``smallest_scale``, material 0) with particles and with
    ``walls``, and at most 0.2 Rayleigh times; a hair below it, so that the engine's
    check of a given step against its stable limit never fails by a rounding.
    """
    from demcal.dem import Simulation
    from demcal.dem.timestep import choose_dt

    from demcal.geometry import Plane, WallSet

    # one static plane per wall material stands in for the walls (only materials matter)
    probe_walls = None
    if walls is not None and len(walls):
        probe_walls = WallSet([Plane(material=int(m), name=f"m{int(m)}")
                               for m in np.unique(walls.material)])
    probe = Simulation(materials, interactions, walls=probe_walls, contact_model=s["contact.model"],
                       rolling_model=s["rolling.model"])
    probe.add_particles(template, [[0.0, 0.0, 0.0]], scales=[smallest_scale])
    t_r, t_c = probe.time_scales()
    f = float(s["time.step_fraction"] if fraction is None else fraction)
    return choose_dt(probe.description.models[0], t_r, t_c, 0.2, contact_fraction=f) * (1.0 - 1e-9)


#: Neighbour-list skin in units of the template's smallest sphere radius (at scale 1).
#: Particles fall at up to 3 m/s in these tests; with the engine's default skin
#: (0.4 of the smallest radius) the list would be rebuilt every few steps.
SKIN_RADII = 1.5


def skin_for(template) -> float:
    """Neighbour skin [m] for the bench tests (see :data:`SKIN_RADII`)."""
    return SKIN_RADII * float(np.min(template.radii))


def make_simulation(s: Mapping[str, Any], materials, interactions, walls, dt: float,
                    gravity=(0.0, 0.0, -G), domain=None, skin=None):
    """A Simulation with the settings' contact and rolling models and step ``dt`` [s]."""
    from demcal.dem import Simulation

    return Simulation(materials, interactions, walls=walls, gravity=gravity, dt=dt,
                      contact_model=s["contact.model"], rolling_model=s["rolling.model"],
                      domain=domain, skin=skin, backend=_BACKEND.get())


#: The compute backend of the tests run in this thread (see :func:`on_backend`).
_BACKEND: contextvars.ContextVar[str] = contextvars.ContextVar("backend", default="cpu")


@contextlib.contextmanager
def on_backend(name: str):
    """Within the block, the bench tests simulate on backend ``name`` (``cpu`` or ``cuda``,
    :data:`demcal.dem.backend.BACKENDS`); checked by the Simulation it makes."""
    token = _BACKEND.set(name)
    try:
        yield name
    finally:
        _BACKEND.reset(token)


#: The :class:`Progress` of the test running in this thread (see :func:`showing`).
_PROGRESS: contextvars.ContextVar[Progress | None] = contextvars.ContextVar("progress", default=None)


def current_progress() -> Progress | None:
    """The :class:`Progress` of the test running in this thread, if any."""
    return _PROGRESS.get()


@contextlib.contextmanager
def showing(progress: Progress):
    """Within the block, ``progress`` is the running test's display (closed at the end)."""
    token = _PROGRESS.set(progress)
    try:
        yield progress
    finally:
        _PROGRESS.reset(token)
        progress.close()


def _duration(seconds: float) -> str:
    """``42 s``, ``3 min 05 s``, ``1 h 02 min``."""
    s = int(round(seconds))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


class _ProgressReporter:
    """Hands the simulation to its :class:`Progress` at the end of every run; it asks for
    no data in between, so it never cuts a run into pieces (the steps taken are the same
    as without it)."""

    def __init__(self, progress: Progress):
        self.progress = progress

    def next_report(self, sim) -> int:
        return 1 << 62

    def report(self, sim) -> None:
        self.progress.update(sim)

    def finish(self, sim) -> None:
        self.progress.update(sim)


class Progress:
    """What ``demcal bench`` says while a test runs (not with ``--json``).

    The test's own messages, each on a line of its own after the wall time, and a
    status line (:class:`demcal.dem.reporters.StatusLine`: rewritten in place on a
    terminal, one plain line every ``log_interval`` seconds in a log) with

    * the simulated time ``t``;
    * while the test runs towards a time limit (a phase of :mod:`demcal.bench.experiment`, which stops at
      ``time.max_time`` at the latest but usually sooner, once the particles are at
      rest), the share of that limit reached and the ETA to it, an upper bound;
    * the wall time per simulated second (over the last 30 s);
    * with a rest criterion (``time.rest_speed``), the rms speed of the particles
      against it, which tells how far the heap is from rest.

    Parameters
    ----------
    enabled : bool
        Print anything at all.
    rest_speed : float, optional
        The test's rest criterion [m/s].
    file : text file, optional
        Default ``sys.stderr``.
    log_interval : float, optional
        Seconds between status lines when ``file`` is not a terminal (default
        :attr:`LOG_INTERVAL`).
    clock : callable
        Wall clock [s].
    """

    #: Seconds between two status lines in a log.
    LOG_INTERVAL = 10.0
    #: Seconds of wall time the speed is averaged over.
    WINDOW = 30.0

    def __init__(self, enabled: bool = False, rest_speed: float | None = None, file=None,
                 log_interval: float | None = None, clock=time.perf_counter):
        self.enabled = bool(enabled)
        self.rest_speed = rest_speed
        self.clock = clock
        self.start = clock()
        self.limit: float | None = None
        self.reporter = _ProgressReporter(self)
        self._samples: deque[tuple[float, float]] = deque()
        self._status = None
        if self.enabled:
            from demcal.dem.reporters import StatusLine

            self._status = StatusLine(file, clock=clock, log_interval=(
                self.LOG_INTERVAL if log_interval is None else log_interval))

    def _stamp(self) -> str:
        return f"  [{self.clock() - self.start:6.1f} s]"

    def __call__(self, text: str) -> None:
        """A message of the test, kept on its own line."""
        if self.enabled:
            self._status.message(f"{self._stamp()} {text}")

    @contextlib.contextmanager
    def time_limit(self, limit: float):
        """Within the block the simulation runs towards ``limit`` [s] of simulated time."""
        outer, self.limit = self.limit, float(limit)
        try:
            yield
        finally:
            self.limit = outer

    def update(self, sim) -> None:
        """Note the simulation's time; redraw the status when it is due."""
        if not self.enabled:
            return
        now, t = self.clock(), float(sim.time)
        self._samples.append((now, t))
        while len(self._samples) > 2 and self._samples[1][0] < now - self.WINDOW:
            self._samples.popleft()
        if self._status.due():
            self._status.update(self.status(sim))

    def seconds_per_simulated_second(self) -> float | None:
        """Wall time per simulated second over the last :attr:`WINDOW` seconds."""
        (c0, t0), (c1, t1) = self._samples[0], self._samples[-1]
        return (c1 - c0) / (t1 - t0) if t1 > t0 and c1 > c0 else None

    def status(self, sim) -> str:
        """The status text for ``sim`` now."""
        t = float(sim.time)
        parts = [f"{self._stamp()} t = {t:.3f} s"]
        pace = self.seconds_per_simulated_second() if self._samples else None
        if self.limit is not None and 0 < self.limit and t <= self.limit:
            parts[0] += f" ({100.0 * t / self.limit:.0f} % of the {self.limit:g} s limit)"
            if pace is not None:
                parts.append(f"ETA at most {_duration((self.limit - t) * pace)}")
        if pace is not None:
            parts.append(f"{pace:.3g} s per simulated s")
        if self.rest_speed is not None and getattr(sim, "n_particles", 0):
            parts.append(f"rms speed {rms_speed(sim):.3g} m/s (rest < {self.rest_speed:g})")
        return ", ".join(parts)

    def close(self) -> None:
        if self._status is not None:
            self._status.close()


class Watch:
    """The engine reporters every phase of a bench test runs with
    (:mod:`demcal.dem.reporters`): a blow-up check (non-finite positions or velocities)
    every ``interval`` steps, and with ``vtk`` a frame every ``FRAME`` seconds of
    simulated time into ``out_dir/vtk`` (the point data of
    :data:`demcal.io.vtk.STATE_FIELDS`, with ``walls``)."""

    #: Simulated seconds between two VTK frames.
    FRAME = 0.05

    def __init__(self, sim, what: str, interval: int, out_dir=None, vtk: bool = False, walls=None,
                 name: str = "bench"):
        from demcal.dem.reporters import BlowUpDetector, VTKReporter

        self.sim = sim
        self.blowup = BlowUpDetector(interval, max_speed=math.inf, what=f"{what} simulation",
                                     fix="lower time.step_fraction")
        self.vtk = None
        if vtk and out_dir is not None:
            dt = sim.description.dt or sim.dt  # the tests give their step
            self.vtk = VTKReporter(Path(out_dir, "vtk"), max(1, int(round(self.FRAME / dt))), name=name,
                                   walls=walls is not None)
        self.reporters = [r for r in (self.vtk, self.blowup) if r is not None]

    def check(self) -> None:
        """The blow-up check now (outside a run)."""
        self.blowup.report(self.sim)

    def last_frame(self) -> None:
        """A VTK frame of the final state (if VTK is on)."""
        if self.vtk is not None and self.sim.n_particles:
            self.vtk.report(self.sim)

    @property
    def path(self):
        return str(self.vtk.pvd_path) if self.vtk is not None and self.vtk.pvd_path else None


def rms_speed(sim) -> float:
    """sqrt(2 KE / M) of the free particles [m/s] (KE includes rotation): the engine's
    :attr:`~demcal.dem.reporters.Snapshot.rms_speed`."""
    return sim.snapshot().rms_speed


def rest(limit: float):
    """The kinetic-energy rest criterion, :func:`rms_speed` below ``limit`` [m/s] at two
    checks in a row: the engine's :class:`~demcal.dem.reporters.RestDetector` (its
    interval is set by :func:`demcal.bench.experiment.run_phase`)."""
    from demcal.dem.reporters import RestDetector

    return RestDetector(1, limit, checks=2)


def show(sim) -> None:
    """Hand ``sim`` to the running test's progress display, if it is shown. The bench
    reporters call it when they report: the display reads the state only where the test
    reads it anyway, so showing progress never changes when the engine sorts (and so
    never a result)."""
    progress = _PROGRESS.get()
    if progress is not None and progress.enabled:
        progress.update(sim)


class DrivenTranslation(Motion):
    """A wall the experiment puts somewhere by hand while it runs (the incline's
    container and the lifted cylinder are moved out of the way this way).

    The wall sits at ``offset`` and reports ``velocity`` to the contacts (the relative
    velocity of a contact uses it). :meth:`place` moves it; the wall set re-evaluates the
    wall only after a move (``moving`` is true until the next :meth:`transform`), so
    between moves a "moving" wall costs nothing. A steady motion is better given as a
    :class:`~demcal.geometry.motion.Translation` (``WallSet.set_motion``), which the
    engine places at every step inside its compiled loop.
    """

    def __init__(self):
        self.offset = np.zeros(3)
        self.velocity = np.zeros(3)
        self.moving = True

    def place(self, offset, velocity=(0.0, 0.0, 0.0)) -> None:
        self.offset = np.asarray(offset, dtype=float).reshape(3).copy()
        self.velocity = np.asarray(velocity, dtype=float).reshape(3).copy()
        self.moving = True

    def transform(self, t):
        self.moving = False
        return np.eye(3), self.offset.copy()

    def twist(self, t):
        return np.zeros(3), self.velocity.copy()

    def velocity_at(self, t, x):
        return self.velocity.copy()

    def pose(self, t, x_ref):
        return np.asarray(x_ref, dtype=float) + self.offset
