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


def test_a_changed_kernel_clears_the_cache(tmp_path, monkeypatch):
    here = _tree(tmp_path, monkeypatch)
    _cache.guard()
    stamp = (here / "__pycache__" / "demcal-dem-sources.stamp").read_text()
    entry = here / "__pycache__" / "forces.pair_forces-70.py311.nbi"
    entry.write_text("compiled")
    _cache.guard()                     # nothing changed: the entry stays
    assert entry.exists()
    # a kernel changes (numba's own check sees only the driver's file)
    (here / "contact" / "kernel.py").write_text("# kernel, changed\n")
    _cache.guard()
    assert not entry.exists()
    assert (here / "__pycache__" / "demcal-dem-sources.stamp").read_text() != stamp


# --------------------------------------------------------------- where the cache lives --

import subprocess  # noqa: E402
import sys  # noqa: E402
from types import SimpleNamespace  # noqa: E402

import demcal  # noqa: E402


def test_the_cache_is_next_to_the_installed_packages(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "venv"))
    assert demcal.numba_cache_dir() == str(tmp_path / "venv" / "numba-cache")


def test_each_engine_version_has_its_own_cache_folder(tmp_path, monkeypatch):
    # numba 0.68 keys a cached function on its own file's bytes: a step loop compiled
    # by a process that imported the old kernels, written after the sources changed,
    # would be loaded as current from a shared folder. Named after the sources' hash,
    # the folders of two versions never mix; old ones go once unused for a day.
    from demcal import _engine_sources

    src = tmp_path / "src"
    src.mkdir()
    (src / "forces.py").write_text("# driver\n")
    monkeypatch.setattr(_engine_sources, "sources", lambda: [src / "forces.py"])
    base = tmp_path / "numba-cache"
    first = demcal.engine_cache_dir(str(base))
    assert first == str(base / ("engine-" + _engine_sources.digest()))
    os.makedirs(first)
    (src / "forces.py").write_text("# driver, changed\n")
    second = demcal.engine_cache_dir(str(base))
    assert second != first and os.path.isdir(first)     # the old one is still in use
    old = 1_000_000_000
    os.utime(first, (old, old))
    os.makedirs(second)
    assert demcal.engine_cache_dir(str(base)) == second
    assert not os.path.exists(first) and os.path.isdir(second)


def test_the_import_names_the_engine_folder(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    out = subprocess.run([sys.executable, "-c", "import os, demcal; print(os.environ['NUMBA_CACHE_DIR'])"],
                         capture_output=True, text=True, env=env).stdout.strip()
    from demcal import _engine_sources

    assert os.path.basename(out) == "engine-" + _engine_sources.digest()


def test_an_unwritable_prefix_falls_back_to_the_users_cache(tmp_path, monkeypatch):
    prefix = str(tmp_path / "usr")
    monkeypatch.setattr(sys, "prefix", prefix)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(demcal, "_writable_folder", lambda path: not path.startswith(prefix))
    assert demcal.numba_cache_dir() == str(tmp_path / "cache" / "demcal" / "numba-cache")
    monkeypatch.setattr(demcal, "_writable_folder", lambda path: False)
    assert demcal.numba_cache_dir() is None  # numba's own places then


def test_writable_folder(tmp_path):
    assert demcal._writable_folder(str(tmp_path / "not" / "yet"))
    (tmp_path / "file").write_text("")
    assert not demcal._writable_folder(str(tmp_path / "file" / "below"))


def _cache_dir_of_a_fresh_process(env):
    code = ("import os, sys, demcal, numba; "
            "print(os.environ.get('NUMBA_CACHE_DIR')); print(numba.config.CACHE_DIR); print(sys.prefix)")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout.splitlines()
    return out


#: the folder of this version of the engine (test_each_engine_version_has_its_own_cache_folder)
ENGINE = "engine-" + __import__("demcal._engine_sources", fromlist=["digest"]).digest()


def test_a_bare_process_uses_the_prefix_cache_and_a_set_variable_wins(tmp_path):
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    chosen, numba_sees, prefix = _cache_dir_of_a_fresh_process(env)
    assert chosen == numba_sees == os.path.join(prefix, "numba-cache", ENGINE)
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "mine")
    chosen, numba_sees, _ = _cache_dir_of_a_fresh_process(env)
    assert chosen == numba_sees == str(tmp_path / "mine")


