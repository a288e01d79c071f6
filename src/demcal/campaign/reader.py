"""One checker for declared TOML tables, and the line of each key.

A table is declared as a frozen dataclass (:mod:`demcal.campaign.schema`): each field is
one key, its type the key's TOML type, its default the value an absent key takes (none:
the key is required) and its metadata (:func:`key`) its range or choices, the sentence a
refused value gets and what the key means. :class:`Reader` walks a declared dataclass over
a TOML table (unknown keys with "did you mean", types, ranges, choices, paths inside the
campaign's folder) and gives each mistake as one :class:`~demcal.errors.ConfigError`
sentence naming the file and the line of the key (:func:`key_lines`).

Types: ``str`` a non-empty string (stripped), :data:`Text` free text (any value, kept as
its text), ``float`` a finite number, ``int`` a whole number, ``bool`` true or false,
``Path`` a file name relative to the campaign file's folder and inside it, :data:`Names`
a list of strings, :data:`Table` a table of its own keys, a dataclass a sub-table, a
tuple of dataclasses an array of tables, ``object`` any value; ``X | None`` may be left
out.
"""

from __future__ import annotations

import difflib
import functools
import math
import os
import re
import tomllib
import types
import typing
from dataclasses import MISSING, field, fields, is_dataclass
from pathlib import Path
from typing import Any, Mapping, NewType

from demcal._checks import MAX_TOML_BYTES, read_limited
from demcal.errors import ConfigError

Text = NewType("Text", str)  #: free text: any value, kept as its text (labels, units)
Names = tuple[str, ...]  #: a TOML list of strings
Table = dict[str, Any]  #: a TOML table whose keys are checked by the loader (or by ``keys``)
NO_RULES: Mapping[str, Any] = types.MappingProxyType({})  #: a key without rules


def key(default: Any = MISSING, *, doc: str, **rules: Any) -> Any:
    """One key of a table: ``default`` (none: required) and ``doc``, and any of these rules:

    ``minimum`` / ``above`` / ``below`` (a number's range: at least / more than / less
    than), ``choices`` (the values allowed), ``pattern`` (a regular expression a string
    must match), ``check`` (a function of the value giving what is wrong with it, or None;
    of each item for a list), ``says`` (the sentence a value outside the rules gets,
    formatted with ``key``, ``value``, ``raw`` and ``table``, the name of the key's
    table), ``off`` (the key may be ``false``, meaning None), ``fallback`` (an absent key
    takes that other key's value), ``what`` (how a path is named), ``file`` (a path must
    name an existing file; the sentence's fix when it is not one), ``keys`` / ``unknown``
    (a :data:`Table`'s allowed keys; the sentence for another), ``entries`` (the declared
    table each entry of a :data:`Table` is), ``source`` (a field that is no key of the
    table: where the loader takes its value from).
    """
    if isinstance(default, dict):  # a table: a fresh empty one each time
        return field(default_factory=dict, metadata={"doc": doc, **rules})
    return field(default=default, metadata={"doc": doc, **rules})


@functools.cache
def declared(cls: type) -> tuple[tuple[Any, Any], ...]:
    """``(field, type)`` of each key of the declared table ``cls`` (``X | None`` as ``X``),
    in the order of the declaration; keys of another table (``source``) left out."""
    hints = typing.get_type_hints(cls)
    out = []
    for f in fields(cls):
        kind = hints[f.name]
        if isinstance(kind, types.UnionType) or typing.get_origin(kind) is typing.Union:
            kind = next(a for a in typing.get_args(kind) if a is not type(None))
        if "source" not in f.metadata:
            out.append((f, kind))
    return tuple(out)


def _item(kind: Any) -> Any:
    """The declared table of an array of tables' entries, or None."""
    if typing.get_origin(kind) is tuple and is_dataclass(typing.get_args(kind)[0]):
        return typing.get_args(kind)[0]
    return None


def allowed_keys(cls: type, name: str = "") -> dict[str, tuple[str, ...]]:
    """The keys of each table, from the declarations: ``{"": top-level tables, "campaign":
    (...), "factors[]": (...), "conditions[].targets.*": (...), ...}``."""
    out = {name: tuple(f.name for f, _ in declared(cls))}
    for f, kind in declared(cls):
        inner = f"{name}.{f.name}" if name else f.name
        if is_dataclass(kind):
            out.update(allowed_keys(kind, inner))
        elif _item(kind) is not None:
            out.update(allowed_keys(_item(kind), inner + "[]"))
        elif f.metadata.get("entries") is not None:
            out.update(allowed_keys(f.metadata["entries"], inner + ".*"))
    return out


