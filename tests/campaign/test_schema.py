"""The campaign file's declared schema (demcal.campaign.schema) and the one checker that
reads it (demcal.campaign.reader): every key is declared with its meaning, and each rule
of a declaration gives its sentence at the line of the key."""

from __future__ import annotations

from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path

import pytest

from demcal.campaign import schema
from demcal.campaign.config import _ALLOWED
from demcal.campaign.reader import Names, Reader, Text, allowed_keys, declared, key
from demcal.errors import ConfigError


def _tables(cls) -> list:
    """``cls`` and every table declared below it."""
    out = [cls]
    for f, kind in declared(cls):
        inner = f.metadata.get("entries") or (kind.__args__[0] if getattr(kind, "__args__", None) else kind)
        if is_dataclass(inner):
            out += _tables(inner)
    return out


def test_every_key_is_declared_with_its_meaning():
    tables = _tables(schema.CampaignFile)
    assert {schema.CampaignTable, schema.Target, schema.Response, schema.ExecutorConfig} <= set(tables)
    for cls in tables:
        for f, _ in declared(cls):
            assert f.metadata.get("doc"), f"{cls.__name__}.{f.name} has no doc"
    assert _ALLOWED == allowed_keys(schema.CampaignFile)
    assert _ALLOWED[""] == tuple(f.name for f in fields(schema.CampaignFile))
    assert _ALLOWED["conditions[].targets.*"] == ("mean", "sd")
    assert _ALLOWED["calibration"][-1] == "replicate_batch" and "budget_runs" not in _ALLOWED["calibration"]


@dataclass(frozen=True, kw_only=True)
class Toy:
    """A table with one key of each type and rule."""

    name: str = key(pattern=r"[a-z]+", says="name '{value}' must be lower-case letters", doc="required")
    label: Text = key("", fallback="name", doc="free text")
    count: int = key(2, minimum=1, doc="a whole number")
    share: float | None = key(None, above=0, below=1, off=True, says="'{key}' must lie in (0, 1), got {raw}",
                              doc="a fraction")
    kind: str = key("a", choices=("a", "b"), doc="a choice")
    flag: bool = key(True, doc="a flag")
    items: Names = key((), says="'{key}' must be a list of strings", check=lambda s: "no x" if s == "x" else None,
                       doc="a list")


def _read(text: str):
    reader = Reader(text, Path("toy.toml"))
    return reader.read(Toy, reader.table(reader.data, "toy", ()), ("toy",))


def test_the_reader_gives_defaults_and_fallbacks():
    toy = _read('[toy]\nname = " ab "\nshare = false\nlabel = 3\n')
    assert toy == Toy(name="ab", label="3", count=2, share=None, kind="a", flag=True, items=())
    assert _read('[toy]\nname = "ab"\n').label == "ab"


@pytest.mark.parametrize("line, sentence", [
    ('nmae = "ab"', "toy.toml line 3: unknown key 'nmae' in [toy]; did you mean 'name'?"),
    ('count = 0', "toy.toml line 3: 'count' must be at least 1, got 0."),
    ('count = 1.5', "toy.toml line 3: 'count' must be a whole number, got 1.5."),
    ('share = 1', "toy.toml line 3: 'share' must lie in (0, 1), got 1."),
    ('share = "x"', "toy.toml line 3: 'share' must be a finite number, got 'x'."),
    ('kind = "c"', "toy.toml line 3: 'kind' = 'c' is not known; choose one of: a, b."),
    ('flag = 1', "toy.toml line 3: 'flag' must be true or false, got 1."),
    ('items = "x"', "toy.toml line 3: 'items' must be a list of strings."),
    ('items = ["a", "x"]', "toy.toml line 3: no x."),
])
def test_each_rule_gives_its_sentence_at_the_line_of_the_key(line, sentence):
    with pytest.raises(ConfigError) as info:
        _read(f'[toy]\nname = "ab"\n{line}\n')
    assert str(info.value) == sentence
    with pytest.raises(ConfigError, match=r"^toy.toml line 2: name 'A1' must be lower-case letters\.$"):
        _read('[toy]\nname = "A1"\n')
    with pytest.raises(ConfigError, match=r"^toy.toml line 1: missing key 'name' in \[toy\]; add it\.$"):
        _read('[toy]\ncount = 3\n')
