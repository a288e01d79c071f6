"""What a run did: :class:`RunSummary`, returned by :meth:`Simulation.run`."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field


@dataclass(frozen=True)
class RunSummary:
    """What one :meth:`Simulation.run` did.

    ``steps`` taken, ``simulated_time`` [s] advanced, ``wall_time`` [s] it took,
    ``particles`` at its end and ``particle_steps`` (particles present times steps,
    summed over the run's stretches between reporters), and ``stopped``, the reason a
    reporter gave for ending it early (None: it ran its length). Before issue 18 ``run()``
    returned the simulation itself: reading one of the simulation's attributes here
    still works, with a DeprecationWarning (use the simulation instead).
    """

    steps: int
    simulated_time: float
    wall_time: float
    particles: int
    particle_steps: int
    simulation: object = field(repr=False, compare=False)
    #: why a reporter ended the run early (:class:`~demcal.dem.reporters.StopRun`), or None
    stopped: str | None = None

    @property
    def particle_steps_per_second(self) -> float:
        """Particle-steps per second of wall time (0 when no time was measured)."""
        return self.particle_steps / self.wall_time if self.wall_time > 0 else 0.0

    def __getattr__(self, name):
        if name.startswith("__") or name == "simulation":
            raise AttributeError(name)
        value = getattr(self.simulation, name)
        warnings.warn(f"run() now returns a RunSummary; read {name!r} from the simulation "
                      f"(sim.{name}) instead.", DeprecationWarning, stacklevel=2)
        return value