def read_toml_text(path: Path, what: str) -> str:
    """The UTF-8 text of the TOML file ``path`` (at most :data:`demcal._checks.MAX_TOML_BYTES`),
    refused by name if it is not UTF-8 or starts with a byte-order mark; ``what`` names the
    file in the size limit's sentence."""
    data = read_limited(path, MAX_TOML_BYTES, what)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path.name} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start}); "
                          "save it as UTF-8.") from None
    check_bom(text, path.name)
    return text


def check_bom(text: str, name: str) -> None:
    if text.startswith("\ufeff"):
        raise ConfigError(f"{name} starts with a UTF-8 byte-order mark (BOM), which TOML does not allow; "
                          "save the file as UTF-8 without BOM.")


class Reader:
    """The TOML text of the campaign file ``path``, parsed, with the line of each key:
    reads declared tables out of it and words each mistake as one sentence naming the
    file and the line. Paths are taken relative to the file's folder and must lie inside
    it unless ``allow_outside``."""

    def __init__(self, text: str, path: Path, allow_outside: bool = False):
        self.path = path
        self.allow_outside = allow_outside
        check_bom(text, path.name)
        try:
            self.data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            message = str(exc)
            match = re.search(r"\(at line (\d+), column \d+\)", message)
            where = f" line {match.group(1)}" if match else ""
            reason = re.sub(r"\s*\(at line \d+, column \d+\)", "", message)
            raise ConfigError(f"{path.name}{where}: not valid TOML ({reason}).") from None
        self.lines = key_lines(text)

    def error(self, where: tuple, message: str) -> ConfigError:
        """``message`` as the sentence of a mistake at ``where`` (a path of keys and
        array indices): the file's name, the line of ``where`` (or of its nearest table)."""
        line = self.line(where)
        prefix = f"{self.path.name} line {line}" if line else self.path.name
        message = message.rstrip()
        if not message.endswith((".", "?", "!")):
            message += "."
        return ConfigError(f"{prefix}: {message}")

    def line(self, where: tuple) -> int | None:
        where = tuple(where)
        while where:
            if where in self.lines:
                return self.lines[where]
            where = where[:-1]
        return None

    def inside(self, path: Path, written: str, where: tuple, what: str) -> Path:
        """``path`` (already joined to the campaign's folder), refused unless it lies in
        that folder or ``allow_outside`` was given; links are followed."""
        if self.allow_outside:
            return path
        folder = self.path.parent.resolve()
        try:
            resolved = path.resolve()
        except (OSError, RuntimeError):  # a loop of links
            resolved = Path(os.path.abspath(path))
        if resolved == folder or folder in resolved.parents:
            return path
        raise self.error(where, f"{what} '{written}' lies outside the campaign file's folder {folder}; "
                                "move it into that folder, or pass --allow-outside to use it where it is")

    def check_keys(self, data: Mapping, where: tuple, allowed: tuple[str, ...], unknown: str | None = None) -> None:
        for name in data:
            if name not in allowed:
                near = difflib.get_close_matches(name, allowed, n=1, cutoff=0.6)
                hint = f"did you mean '{near[0]}'?" if near else f"valid keys are: {', '.join(allowed)}"
                shown = _table_name(where) or "the top level"
                raise self.error(where + (name,), (unknown or "unknown key '{key}' in {table}; {hint}").format(
                    key=name, table=shown, hint=hint))

    def check_file(self, cls: type) -> None:
        """The file's top level (declared by ``cls``): known tables only, the required ones there."""
        self.check_keys(self.data, (), allowed_keys(cls)[""])
        for f, kind in declared(cls):
            if f.default is MISSING and f.name not in self.data:
                form = f"[[{f.name}]]" if _item(kind) is not None else f"[{f.name}]"
                raise self.error((), f"missing {form}; a campaign needs {form}")

    def table(self, data: Mapping, name: str, where: tuple, required: bool = False) -> dict:
        """The sub-table ``name`` of ``data`` (at ``where``); {} if absent and not required."""
        value = data.get(name)
        if value is None:
            if required:
                raise self.error(where, f"missing table [{_dotted(where + (name,))}]; add it")
            return {}
        if not isinstance(value, dict):
            raise self.error(where + (name,), f"'{_dotted(where + (name,))}' must be a table")
        return value

    def section(self, cls: type, name: str, required: bool = False) -> Any:
        """The top-level table ``[name]`` read as its declaration ``cls`` (:meth:`read`)."""
        return self.read(cls, self.table(self.data, name, (), required), (name,))

    def tables(self, name: str) -> list[dict]:
        """The array of tables ``[[name]]`` of the top level."""
        value = self.data.get(name, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error((name,), f"'{name}' must be written as [[{name}]] tables")
        return value

    def read(self, cls: type, data: Mapping, where: tuple, defaults: Mapping[str, Any] = NO_RULES) -> Any:
        """The declared table ``cls`` read from the TOML table ``data`` at ``where``: each
        key checked against its declaration, an absent one given its default (or the
        value ``defaults`` names for it; also for a field the table does not hold)."""
        self.check_keys(data, where, allowed_keys(cls)[""])
        values = dict(defaults)
        for f, kind in declared(cls):
            if f.name in data:
                values[f.name] = self.value(kind, data, f.name, where, f.metadata)
            elif f.name in values:
                continue
            elif "fallback" in f.metadata:
                values[f.name] = values[f.metadata["fallback"]]
            elif f.default is MISSING and f.default_factory is MISSING:
                raise self.error(where, f"missing key '{f.name}' in {_table_name(where)}; add it")
        return cls(**values)  # an absent key not named here takes its declared default

    def value(self, kind: Any, data: Mapping, name: str, where: tuple, rules: Mapping = NO_RULES) -> Any:
        """The value of key ``name`` of ``data``, checked as the type ``kind`` under ``rules``
        (:func:`key`)."""
        raw, at, says = data[name], where + (name,), rules.get("says")
        if rules.get("off") and raw is False:
            return None
        value = self._typed(kind, raw, name, at, rules)
        words = {"key": name, "value": value, "raw": raw, "table": where[-1] if where else "",
                 "minimum": rules.get("minimum")}
        if _outside(value, rules):
            raise self.error(at, (says or "'{key}' must be at least {minimum}, got {value}").format(**words))
        if "pattern" in rules and not re.fullmatch(rules["pattern"], value):
            raise self.error(at, says.format(**words))
        choices = rules.get("choices")
        if choices is not None and value not in choices:
            near = difflib.get_close_matches(value, choices, n=1, cutoff=0.5)
            hint = f"did you mean '{near[0]}'?" if near else f"choose one of: {', '.join(choices)}"
            raise self.error(at, f"'{name}' = '{value}' is not known; {hint}")
        if "check" in rules:
            for item in value if kind == Names else (value,):
                problem = rules["check"](item)
                if problem:
                    raise self.error(at, problem)
        return self.path_of(value, at, rules) if kind is Path else value

    def _typed(self, kind: Any, raw: Any, name: str, at: tuple, rules: Mapping) -> Any:
        """``raw`` as the TOML type ``kind``; its sentence if it is not one."""
        if kind in (str, Path):
            if not isinstance(raw, str) or not raw.strip():
                raise self.error(at, f"'{name}' must be a non-empty string")
            return raw.strip()
        if kind is float:
            if isinstance(raw, bool) or not isinstance(raw, (int, float)) or not math.isfinite(raw):
                raise self.error(at, f"'{name}' must be a finite number, got {raw!r}")
            return float(raw)
        if kind is int and (isinstance(raw, bool) or not isinstance(raw, int)):
            raise self.error(at, f"'{name}' must be a whole number, got {raw!r}")
        if kind is bool and not isinstance(raw, bool):
            raise self.error(at, f"'{name}' must be true or false, got {raw!r}")
        if kind == Names:
            if not isinstance(raw, list) or not all(isinstance(p, str) for p in raw):
                raise self.error(at, rules["says"].format(key=name))
            return tuple(raw)
        if kind == Table:
            if not isinstance(raw, dict):
                raise self.error(at, f"'{_dotted(at)}' must be a table")
            return self._entries(raw, at, rules) if "keys" in rules else dict(raw)
        return str(raw) if kind is Text else raw

    def _entries(self, raw: dict, at: tuple, rules: Mapping) -> dict[str, str]:
        """A table of non-empty strings under the keys ``rules["keys"]``."""
        for name, text in raw.items():
            self.check_keys({name: text}, at, rules["keys"], rules["unknown"])
            if not isinstance(text, str) or not text.strip():
                raise self.error(at + (name,), rules["says"].format(key=name))
        return {name: text.strip() for name, text in raw.items()}

    def path_of(self, written: str, at: tuple, rules: Mapping) -> Path:
        """The file ``written`` in the campaign's folder (and inside it); with the rule
        ``file``, refused unless it is an existing file."""
        what = rules.get("what", at[-1])
        path = self.inside(self.path.parent / written, written, at, what)
        if "file" in rules and not path.is_file():
            raise self.error(at, f"{what} '{written}' does not exist next to the campaign file"
                             if not path.exists() else f"{what} '{written}' is not a file; {rules['file']}")
        return path


def _outside(value: Any, rules: Mapping) -> bool:
    """Whether a number lies outside its declared range (``minimum``, ``above``, ``below``)."""
    minimum, above, below = rules.get("minimum"), rules.get("above"), rules.get("below")
    return ((minimum is not None and value < minimum) or (above is not None and value <= above)
            or (below is not None and value >= below))


def _dotted(where: tuple) -> str:
    return ".".join(str(p) for p in where if not isinstance(p, int))


def _table_name(where: tuple) -> str:
    if not where:
        return ""
    if len(where) >= 2 and isinstance(where[1], int):
        head = f"[[{where[0]}]] #{where[1] + 1}"
        rest = _dotted(where[2:])
        return f"{head} {rest}".strip() if rest else head
    return f"[{_dotted(where)}]"


# --------------------------------------------------------------- key -> line map

_HEADER = re.compile(r"^\s*(\[\[?)\s*(.+?)\s*(\]\]?)\s*(?:#.*)?$")
_KEY_PART = r'(?:[A-Za-z0-9_-]+|"(?:[^"\\]|\\.)*"|\'[^\']*\')'
_KEY = re.compile(rf"^\s*({_KEY_PART}(?:\s*\.\s*{_KEY_PART})*)\s*=")
_INLINE_KEY = re.compile(rf"[{{,]\s*({_KEY_PART})\s*=")


def _split_key(text: str) -> tuple[str, ...]:
    parts = re.findall(_KEY_PART, text)
    return tuple(p[1:-1] if p[:1] in "\"'" else p for p in parts)


def key_lines(text: str) -> dict[tuple, int]:
    """Map each table and key path (array indices included) to its 1-based line.

    ``tomllib`` keeps no positions, so this scans the text once: table headers,
    ``key = value`` lines and the keys of one-line inline tables. Lines inside
    multi-line arrays and strings are skipped. Good enough to point a user at the
    line of a mistake; the parse itself is ``tomllib``'s.
    """
    lines: dict[tuple, int] = {}
    counts: dict[tuple, int] = {}
    current: tuple = ()
    depth = 0  # open brackets of a multi-line array
    in_string = False
    for number, line in enumerate(text.splitlines(), start=1):
        if in_string:
            if '"""' in line or "'''" in line:
                in_string = False
            continue
        if depth > 0:
            depth += _bracket_balance(line)
            continue
        header = _HEADER.match(line)
        if header and not _KEY.match(line):
            parts = _split_key(header.group(2))
            path = _with_indices(parts, counts)
            if header.group(1) == "[[":
                counts[parts] = counts.get(parts, -1) + 1
                path = _with_indices(parts, counts)
            current = path
            lines.setdefault(path, number)
            continue
        found = _KEY.match(line)
        if not found:
            continue
        path = current + _split_key(found.group(1))
        lines.setdefault(path, number)
        value = line[found.end():]
        for inner in _INLINE_KEY.finditer(value):
            lines.setdefault(path + _split_key(inner.group(1)), number)
        if value.count('"""') == 1 or value.count("'''") == 1:
            in_string = True
        depth = max(0, _bracket_balance(value))
    return lines


def _with_indices(parts: tuple[str, ...], counts: dict[tuple, int]) -> tuple:
    """Insert the current index after each prefix that names an array of tables."""
    path: list = []
    for i in range(len(parts)):
        path.append(parts[i])
        prefix = parts[: i + 1]
        if prefix in counts:
            path.append(counts[prefix])
    return tuple(path)


def _bracket_balance(text: str) -> int:
    text = re.sub(r'"(?:[^"\\]|\\.)*"|\'[^\']*\'', "", text)
    text = text.split("#", 1)[0]
    return text.count("[") - text.count("]")
