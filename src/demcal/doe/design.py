"""A design bound to named factors: coded matrix, actual levels and run order."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from demcal.doe.factors import Factor
from demcal.errors import ConfigError


@dataclass(frozen=True)
class Design:
    """A coded design matrix with its factors.

    Parameters
    ----------
    kind : str
        What generated it, e.g. ``"box-behnken"``.
    factors : tuple of Factor
        One per column of ``coded``.
    coded : numpy.ndarray
        ``(runs, k)`` coded levels in standard order.
    run_order : numpy.ndarray
        ``run_order[i]`` is the 1-based position in which standard-order row ``i`` is run.
    """

    kind: str
    factors: tuple[Factor, ...]
    coded: np.ndarray
    run_order: np.ndarray = field(default=None)

    def __post_init__(self):
        coded = np.asarray(self.coded, dtype=float)
        if coded.ndim != 2 or coded.shape[1] != len(self.factors):
            raise ConfigError(
                f"the design has {coded.shape[-1]} columns but {len(self.factors)} factors were named."
            )
        names = [f.name for f in self.factors]
        if len(set(names)) != len(names):
            raise ConfigError(f"factor names must be distinct (got {', '.join(names)}).")
        object.__setattr__(self, "coded", coded)
        order = self.run_order
        if order is None:
            order = np.arange(1, coded.shape[0] + 1)
        object.__setattr__(self, "run_order", np.asarray(order, dtype=int))

    @property
    def names(self) -> list[str]:
        return [f.name for f in self.factors]

    @property
    def actual(self) -> np.ndarray:
        """``(runs, k)`` actual levels in standard order."""
        return np.column_stack([f.to_actual(self.coded[:, j]) for j, f in enumerate(self.factors)])

    def randomized(self, seed: int | None) -> "Design":
        """The same design with a run order drawn from ``seed`` (None: standard order)."""
        if seed is None:
            return Design(self.kind, self.factors, self.coded)
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ConfigError(f"the run-order seed must be a whole number of 0 or more, not {seed!r}.")
        rng = np.random.default_rng(seed)
        perm = rng.permutation(self.coded.shape[0])
        order = np.empty_like(perm)
        order[perm] = np.arange(1, perm.size + 1)
        return Design(self.kind, self.factors, self.coded, order)

    def to_frame(self, coded: bool = False) -> pd.DataFrame:
        """Table sorted by run order: ``run``, ``std_order``, then one column per factor.

        Parameters
        ----------
        coded : bool
            Write coded levels instead of actual ones.
        """
        values = self.coded if coded else self.actual
        df = pd.DataFrame(values, columns=self.names)
        df.insert(0, "std_order", np.arange(1, len(df) + 1))
        df.insert(0, "run", self.run_order)
        return df.sort_values("run").reset_index(drop=True)
