"""Lab records of a granular sample: moisture, bulk density, sieve table, measured angles.

A :class:`LabRecord` is plain data, built from a campaign file's table by
:meth:`LabRecord.from_dict` (which names the bad key in a :class:`ConfigError`). Its
angles are either given as ``mean +- sd`` or measured from raw data: heap photos
(:mod:`demcal.measure.photo`) and inclined-plane ruler readings
(:mod:`demcal.measure.incline`); :func:`resolve_targets` turns either into the
:class:`MeasuredAngle` targets of a calibration.

Accepted table (TOML shown; every key but ``name`` is optional)::

    name = "L"                      # sample name
    moisture_percent = 6.26         # water content [%]
    moisture_sd_percent = 1.5
    bulk_density = 1697.95          # [kg/m^3]
    [sieve]                         # particle-size distribution (mass %)
    edges_mm = [0, 0.25, 0.5, 1, 2, 5, inf]   # class bounds [mm]; inf for ">= 5 mm"
    mass_percent = [16.66, 11.37, 20.36, 14.36, 24.52, 12.73]
    [repose]                        # angle of repose: either given ...
    mean_deg = 31.07
    sd_deg = 2.1
    n = 20
    # ... or measured: photos = ["photos/L/*.jpg"], mm_per_px = 0.2,
    #     roi = [x0, y0, x1, y1], base_y = 820,
    #     exclude = ["photos/L/IMG_0042.jpg"]   # photos to leave out, on purpose
    [sliding]                       # inclined-plane sliding angle: given ...
    mean_deg = 25.42
    sd_deg = 2.6
    n = 10
    # ... or measured: H_mm = [...], L_mm = 300, repeats = 3, H0_mm = 0
    [drum]                          # rotating drum: dynamic angle at each speed
    rpm = [2, 5, 10]                # drum speeds [1/min]
    mean_deg = [33.0, 35.5, 38.0]   # angle at each speed [deg]
    sd_deg = [1.2, 1.4, 1.5]
    n = 5                           # tests at each speed (or one number a speed)

The reference paper's two samples (IJABE 2020, Table 1 and Sections 2.1 and 3.1) are in
:func:`paper_records`.
"""

from __future__ import annotations

import glob
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from demcal.errors import ConfigError, DataError

#: A sieve table's mass percentages must sum to 100 within this [%].
SIEVE_SUM_TOLERANCE = 0.5


@dataclass(frozen=True)
class MeasuredAngle:
    """An angle measured in the lab: mean +- sd over n tests [deg]."""

    mean_deg: float
    sd_deg: float = float("nan")
    n: int = 0
    source: str = "given"  #: "given", "photos" or "incline readings"

    def to_dict(self) -> dict:
        return {"mean_deg": self.mean_deg, "sd_deg": self.sd_deg, "n": self.n, "source": self.source}


@dataclass(frozen=True)
class SieveTable:
    """Particle-size distribution by sieving.

    Attributes
    ----------
    edges_mm : (k + 1,) increasing class bounds [mm]; the first may be 0 ("< d") and
        the last ``inf`` (">= d").
    mass_percent : (k,) mass of each class [%], summing to 100 within
        :data:`SIEVE_SUM_TOLERANCE`.
    """

    edges_mm: np.ndarray
    mass_percent: np.ndarray

    def __post_init__(self):
        edges = np.asarray(self.edges_mm, dtype=float).ravel()
        mass = np.asarray(self.mass_percent, dtype=float).ravel()
        if edges.size != mass.size + 1 or mass.size == 0:
            raise DataError(f"a sieve table needs one more class bound than classes; got "
                            f"{edges.size} bounds for {mass.size} mass percentages.")
        if np.isnan(edges).any() or edges[0] < 0 or np.any(np.diff(edges) <= 0):
            raise DataError(f"sieve class bounds {edges.tolist()} must be >= 0 and increasing.")
        if not np.all(np.isfinite(mass)) or np.any(mass < 0):
            raise DataError(f"sieve mass percentages {mass.tolist()} must be non-negative numbers.")
        total = mass.sum()
        if abs(total - 100.0) > SIEVE_SUM_TOLERANCE:
            raise DataError(f"sieve mass percentages sum to {total:.2f} %, not 100 % "
                            f"(within {SIEVE_SUM_TOLERANCE} %); check the table.")
        object.__setattr__(self, "edges_mm", edges)
        object.__setattr__(self, "mass_percent", mass)

    @property
    def fractions(self) -> np.ndarray:
        """Mass fraction of each class, normalised to sum 1 [-]."""
        return self.mass_percent / self.mass_percent.sum()

    @property
    def lower_mm(self) -> np.ndarray:
        return self.edges_mm[:-1]

    @property
    def upper_mm(self) -> np.ndarray:
        return self.edges_mm[1:]

    def to_dict(self) -> dict:
        return {"edges_mm": self.edges_mm.tolist(), "mass_percent": self.mass_percent.tolist()}


