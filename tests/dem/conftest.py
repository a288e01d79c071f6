"""Shared fixtures for the engine tests: every test body runs on every backend present.

``cuda`` is present where numba-cuda finds a GPU (not in its simulator, which would take
hours over the whole engine suite: tests/dem/test_cuda_backend.py runs small cases
there instead).
"""

import pytest

from demcal.dem.backend import BACKENDS
from demcal.dem.cuda.backend import device_present


def _present(name: str) -> bool:
    return name != "cuda" or device_present()


@pytest.fixture(params=[b for b in BACKENDS if _present(b)])
def backend(request):
    return request.param
