"""Fixtures shared by several test folders."""

import shutil
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "residual-film-soil"


@pytest.fixture
def example(tmp_path, monkeypatch):
    """The residual-film-soil campaigns copied into an empty folder, the working folder."""
    for path in EXAMPLE.iterdir():
        if path.is_file():
            shutil.copy2(path, tmp_path / path.name)
    monkeypatch.chdir(tmp_path)
    return tmp_path
