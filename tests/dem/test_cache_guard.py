"""The engine's cache guard (``demcal.dem._cache.guard``) on a stand-in source tree."""

import os

from demcal.dem import _cache


def _tree(tmp_path, monkeypatch):
    here = tmp_path / "dem"
    (here / "contact").mkdir(parents=True)
    (here / "__pycache__").mkdir()
    (here / "forces.py").write_text("# driver\n")
    (here / "contact" / "kernel.py").write_text("# kernel\n")
    monkeypatch.setattr(_cache, "_HERE", here)
    monkeypatch.setattr(_cache, "_SOURCES", [here / "forces.py", here / "contact" / "kernel.py"])
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    return here


def test_a_changed_kernel_clears_the_cache_and_touches_the_drivers(tmp_path, monkeypatch):
    here = _tree(tmp_path, monkeypatch)
    _cache.guard()
    stamp = (here / "__pycache__" / "demcal-dem-sources.stamp").read_text()
    entry = here / "__pycache__" / "forces.pair_forces-70.py311.nbi"
    entry.write_text("compiled")
    old = 1_000_000_000
    os.utime(here / "forces.py", (old, old))
    _cache.guard()                     # nothing changed: the entry and the time stay
    assert entry.exists() and os.stat(here / "forces.py").st_mtime == old
    # a kernel changes (numba's own check sees only the driver's file)
    (here / "contact" / "kernel.py").write_text("# kernel, changed\n")
    _cache.guard()
    assert not entry.exists()
    assert (here / "__pycache__" / "demcal-dem-sources.stamp").read_text() != stamp
    # the driver's time moved, so an entry a running process writes late, keyed on the
    # old time, is never loaded
    assert os.stat(here / "forces.py").st_mtime > old
