"""The engine's worker threads: contiguous chunks of a loop, one thread each.

The compiled kernels are built with ``nogil=True`` and each writes disjoint slots, so a
loop split into chunks gives the same bits for any number of threads.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor


class Workers:
    """``threads`` threads (the caller's is the last); loops are split only when the
    simulation has at least ``parallel_threshold`` particles (handing a few thousand
    spheres of a two-sphere-clump heap to a thread costs more than it saves)."""

    #: Below this many particles a loop runs in the calling thread only.
    parallel_threshold = 2048

    def __init__(self, threads: int):
        self.threads = threads
        self._pool = None

    def split(self, n_particles: int) -> bool:
        """Whether loops of a simulation of ``n_particles`` are split between threads."""
        return self.threads > 1 and n_particles >= self.parallel_threshold

    def pool(self) -> ThreadPoolExecutor:
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.threads - 1,
                                            thread_name_prefix="demcal-dem")
        return self._pool

    def map_range(self, split: bool, fn, n, *args):
        """``fn(*args, lo, hi)`` over [0, n): in ``threads`` contiguous chunks when
        ``split``, else in one call; returns the results in chunk order."""
        t = self.threads
        if not split:
            return [fn(*args, 0, n)]
        bounds = [n * k // t for k in range(t + 1)]
        futs = [self.pool().submit(fn, *args, bounds[k], bounds[k + 1])
                for k in range(t - 1)]
        last = fn(*args, bounds[t - 1], bounds[t])
        return [f.result() for f in futs] + [last]

    def each_chunk(self, fn) -> None:
        """``fn(c)`` for each chunk c = 0 .. threads - 1, each in a thread of its own."""
        t = self.threads
        futs = [self.pool().submit(fn, c) for c in range(t - 1)]
        fn(t - 1)
        for f in futs:
            f.result()
