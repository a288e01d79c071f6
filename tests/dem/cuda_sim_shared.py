"""numba-cuda's simulator, as patched by demcal.dem.cuda.kernels: every thread of a block
that reaches one ``cuda.shared.array`` call at once gets the same array.

The simulator allocates the array when the first thread reaches the call, with no lock;
a dictionary that pauses on each look-up widens that window so that the race, rare at
full speed, happens on every try. Prints one JSON line: the arrays handed to 16 threads
by demcal's allocation and by the simulator's own. Run with ``NUMBA_ENABLE_CUDASIM=1``
(tests/dem/test_cuda_backend.py).
"""

from __future__ import annotations

import json
import sys
import threading
import time

from numba import float64
from numba.cuda.simulator import kernelapi

import demcal.dem.cuda.kernels  # noqa: F401 - installs the locked allocation

THREADS = 16


class SlowLookups(dict):
    def get(self, key, default=None):
        found = super().get(key, default)
        time.sleep(0.002)
        return found


def arrays_handed_out(array) -> int:
    """How many distinct arrays ``THREADS`` threads get from one call site at once."""
    shared = kernelapi.FakeCUDAShared(0)
    shared._allocations = SlowLookups()
    start = threading.Barrier(THREADS)
    got = [None] * THREADS

    def thread(k):
        start.wait()
        got[k] = array(shared, 16, float64)

    threads = [threading.Thread(target=thread, args=(k,)) for k in range(THREADS)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return len({id(a) for a in got})


def main() -> int:
    locked = kernelapi.FakeCUDAShared.array
    print(json.dumps({"locked": getattr(locked, "demcal_locked", False),
                      "demcal": arrays_handed_out(locked),
                      "simulator": arrays_handed_out(locked.__wrapped__)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
