"""Shared fixtures for the engine tests: every test body runs on every backend present."""

import pytest

from demcal.dem.backend import BACKENDS


@pytest.fixture(params=list(BACKENDS))
def backend(request):
    return request.param
