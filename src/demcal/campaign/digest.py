"""The campaign hash: what decides a calibration, as one SHA-256.

:func:`campaign_hash` is the SHA-256 of the canonical JSON (sorted keys, floats to 12
significant digits) of :func:`resolved_config`: every field of the campaign that decides
what a calibration finds -- virtual test, profile, plug-ins, the *resolved* settings of
the test (its defaults under that profile with the campaign's overrides, so a change of
a demcal default changes the hash too; an option at the default that leaves it off is
left out), factors and their levels, design, responses,
seeds and replicates, model, conditions and their targets, verification -- and none of
what only names or places things (file path, work folder, lab file, executor, report
title, descriptions, labels, photos, lab records beyond their targets, published
reference values). Fields added to the campaign later are included by the same rule.

``demcal calibrate`` writes it into calibration.json, the material card carries it
(:mod:`demcal.export.card`), and ``demcal export`` refuses a calibration whose hash is
not the campaign file's any more.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any, Mapping

#: Campaign fields (at any depth) that name or place things and do not change a calibration.
_NOT_HASHED = frozenset({"path", "workdir", "lab_file", "executor", "title", "description", "label", "photo",
                         "reference_table", "reference", "unit", "units", "sample"})


def resolved_config(campaign) -> dict[str, Any]:
    """What decides a calibration of ``campaign``, as plain JSON data (see the module
    docstring): the campaign's fields less :data:`_NOT_HASHED`, with ``settings`` the
    test's full resolved settings at the campaign's profile."""
    from demcal.bench.registry import get_experiment, resolve_settings

    out = _plain(campaign)
    experiment = get_experiment(campaign.test)
    table = experiment.settings(campaign.profile)
    resolved = resolve_settings(experiment, campaign.settings, campaign.profile)
    # an option left off at its default decides nothing (Setting.inert): a new option
    # does not put every existing calibration out of date
    out["settings"] = _plain({key: value for key, value in resolved.items()
                              if not (getattr(table[key], "inert", False) and value == table[key].default)})
    return out


def campaign_hash(campaign) -> str:
    """``sha256:<hex>`` of the canonical JSON of :func:`resolved_config`."""
    blob = json.dumps(resolved_config(campaign), sort_keys=True, separators=(",", ":"))
    return "sha256:" + hashlib.sha256(blob.encode()).hexdigest()


def _plain(value: Any) -> Any:
    """``value`` as JSON data for the hash: dataclasses as dicts of their fields (less
    :data:`_NOT_HASHED` and None), floats to 12 significant digits."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.name not in _NOT_HASHED and getattr(value, f.name) is not None}
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items() if k not in _NOT_HASHED}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, (int, str)):
        return value
    if isinstance(value, float):
        return float(f"{value:.12g}") if math.isfinite(value) else str(value)
    if isinstance(value, Path):
        return value.name
    if hasattr(value, "tolist"):
        return _plain(value.tolist())
    return str(value)


def as_calibrated(campaign, calibration: Mapping[str, Any]):
    """``campaign`` as the calibration in ``calibration`` (a parsed calibration.json) ran
    it: at its design profile and production profile, with the values of the campaigns
    it takes some from read (:func:`demcal.campaign.chain.resolve_chain`)."""
    from demcal.campaign.chain import resolve_chain

    profile, production = calibration.get("profile"), calibration.get("production")
    if isinstance(profile, str) and profile != campaign.profile:
        campaign = campaign.with_profile(profile)
    if isinstance(production, str) and production != campaign.calibration.production:
        campaign = campaign.with_production(production)
    return resolve_chain(campaign)


def calibrated_from(campaign, calibration: Mapping[str, Any]) -> bool | None:
    """Whether ``calibration`` was calibrated from ``campaign`` as it is now (its stored
    ``campaign_hash`` against :func:`as_calibrated`'s); None when it stores no hash."""
    stored = calibration.get("campaign_hash")
    if not isinstance(stored, str):
        return None
    return stored.split(":")[-1] == campaign_hash(as_calibrated(campaign, calibration)).split(":")[-1]
