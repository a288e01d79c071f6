"""Chained campaigns: a condition's fixed settings from another campaign's calibration.

A campaign file may say, for one condition (``[[conditions]] from_campaign``) or for all
(``[campaign] from_campaign``), that its runs of a condition take the values another
campaign calibrated for the condition of the same name: the sliding campaign on film
uses, for each moisture content, the inter-particle values the repose campaign found for
that moisture content. The loader only names that campaign
(:class:`~demcal.campaign.config.Upstream`); :func:`resolve_chain` reads the solution its
``demcal calibrate`` stored (``calibration.json`` in its work folder) when runs are planned,
so the next command picks up a calibration made since.

For one condition's runs a setting's value comes from, first to last: the condition's
``[conditions.settings]``, the values calibrated by its ``from_campaign``,
``[experiment.settings]``, the virtual test's default. A factor's own parameter is never
fixed. Conditions with different fixed settings get a design each
(:meth:`~demcal.campaign.config.Campaign.designs`); the run keys hash every setting, so
stored runs are never reused across different fixed settings.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any, Mapping

from demcal.campaign.config import Campaign, Upstream
from demcal.errors import ConfigError, DataError

#: Where a fixed value came from (:func:`condition_settings`).
SOURCE_FILE = "campaign file"
SOURCE_DEFAULT = "default"


def upstream_source(upstream: Upstream) -> str:
    """``campaign repose.toml, calibrated``: the source of a value taken from ``upstream``."""
    return f"campaign {upstream.path.name}, calibrated"


def calibration_path(campaign) -> Path:
    """Where ``demcal calibrate`` writes its result for ``campaign``."""
    return Path(campaign.workdir) / "calibration.json"


def read_calibration(campaign) -> tuple[dict, Path, str]:
    """The parsed calibration.json of ``campaign``, its path and its SHA-256 (what a
    chained campaign and the material card, :mod:`demcal.export.card`, read).

    Raises
    ------
    DataError
        There is none yet, or it is not a JSON object: one sentence saying to run
        ``demcal calibrate`` first.
    """
    path = calibration_path(campaign)
    run = f"run `demcal calibrate {campaign.path}` first"
    try:
        blob = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{campaign.path.name} has no calibration yet ({path} does not exist); "
                        f"{run}.") from None
    try:
        data = json.loads(blob.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        reason = str(exc).split("\n")[0].rstrip(".")
        raise DataError(f"{path} is not valid JSON ({reason}); run `demcal calibrate "
                        f"{campaign.path}` again.") from None
    if not isinstance(data, dict) or not isinstance(data.get("conditions"), list):
        raise DataError(f"{path} holds no calibrated conditions; run `demcal calibrate "
                        f"{campaign.path}` again.")
    return data, path, hashlib.sha256(blob).hexdigest()


def resolve_chain(campaign: Campaign) -> Campaign:
    """``campaign`` with the calibrated values of every condition's ``from_campaign`` read
    (the same campaign when it takes none, or has read them already).

    Raises
    ------
    DataError
        The other campaign has no calibration yet (the sentence names the ``demcal
        calibrate`` to run first), or it holds none of the condition.
    ConfigError
        A calibrated value that would fix one of this campaign's factors, that is not a
        setting of this campaign's virtual test, or that is out of its range.
    """
    if all(c.upstream is None or c.upstream.values is not None for c in campaign.conditions):
        return campaign
    from demcal.bench.registry import get_experiment, resolve_settings

    experiment = get_experiment(campaign.test)
    table = experiment.settings(campaign.profile)
    factors = {f.parameter for f in campaign.factors}
    calibrations: dict[Any, dict] = {}
    conditions = []
    for condition in campaign.conditions:
        upstream = condition.upstream
        if upstream is None or upstream.values is not None:
            conditions.append(condition)
            continue
        where = f"{campaign.path.name}, condition '{condition.name}'"
        if upstream.path not in calibrations:
            try:
                data = read_calibration(upstream)[0]
            except DataError as exc:
                raise DataError(f"{campaign.path.name} takes the settings of its conditions from "
                                f"{upstream.path.name}: {exc}") from None
            if data.get("campaign", upstream.name) != upstream.name:
                raise DataError(f"{where}: {upstream.workdir / 'calibration.json'} holds the calibration of campaign "
                                f"'{data.get('campaign')}', not of '{upstream.name}' ({upstream.path.name}); run "
                                f"`demcal calibrate {upstream.path}` first.")
            calibrations[upstream.path] = data
        data = calibrations[upstream.path]
        entries = {e.get("name"): e for e in data["conditions"] if isinstance(e, Mapping)}
        entry = entries.get(condition.name)
        if entry is None:
            held = ", ".join(repr(n) for n in entries) or "none"
            raise DataError(f"{where}: the calibration of {upstream.path.name} holds no condition "
                            f"'{condition.name}' (it holds {held}); name the conditions alike in both files, or "
                            f"run `demcal calibrate {upstream.path}` if it has that condition now.")
        chosen = entry.get("chosen")
        if (not isinstance(chosen, Mapping) or not chosen or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in chosen.values())):
            raise DataError(f"{where}: the calibration of {upstream.path.name} holds no calibrated values for "
                            f"'{condition.name}'; run `demcal calibrate {upstream.path}` again.")
        for key in chosen:
            if key in factors:
                raise ConfigError(f"{where}: '{key}', calibrated by {upstream.path.name}, is a factor of this "
                                  "campaign and cannot also be fixed; drop the factor, or take this condition's "
                                  "settings from a campaign that does not calibrate it.")
            if key not in table:
                raise ConfigError(f"{where}: '{key}', calibrated by {upstream.path.name}, is not a setting of "
                                  f"{campaign.test}; chain campaigns whose virtual tests share their parameters.")
        values = {key: float(value) for key, value in chosen.items()}
        try:
            resolve_settings(experiment, {**campaign.settings, **values, **condition.settings}, campaign.profile)
        except ConfigError as exc:
            raise ConfigError(f"{where}: the values calibrated by {upstream.path.name} are not a valid run: "
                              f"{exc}") from None
        status = entry.get("status")
        profile = data.get("profile")
        resolved = dataclasses.replace(upstream, values=values, status=status if isinstance(status, str) else None,
                                       profile=profile if isinstance(profile, str) else None)
        conditions.append(dataclasses.replace(condition, upstream=resolved))
    return dataclasses.replace(campaign, conditions=tuple(conditions))


def condition_settings(campaign: Campaign) -> dict[str, dict[str, tuple[Any, str]]]:
    """Condition name -> setting -> (value, source) for every setting fixed for some
    condition's runs: source "campaign file" (``[experiment.settings]`` or
    ``[conditions.settings]``), "campaign repose.toml, calibrated" (its ``from_campaign``)
    or "default" (the test's default, where another condition fixes the setting)."""
    from demcal.bench.registry import get_experiment

    keys = list(dict.fromkeys([*campaign.settings, *(k for c in campaign.conditions for k in c.fixed)]))
    table = get_experiment(campaign.test).settings(campaign.profile)
    out: dict[str, dict[str, tuple[Any, str]]] = {}
    for condition in campaign.conditions:
        upstream = condition.upstream.values if condition.upstream is not None else {}
        rows = {}
        for key in keys:
            if key in condition.settings:
                rows[key] = (condition.settings[key], SOURCE_FILE)
            elif key in upstream:
                rows[key] = (upstream[key], upstream_source(condition.upstream))
            elif key in campaign.settings:
                rows[key] = (campaign.settings[key], SOURCE_FILE)
            else:
                rows[key] = (table[key].default, SOURCE_DEFAULT)
        out[condition.name] = rows
    return out


def chain_notes(campaign: Campaign) -> list[str]:
    """What a reader must know of the values taken from other campaigns: a condition whose
    loop there did not end verified, or that was calibrated at another profile."""
    notes = []
    for condition in campaign.conditions:
        upstream = condition.upstream
        if upstream is None or upstream.values is None:
            continue
        if upstream.status is not None and upstream.status != "verified":
            notes.append(f"condition '{condition.name}' takes the values {upstream.path.name} calibrated for it, "
                         f"whose loop there ended '{upstream.status}', not verified; calibrate "
                         f"{upstream.path.name} further before trusting what rests on them.")
        if upstream.profile is not None and upstream.profile != campaign.profile:
            notes.append(f"condition '{condition.name}' takes values {upstream.path.name} calibrated at profile "
                         f"'{upstream.profile}', and runs here at '{campaign.profile}'.")
    return notes