def test_numba_imported_first_still_sees_the_choice():
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    code = "import sys, numba, demcal; print(numba.config.CACHE_DIR); print(sys.prefix)"
    numba_sees, prefix = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                                        text=True, check=True).stdout.splitlines()
    assert numba_sees == os.path.join(prefix, "numba-cache", ENGINE)


# ------------------------------------------------------------ saying that it compiles --

def _compile_event(module):
    from numba.core import event

    dispatcher = SimpleNamespace(py_func=SimpleNamespace(__module__=module))
    return event.Event("numba:compile", event.EventStatus.START, data={"dispatcher": dispatcher})


def test_compiling_an_engine_function_is_said_once(monkeypatch, capsys):
    monkeypatch.setattr(_cache, "_announced", False)
    _cache._announce(_compile_event("numpy.something"))   # not ours: nothing
    assert capsys.readouterr().err == ""
    _cache._announce(_compile_event("demcal.dem.forces"))
    _cache._announce(_compile_event("demcal.dem.stepper"))
    assert capsys.readouterr().err == _cache.COMPILING + "\n"


def test_the_listener_is_registered_with_numba(monkeypatch, capsys):
    from numba.core import event

    _cache.announce_compilation()
    _cache.announce_compilation()  # once
    assert sum(type(listener).__name__ == "_FirstCompile"
               for listener in event._registered["numba:compile"]) == 1
    monkeypatch.setattr(_cache, "_announced", False)
    event.broadcast(_compile_event("demcal.geometry.kernels"))
    assert _cache.COMPILING in capsys.readouterr().err


def test_the_engine_asks_for_openmp_before_numba_starts_its_threads():
    # Simulation() asks numba for its thread count, which starts the threading layer:
    # the engine's preference (OpenMP before TBB, _cache.prefer_openmp) must be set
    # before that, or the split step loop runs on TBB (measured: 2.7x slower on a
    # loaded 2-core machine). The layer started is the first of the engine's order that
    # this numba has (OpenMP wherever numba ships it).
    code = ("import demcal.dem, numba; "
            "from demcal.particles.materials import soil, soil_interaction; "
            "demcal.dem.Simulation([soil()], soil_interaction()); "
            "print(numba.threading_layer(), *numba.config.THREADING_LAYER_PRIORITY)")
    env = dict(os.environ, NUMBA_NUM_THREADS="2")
    env.pop("NUMBA_THREADING_LAYER", None)
    env.pop("NUMBA_THREADING_LAYER_PRIORITY", None)
    layer, *priority = subprocess.run([sys.executable, "-c", code], check=True,
                                      capture_output=True, text=True,
                                      env=env).stdout.split()[-4:]
    assert priority == ["omp", "tbb", "workqueue"]
    available = []
    for name, module in (("omp", "omppool"), ("tbb", "tbbpool"), ("workqueue", "workqueue")):
        try:
            __import__(f"numba.np.ufunc.{module}")
            available.append(name)
        except ImportError:
            pass
    assert layer == available[0]


def test_the_guard_hashes_the_named_tuples_the_step_loop_takes():
    # numba's cache index pickles the classes of its arguments by name; renaming one
    # (stepper.Translations became WallMotions) made the index unreadable
    # (AttributeError while loading), so their modules must clear the cache too
    names = {p.name for p in _cache._SOURCES}
    assert {"stepper.py", "storage.py", "walltable.py", "backend.py"} <= names