@dataclass(frozen=True)
class DrumReading:
    """A rotating drum's dynamic angle of repose measured in the lab at one speed."""

    rpm: float  #: drum speed [1/min]
    angle: MeasuredAngle  #: the dynamic angle [deg], mean +- sd over n tests

    def to_dict(self) -> dict:
        return {"rpm": self.rpm, **self.angle.to_dict()}


@dataclass(frozen=True)
class PhotoSet:
    """Heap photos to be measured for a record's angle of repose."""

    patterns: tuple[str, ...]
    mm_per_px: float | None = None
    roi: tuple[int, int, int, int] | None = None
    base_y: float | None = None
    exclude: tuple[str, ...] = ()  #: patterns of photos left out on purpose

    def paths(self, base_dir: str | Path | None = None, sample: str | None = None,
              confine: bool = False) -> list[str]:
        """Photo files, glob patterns expanded relative to ``base_dir``, sorted, less
        those matched by ``exclude``; with ``confine``, every photo must lie inside
        ``base_dir`` (links followed).

        Raises
        ------
        DataError
            A pattern or an exclusion matches no file, every photo is excluded, or (with
            ``confine``) a photo lies outside ``base_dir``; ``sample`` names the record in
            the sentence.
        """
        of = "" if sample is None else f" of sample '{sample}'"

        def expand(pattern):
            full = pattern if base_dir is None or Path(pattern).is_absolute() else str(Path(base_dir) / pattern)
            return full, sorted(glob.glob(full))

        out = []
        folder = Path(base_dir if base_dir is not None else ".").resolve()
        for pattern in self.patterns:
            full, hits = expand(pattern)
            if not hits:
                raise DataError(f"no photo matches '{full}'; check the path in the lab record.")
            for hit in hits if confine else ():
                resolved = Path(os.path.realpath(hit))
                if folder not in resolved.parents:
                    raise DataError(f"photo '{hit}'{of} lies outside the campaign file's folder {folder}; move "
                                    "it into that folder, or pass --allow-outside to use it where it is.")
            out.extend(hits)
        left_out = set()
        for pattern in self.exclude:
            full, hits = expand(pattern)
            if not hits:
                raise DataError(f"exclude pattern '{pattern}'{of} matches no photo; check the path "
                                "in the lab record.")
            left_out.update(_key(h) for h in hits)
        kept = [p for p in out if _key(p) not in left_out]
        if out and not kept:
            raise DataError(f"every photo{of} is excluded; keep at least one in 'photos' or give "
                            "'mean_deg' instead.")
        return kept


def _key(path) -> str:
    return os.path.normcase(os.path.abspath(path))


@dataclass(frozen=True)
class InclineReadings:
    """Ruler readings of the inclined-plane test: H per reading [mm], arm L [mm], and the
    starting point's height above the base with the plate level, H0 [mm]."""

    H_mm: tuple[float, ...]
    L_mm: float = 300.0
    repeats: int | None = None
    H0_mm: float = 0.0


