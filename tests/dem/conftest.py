"""Shared fixtures for the engine tests: every test body runs on every backend present."""

import pytest

from demcal.dem.simulation import BACKENDS


@pytest.fixture(params=BACKENDS)
def backend(request):
    return request.param
