"""Impact: one sphere shot at a wall or at another sphere; measures the restitution.

EDEM users check their contact parameters this way: with the contact model and the
interaction under test, a sphere of radius ``impact.radius`` hits, at ``impact.speed``
along the normal and without gravity,

* ``impact.target = "particle"``: an equal sphere coming the other way (the
  particle-particle interaction ``particle.*``);
* ``"wall"``: a steel plane (``wall.*``);
* ``"film"``: a plane of film material (``film.*``).

The response ``restitution`` is ``e = -(v_n after) / (v_n before)`` of the relative normal
velocity, read once the bodies have separated. For the Hertz-Mindlin model (Tsuji
damping, EDEM) and for the Hysteretic Spring model with ``damping_factor = 0``
(``e = sqrt(K1/K2)``, paper Eq. 3) it returns the set ``e``; the Hysteretic Spring
damping factor ``zeta`` adds viscous damping on top, so with ``zeta > 0`` the measured
``e`` is lower than the set one -- which is what this test is for. The step is
``time.step_fraction`` (default 0.01: 100 steps per contact) of the contact duration.
"""

from __future__ import annotations

import math

from demcal.bench import common as C
from demcal.bench.experiment import BenchExperiment, Phase, Setup
from demcal.bench.registry import Setting, register
from demcal.dem.reporters import Reporter, StopRun
from demcal.errors import SimulationError

TARGETS = ("particle", "wall", "film")


class Impact(BenchExperiment):
    name = "impact"
    description = ("a sphere shot at an equal sphere, a steel wall or the film; measures the "
                   "coefficient of restitution of that interaction")
    responses = ("restitution",)

    def _settings(self, profile):
        return (C.material_settings(film=True)
                + [
                    Setting("impact.target", "particle", "-", "what the sphere hits", choices=TARGETS),
                    Setting("impact.speed", 1.0, "m/s", "normal approach speed (relative)", 1e-3, 100.0),
                    Setting("impact.radius", 0.005, "m", "sphere radius", 1e-4, 1.0),
                    Setting("time.step_fraction", 0.01, "-",
                            "time step as a fraction of the shortest contact duration", 0.001, 0.2),
                ])

    def build(self, s, seed, out_dir, vtk, progress):
        from demcal.geometry import Plane, WallSet
        from demcal.particles.materials import steel
        from demcal.particles.templates import sphere

        r = float(s["impact.radius"])
        v = float(s["impact.speed"])
        target = s["impact.target"]
        film = C.material_of(s, "film")
        mats = [C.material_of(s), steel(), film]
        inter = {(0, 0): C.interaction(s, "particle"), (0, 1): C.interaction(s, "wall"),
                 (0, 2): C.interaction(s, "film"), "default": C.interaction(s, "wall")}
        walls = None
        if target != "particle":
            walls = WallSet([Plane(point=(0, 0, 0), normal=(0, 0, 1), name=target,
                                   material=1 if target == "wall" else 2)])
        tpl = sphere(r)
        dt = C.time_step(s, mats, inter, walls, tpl, 1.0)
        sim = C.make_simulation(s, mats, inter, walls, dt, gravity=(0.0, 0.0, 0.0))
        gap = 0.01 * r
        if target == "particle":
            sim.add_particles(tpl, [[0, 0, -(r + gap / 2)], [0, 0, r + gap / 2]],
                              velocities=[[0, 0, 0.5 * v], [0, 0, -0.5 * v]])
        else:
            sim.add_particles(tpl, [[0, 0, r + gap]], velocities=[[0, 0, -v]])

        def separation():
            st = sim.state
            if target == "particle":
                return float(st.positions[1, 2] - st.positions[0, 2]) - 2 * r
            return float(st.positions[0, 2]) - r

        # the impact, watched every 10 steps until the bodies are clear of each other
        contact = _Contact(separation, 50.0 * (gap / v) + 1.0)
        impact = Phase(contact, chunk=None, ok=("clear",),
                       failure="the impact did not finish (the sphere stuck to its target); "
                               "check the restitution and damping settings.")
        return Setup(sim, [impact], C.Watch(sim, "impact", 10), info=dict(target=target, speed=v))

    def measure(self, setup, s, out_dir, progress):
        st, target, v = setup.sim.state, setup.info["target"], setup.info["speed"]
        vn = float(st.velocities[1, 2] - st.velocities[0, 2]) if target == "particle" else float(st.velocities[0, 2])
        e = vn / v
        if not math.isfinite(e):
            raise SimulationError("the impact simulation blew up; lower time.step_fraction.")
        progress(f"impact on {target}: e = {e:.5f} (set {s[_prefix(target) + '.restitution']:.5f})")
        return dict(responses={"restitution": float(e)})


class _Contact(Reporter):
    """The impact as an engine reporter, every 10 steps: once the gap has closed and
    opened again, 10 steps more (clear of the contact and its skin), then
    ``StopRun("clear")``; ``StopRun("time limit")`` if the time ``t_max`` passes first."""

    def __init__(self, separation, t_max):
        super().__init__(10)
        self.separation, self.t_max = separation, t_max
        self.touched = self.opened = False

    def report(self, sim):
        C.show(sim)
        if self.opened:
            raise StopRun("clear")
        d = self.separation()
        if d < 0:
            self.touched = True
        elif self.touched and d > 0.0:
            self.opened = True
            return
        if sim.time >= self.t_max:
            raise StopRun("time limit")


def _prefix(target: str) -> str:
    return {"particle": "particle", "wall": "wall", "film": "film"}[target]


register(Impact())
