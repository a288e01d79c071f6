"""Bench tests register through one mechanism: the ``demcal.benches`` entry-point group
(demcal's own tests are listed in pyproject.toml like another package's would be)."""

from importlib.metadata import EntryPoint

import pytest

from demcal.bench import registry
from demcal.errors import ConfigError


def test_demcal_s_own_tests_come_through_the_entry_point_group():
    from importlib.metadata import entry_points
    modules = {ep.value for ep in entry_points(group=registry.ENTRY_POINT_GROUP)}
    assert {"demcal.bench.repose", "demcal.bench.incline", "demcal.bench.impact"} <= modules
    assert {"repose-funnel", "repose-cylinder", "incline", "impact"} <= set(registry.names())


def test_a_module_that_fails_to_load_is_one_sentence(monkeypatch):
    broken = EntryPoint(name="broken", value="demcal_no_such_module_xyz", group=registry.ENTRY_POINT_GROUP)
    own = EntryPoint(name="impact", value="demcal.bench.impact", group=registry.ENTRY_POINT_GROUP)
    monkeypatch.setattr("importlib.metadata.entry_points", lambda group: [own, broken])
    monkeypatch.setattr(registry, "_loaded", False)
    with pytest.raises(ConfigError, match=r"^the bench-test module 'demcal_no_such_module_xyz' "
                                          r"\(entry point 'broken' of an installed package\) failed to load: "):
        registry.names()


def test_missing_metadata_says_reinstall(monkeypatch):
    monkeypatch.setattr("importlib.metadata.entry_points", lambda group: [])
    monkeypatch.setattr(registry, "_loaded", False)
    with pytest.raises(ConfigError, match="reinstall demcal"):
        registry.get_experiment("incline")
