"""demcal.dem: a numba-compiled DEM engine for rigid multi-sphere particles.

Public API (stable)
-------------------
``Simulation(materials, interactions, walls=None, gravity=(0, 0, -9.81), dt=None,
contact_model="hertz_mindlin", rolling_model=None, dt_fraction=0.2,
impact_speed=2.0, skin=None, domain=None, threads=None)``

* ``sim.add_particles(template_or_radius, positions, orientations=None, scales=None,
  velocities=None, angular_velocities=None, material=0, fixed=False, seed=0,
  radii=None, rotation=True)`` -> indices of the new particles; allowed at any time,
  also from a reporter during a run (insertion at a rate). ``radii=`` adds single
  spheres of those radii (one per particle, no template); ``rotation=False`` locks the
  particles' rotation (they only translate). Refused with one sentence: non-finite
  numbers, arrays of the wrong shape, particles outside ``domain`` or larger than a
  ``Box`` they are placed in, and particles overlapping another by more than
  ``Simulation.overlap_tolerance`` (0.25: 25 %) of the smaller sphere radius (a
  settled bed's few per cent pass).
* ``sim.remove_particles(mask_or_indices)``, ``sim.remove_wall(name)`` (also
  mid-run: its contacts go with it)
* ``sim.run(duration=None, steps=None, reporters=[...])`` -> ``RunSummary`` (steps,
  simulated time, wall time, particle-steps per second); ``steps`` a whole number;
  a run by ``duration`` ends at that time even when particles added during the run
  shrink the automatic step. A given ``dt`` is checked against the stable limit again
  after every ``add_particles``.
* ``sim.state``: the particles in user order (copies, SI units): ``positions,
  velocities, omegas, quaternions, forces, torques, masses, inertias, radii,
  sphere_positions, sphere_body, ...``; write positions, velocities, spins and
  ``fixed`` into it before a run to start the run from them
* ``sim.kinetic_energy()`` [J], ``sim.wall_forces()`` -> ``{group: (force, torque)}``,
  ``sim.contacts()``, ``sim.time`` [s], ``sim.step_count``, ``sim.dt`` [s],
  ``sim.gravity`` (writable, e.g. to tilt a plane exactly), ``sim.gravity_schedule``
  (a ramp or a constant-rate rotation of gravity, :mod:`demcal.dem.gravity`, set
  once per window of steps within a stated tolerance)
* ``sim.save_checkpoint(path)``, ``sim.load_checkpoint(path)`` (bit-identical restart);
  ``demcal.io.particles.save_particles(path, sim)`` / ``load_particles(path)`` (a CSV file
  of the particles, to start another simulation from a packing)

Contact models (``contact_model``, default ``"hertz_mindlin"``): ``"hertz_mindlin"``
(EDEM Hertz-Mindlin no slip),
``"hysteretic_spring"`` (EDEM HSCM, the paper's Eq. 1-3), ``"linear"``; or a
:class:`ContactModel` naming one sub-model per slot. Rolling models
(``rolling_model``): ``"none"``, ``"type_a"`` (EDEM standard rolling friction, constant
directional torque on each body's own spin; the default), ``"cdt"`` (LIGGGHTS-PUBLIC
3.8.0 ``rolling_friction cdt``: the elastic normal force k_n delta, the relative spin
without its twisting part, lever R* and R against a wall), ``"type_c"``
(elastic-plastic spring-dashpot, Ai et al. 2011 model C), ``"type_a_limited"`` (type A
with a moment limiter: at most 0.08 of the torque that stops the spin in one step, the
form STAR-CCM+ documents for its constant torque method), ``"rvd"`` (EDEM's RVD rolling
friction: the same torque on both sides, against the tangential part of w_i + w_j). A
``ContactModel`` carries
its own ``rolling``; a ``rolling_model`` that differs from it is refused (name the
rolling model once). Equations and sources are in :mod:`demcal.dem.contact` and
docs/dem.md.

Reporters (:mod:`demcal.dem.reporters`): ``ProgressReporter``, ``EnergyReporter``,
``BlowUpDetector``, ``VTKReporter``, ``CheckpointReporter``, ``Callback``.

Determinism: every array element is written by one thread and sums run in a fixed
order, so a run gives bitwise identical results for any thread count and on restart.

Architecture (docs/dem.md, "Layout"): a frozen description (``description.py``), the
run state as named fields (``storage.py``), the spatial order (``ordering.py``), a
backend that runs the compiled loops (``backend.py``, ``BACKENDS``), and the
``Simulation`` (``simulation.py``), the public face and the run loop.

Example
-------
>>> from demcal.dem import Simulation
>>> from demcal.particles.materials import soil, soil_interaction
>>> sim = Simulation([soil()], soil_interaction(), contact_model="hysteretic_spring")
>>> sim.add_particles(0.004, [[0, 0, 0.01]])              # doctest: +SKIP
>>> sim.run(duration=0.1)                                  # doctest: +SKIP
"""

# The numba cache guard runs when the first Simulation is built (``_cache.ensure``),
# not at import.
from .contact.registry import ContactModel
from .gravity import GravityRamp, GravityRotation
from .simulation import RunSummary, Simulation, State

__all__ = ["Simulation", "State", "RunSummary", "ContactModel", "GravityRamp",
           "GravityRotation"]
