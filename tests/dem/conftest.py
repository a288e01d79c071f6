"""Shared fixtures for the engine tests: every test body runs on every backend present.

``cuda`` is present where numba-cuda finds a GPU (not in its simulator, which would take
hours over the whole engine suite: tests/dem/test_cuda_backend.py runs small cases
there instead).
"""

import os

import pytest

from demcal.dem.backend import BACKENDS


def _present(name: str) -> bool:
    if name != "cuda":
        return True
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return False
    try:
        from numba import cuda
    except ImportError:
        return False
    return cuda.is_available()


@pytest.fixture(params=[b for b in BACKENDS if _present(b)])
def backend(request):
    return request.param