@dataclass(frozen=True)
class LabRecord:
    """What the lab knows about one sample.

    Attributes
    ----------
    name : sample name.
    moisture_percent, moisture_sd_percent : water content [%] and its sd.
    bulk_density : [kg/m^3].
    sieve : particle-size distribution, if measured.
    repose, sliding : angle of repose and sliding angle as measured (mean +- sd).
    repose_photos : heap photos to measure instead of a given ``repose``.
    incline : inclined-plane readings to convert instead of a given ``sliding``.
    notes : free text.
    """

    name: str
    moisture_percent: float | None = None
    moisture_sd_percent: float | None = None
    bulk_density: float | None = None
    sieve: SieveTable | None = None
    repose: MeasuredAngle | None = None
    sliding: MeasuredAngle | None = None
    repose_photos: PhotoSet | None = None
    incline: InclineReadings | None = None
    drum: tuple[DrumReading, ...] = ()
    notes: str = ""

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "lab record", *, file: str | None = None,
                  lines: Mapping[tuple, int] | None = None) -> "LabRecord":
        """Build a record from a parsed table (see the module docstring for the keys).

        ``where`` prefixes error messages, e.g. ``"[lab.L]"``; with ``file`` (the lab
        file's name) and ``lines`` (the 1-based line of each key path inside the record,
        ``()`` for its table, ``("repose", "mean_deg")`` for a key), a sentence names the
        file and the line of the key it is about: ``lab.toml line 21 [L] repose: ...``.

        Raises
        ------
        ConfigError
            Unknown key, missing name, a value of the wrong type or out of range; the
            sentence names the key.
        """
        at = _Place(where, file, lines or {})
        if not isinstance(d, Mapping):
            raise ConfigError(f"{at} must be a table of keys, not {type(d).__name__}.")
        known = {"name", "moisture_percent", "moisture_sd_percent", "bulk_density", "sieve",
                 "repose", "sliding", "drum", "notes"}
        _unknown(d, known, at)
        if "name" not in d or not isinstance(d["name"], str) or not d["name"].strip():
            raise ConfigError(f"{at.key('name')} needs a 'name' (the sample's name, a string).")
        moisture = _number(d, "moisture_percent", at, 0.0, 100.0)
        moisture_sd = _number(d, "moisture_sd_percent", at, 0.0, 100.0)
        density = _number(d, "bulk_density", at, 0.0, None, open_low=True)
        sieve = None
        if "sieve" in d:
            s = d["sieve"]
            if not isinstance(s, Mapping):
                raise ConfigError(f"{at.key('sieve')}: 'sieve' must be a table with edges_mm and mass_percent.")
            _unknown(s, {"edges_mm", "mass_percent"}, at.sub("sieve"))
            for key in ("edges_mm", "mass_percent"):
                if key not in s:
                    raise ConfigError(f"{at.key('sieve')}: 'sieve.{key}' is missing.")
            try:
                sieve = SieveTable(_numbers(s, "edges_mm", at.sub("sieve")),
                                   _numbers(s, "mass_percent", at.sub("sieve")))
            except DataError as exc:
                raise ConfigError(f"{at.key('sieve')}: 'sieve': {exc}") from None
        repose = photos = None
        if "repose" in d:
            repose, photos = _repose(d["repose"], at)
        sliding = incline = None
        if "sliding" in d:
            sliding, incline = _sliding(d["sliding"], at)
        drum = _drum(d["drum"], at) if "drum" in d else ()
        notes = d.get("notes", "")
        if not isinstance(notes, str):
            raise ConfigError(f"{at.key('notes')}: 'notes' must be a string.")
        return cls(name=d["name"].strip(), moisture_percent=moisture, moisture_sd_percent=moisture_sd,
                   bulk_density=density, sieve=sieve, repose=repose, sliding=sliding,
                   repose_photos=photos, incline=incline, drum=drum, notes=notes)

    def to_dict(self) -> dict:
        out: dict[str, Any] = {"name": self.name}
        for key in ("moisture_percent", "moisture_sd_percent", "bulk_density"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        if self.sieve is not None:
            out["sieve"] = self.sieve.to_dict()
        if self.repose is not None:
            out["repose"] = self.repose.to_dict()
        if self.sliding is not None:
            out["sliding"] = self.sliding.to_dict()
        if self.drum:
            out["drum"] = [reading.to_dict() for reading in self.drum]
        if self.notes:
            out["notes"] = self.notes
        return out


def resolve_targets(record: LabRecord, base_dir: str | Path | None = None,
                    out_dir: str | Path | None = None, confine: bool = False,
                    drum_rpm: float | None = None,
                    drums: Mapping[str, float | None] | None = None) -> dict[str, MeasuredAngle]:
    """The record's measured angles, measuring photos and readings where given.

    Returns ``{"repose_angle_deg": ..., "sliding_angle_deg": ..., "dynamic_angle_deg":
    ...}`` (the keys present in the record). Photos are found relative to ``base_dir``
    (and with ``confine`` must lie inside it); annotated PNGs go to ``out_dir``. The drum's
    angle is the reading at ``drum_rpm`` (the speed the campaign turns its drum at), or the
    only reading when ``drum_rpm`` is None; ``drums`` names several drum responses with
    their speeds instead (a joint test's drums at two speeds: ``{"dynamic_angle_deg": 5,
    "dynamic_angle_deg_2": 15}``).

    Raises
    ------
    DataError
        No photo matches, or a photo cannot be measured: it is named, never silently
        left out of the mean (the record's ``exclude`` leaves photos out on purpose); or
        inclined-plane readings that give no angle (the sentence names the sample).
    """
    from demcal.measure.incline import measure_incline
    from demcal.measure.photo import measure_photos

    out: dict[str, MeasuredAngle] = {}
    if record.repose is not None:
        out["repose_angle_deg"] = record.repose
    elif record.repose_photos is not None:
        ps = record.repose_photos
        paths = ps.paths(base_dir, record.name, confine)
        batch = measure_photos(paths, roi=ps.roi, base_y=ps.base_y,
                               mm_per_px=ps.mm_per_px, out_dir=out_dir)
        if batch.failures:
            raise DataError(_failed_photos(record.name, batch.failures, len(paths), base_dir))
        s = batch.summary
        out["repose_angle_deg"] = MeasuredAngle(s.mean, s.sd, s.n, "photos")
    if record.sliding is not None:
        out["sliding_angle_deg"] = record.sliding
    elif record.incline is not None:
        try:
            inc = measure_incline(record.incline.H_mm, record.incline.L_mm, record.incline.repeats,
                                  record.incline.H0_mm)
        except DataError as exc:
            raise DataError(f"the inclined-plane readings of sample '{record.name}': {exc}") from None
        level = f", H0 {inc.H0_mm:g} mm" if inc.H0_mm else ""
        out["sliding_angle_deg"] = MeasuredAngle(inc.mean_deg, inc.sd_deg, inc.n, f"incline readings{level}")
    if record.drum:
        for response, rpm in (drums if drums is not None else {"dynamic_angle_deg": drum_rpm}).items():
            out[response] = drum_reading(record, rpm).angle
    return out


def drum_reading(record: LabRecord, rpm: float | None) -> DrumReading:
    """The record's drum reading at ``rpm`` [1/min] (its only one when None).

    Raises
    ------
    DataError
        No reading at that speed, or several readings and no speed.
    """
    speeds = ", ".join(f"{r.rpm:g}" for r in record.drum)
    if rpm is None:
        if len(record.drum) == 1:
            return record.drum[0]
        raise DataError(f"sample '{record.name}' has drum readings at {speeds} rpm; the campaign must "
                        "turn its drum at one of them (set drum.rpm).")
    for reading in record.drum:
        if math.isclose(reading.rpm, float(rpm), rel_tol=1e-9):
            return reading
    raise DataError(f"sample '{record.name}' has no drum reading at {float(rpm):g} rpm, only at {speeds} rpm; "
                    "set drum.rpm to one of them or add the reading to the lab file.")


def _failed_photos(sample: str, failures, total: int, base_dir) -> str:
    """The sentence refusing a record whose photos did not all measure: the first
    photo and why, and the ``exclude`` line that would leave them out."""

    def shown(photo):  # as written in the lab record: relative to its folder
        if base_dir is not None:
            try:
                return Path(os.path.relpath(photo, base_dir)).as_posix()
            except ValueError:  # another drive
                pass
        return Path(photo).as_posix()

    first, why = failures[0]
    names = [shown(p) for p, _ in failures]
    exclude = "exclude = [" + ", ".join(f'"{n}"' for n in names) + "]"
    why = why.rstrip(".")
    if len(failures) == 1:
        return (f"photo '{names[0]}' of sample '{sample}' cannot be measured ({why}); fix or "
                f"replace it, or leave it out with {exclude} in the sample's [repose] table.")
    return (f"{len(failures)} of the {total} photos of sample '{sample}' cannot be measured, the "
            f"first '{names[0]}' ({why}); fix or replace them, or leave them out with {exclude} "
            "in the sample's [repose] table.")


def paper_records() -> dict[str, LabRecord]:
    """The reference paper's two samples: surface (L) and internal (I).

    Source: IJABE 2020, doi:10.25165/j.ijabe.20201304.5586 -- Table 1 (water content,
    sieve table, average volume weight taken as bulk density [kg/m^3]), Section 2.1
    (angle of repose over 20 photos) and Section 3.1 (sliding angle, 10 groups x 3).
    """
    edges = [0.0, 0.25, 0.5, 1.0, 2.0, 5.0, float("inf")]
    return {
        "L": LabRecord(
            name="L", moisture_percent=6.26, moisture_sd_percent=1.5, bulk_density=1697.95,
            sieve=SieveTable(edges, [16.66, 11.37, 20.36, 14.36, 24.52, 12.73]),
            repose=MeasuredAngle(31.07, 2.1, 20), sliding=MeasuredAngle(25.42, 2.6, 10),
            notes="surface sample, IJABE 2020 Table 1"),
        "I": LabRecord(
            name="I", moisture_percent=14.1, moisture_sd_percent=2.1, bulk_density=1087.85,
            sieve=SieveTable(edges, [38.58, 7.9, 19.94, 8.47, 18.75, 6.36]),
            repose=MeasuredAngle(39.88, 2.2, 20), sliding=MeasuredAngle(30.46, 3.2, 10),
            notes="internal sample, IJABE 2020 Table 1"),
    }


# --- parsing helpers -------------------------------------------------------------------

@dataclass(frozen=True)
class _Place:
    """Where a record's (sub-)table is written, for error sentences: ``where`` (``[L]``),
    and with the lab ``file`` and its key ``lines`` the line of the key a sentence names
    (``lab.toml line 21 [L] repose``)."""

    where: str
    file: str | None = None
    lines: Mapping[tuple, int] = field(default_factory=dict)
    table: tuple[str, ...] = ()  #: the sub-table, e.g. ("repose",)

    def sub(self, name: str) -> "_Place":
        return _Place(self.where, self.file, self.lines, self.table + (name,))

    def key(self, key: str | None = None) -> str:
        """The prefix of a sentence about ``key`` of this table (None: the table)."""
        text = " ".join((self.where,) + self.table)
        if self.file is None:
            return text
        path = self.table + ((key,) if key is not None else ())
        while path and path not in self.lines:
            path = path[:-1]
        line = self.lines.get(path)
        return f"{self.file} line {line} {text}" if line is not None else f"{self.file} {text}"

    def __str__(self) -> str:
        return self.key()


def _unknown(d: Mapping, known: set, at: _Place) -> None:
    extra = sorted(set(d) - known)
    if extra:
        raise ConfigError(f"{at.key(extra[0])}: unknown key '{extra[0]}'; known keys are {', '.join(sorted(known))}.")


def _number(d, key, at: _Place, low=None, high=None, open_low=False, required=False, open_high=False):
    if key not in d:
        if required:
            raise ConfigError(f"{at}: '{key}' is missing.")
        return None
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ConfigError(f"{at.key(key)}: '{key}' must be a finite number, got {v!r}.")
    if (low is not None and (v < low or (open_low and v == low))
            or high is not None and (v > high or (open_high and v == high))):
        rng = (f"{'(' if open_low else '['}{low:g}, {'inf' if high is None else f'{high:g}'}"
               f"{')' if open_high or high is None else ']'}")
        raise ConfigError(f"{at.key(key)}: '{key}' = {v} is outside its allowed range {rng}.")
    return float(v)


def _numbers(d, key, at: _Place) -> list[float]:
    v = d[key]
    if isinstance(v, (str, bytes)) or not hasattr(v, "__iter__"):
        raise ConfigError(f"{at.key(key)}: '{key}' must be a list of numbers.")
    out = []
    for item in v:
        if isinstance(item, bool) or not isinstance(item, (int, float)):
            raise ConfigError(f"{at.key(key)}: '{key}' must be a list of numbers, found {item!r}.")
        out.append(float(item))
    return out


def _given_angle(t, at: _Place) -> MeasuredAngle:
    """``mean_deg`` in [0, 90) deg (an angle of repose or sliding below a vertical face),
    ``sd_deg`` in [0, 90] and ``n`` of the table at ``at``."""
    mean = _number(t, "mean_deg", at, 0.0, 90.0, required=True, open_high=True)
    sd = _number(t, "sd_deg", at, 0.0, 90.0)
    n = t.get("n", 0)
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise ConfigError(f"{at.key('n')}: 'n' must be a whole number >= 0, got {n!r}.")
    return MeasuredAngle(mean, float("nan") if sd is None else sd, n)


def _given_or_measured(t, at: _Place, key, source, table_text, source_text, keys):
    """The angle ``key`` given as ``mean_deg`` (and ``sd_deg``, ``n``), or ``None`` when
    the table holds its ``source`` data (photos, readings) instead; ``keys`` are the
    keys that data may use; ``table_text`` and ``source_text`` name it in messages."""
    if not isinstance(t, Mapping):
        raise ConfigError(f"{at.key(key)}: '{key}' must be a table (mean_deg/sd_deg/n or {table_text}).")
    here = at.sub(key)
    _unknown(t, {"mean_deg", "sd_deg", "n", *keys}, here)
    if "mean_deg" in t:
        if source in t:
            raise ConfigError(f"{here.key(source)}: give either 'mean_deg' or '{source}', not both.")
        return _given_angle(t, here)
    if source not in t:
        raise ConfigError(f"{here}: give 'mean_deg' (and 'sd_deg', 'n') or {source_text}.")
    return None


def _drum(t, at: _Place) -> tuple[DrumReading, ...]:
    """``[NAME.drum]``: ``rpm``, ``mean_deg``, ``sd_deg`` lists of one length (one entry a
    speed) and ``n`` (tests at each speed, one number or a list)."""
    if not isinstance(t, Mapping):
        raise ConfigError(f"{at.key('drum')}: 'drum' must be a table with rpm, mean_deg, sd_deg and n.")
    here = at.sub("drum")
    _unknown(t, {"rpm", "mean_deg", "sd_deg", "n"}, here)
    for key in ("rpm", "mean_deg"):
        if key not in t:
            raise ConfigError(f"{here}: '{key}' is missing; give the drum speeds [1/min] and the angle "
                              "measured at each [deg].")
    rpm = _numbers(t, "rpm", here)
    mean = _numbers(t, "mean_deg", here)
    sd = _numbers(t, "sd_deg", here) if "sd_deg" in t else [float("nan")] * len(rpm)
    n = t.get("n", 0)
    n = list(n) if isinstance(n, list) else [n] * len(rpm)
    if not rpm or not (len(rpm) == len(mean) == len(sd) == len(n)):
        raise ConfigError(f"{here}: rpm, mean_deg, sd_deg (and n, when a list) need one entry per speed; got "
                          f"{len(rpm)}, {len(mean)}, {len(sd)} and {len(n)}.")
    if any(not r > 0 for r in rpm) or len(set(rpm)) != len(rpm):
        raise ConfigError(f"{here.key('rpm')}: drum speeds must be > 0 and each given once, got {rpm}.")
    readings = []
    for r, m, s_, k in zip(rpm, mean, sd, n):
        angle = _given_angle({"mean_deg": m, **({"sd_deg": s_} if math.isfinite(s_) else {}), "n": k}, here)
        readings.append(DrumReading(r, angle))
    return tuple(readings)


def _repose(t, at: _Place):
    given = _given_or_measured(t, at, "repose", "photos", "photos", "'photos'",
                               ("photos", "mm_per_px", "roi", "base_y", "exclude"))
    if given is not None:
        return given, None
    here = at.sub("repose")
    photos = t["photos"]
    if isinstance(photos, str):
        photos = [photos]
    if not photos or not all(isinstance(p, str) for p in photos):
        raise ConfigError(f"{here.key('photos')}: 'photos' must be a file pattern or a list of them.")
    exclude = t.get("exclude", [])
    if isinstance(exclude, str):
        exclude = [exclude]
    if not isinstance(exclude, list) or not all(isinstance(p, str) for p in exclude):
        raise ConfigError(f"{here.key('exclude')}: 'exclude' must be a file pattern or a list of them "
                          "(the photos to leave out).")
    roi = None
    if "roi" in t:
        roi = _numbers(t, "roi", here)
        if len(roi) != 4:
            raise ConfigError(f"{here.key('roi')}: 'roi' must be [x0, y0, x1, y1] in pixels.")
        roi = tuple(int(v) for v in roi)
    return None, PhotoSet(tuple(photos), _number(t, "mm_per_px", here, 0.0, None, True),
                          roi, _number(t, "base_y", here, 0.0, None), tuple(exclude))


def _sliding(t, at: _Place):
    given = _given_or_measured(t, at, "sliding", "H_mm", "H_mm/L_mm", "'H_mm' readings",
                               ("H_mm", "L_mm", "repeats", "H0_mm"))
    if given is not None:
        return given, None
    from demcal.measure.incline import measure_incline

    here = at.sub("sliding")
    H = _numbers(t, "H_mm", here)
    L = _number(t, "L_mm", here, 0.0, None, open_low=True)
    H0 = _number(t, "H0_mm", here, 0.0, None)
    repeats = t.get("repeats")
    if repeats is not None and (isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1):
        raise ConfigError(f"{here.key('repeats')}: 'repeats' must be a whole number >= 1.")
    readings = InclineReadings(tuple(H), 300.0 if L is None else L, repeats, 0.0 if H0 is None else H0)
    if not H:
        raise ConfigError(f"{here.key('H_mm')}: there are no inclined-plane readings H to convert; give the "
                          "heights read on the ruler [mm], e.g. H_mm = [128, 131, 127].")
    try:  # every reading a sliding angle below 90 deg, in whole groups: refused here, not when converted
        measure_incline(readings.H_mm, readings.L_mm, readings.repeats, readings.H0_mm)
    except DataError as exc:
        raise ConfigError(f"{here.key('H_mm')}: {exc}") from None
    return None, readings
