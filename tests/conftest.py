"""Fixtures shared by several test folders."""

import os
import shutil
from pathlib import Path

import pytest

# The engine's OpenMP threads meet at a barrier in every parallel region of every step.
# OpenMP's default wait spins at that barrier, and a thread that spins holds a core that
# a working thread needs whenever there are more threads than free cores: the tests of 3
# and 5 threads on the 2-core VM, or any test while other jobs share the cores
# (tests/dem/test_sorting.py's three thread counts: 24.6 s spinning, 3.3 s passive, one
# run each, 29 Nov 2026). A passive wait sleeps instead; it changes no bit (the results
# do not depend on the threads at all). Set before numba loads its OpenMP pool, so this
# process and every subprocess of a test take it; a value set by the user wins.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "residual-film-soil"


@pytest.fixture
def example(tmp_path, monkeypatch):
    """The residual-film-soil campaigns copied into an empty folder, the working folder."""
    for path in EXAMPLE.iterdir():
        if path.is_file():
            shutil.copy2(path, tmp_path / path.name)
    monkeypatch.chdir(tmp_path)
    return tmp_path
