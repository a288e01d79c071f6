"""Writing output files whole or not at all, and never over what is not an output
(ground floor: any package may use it).

A full disk, a killed process or a read-only folder must leave the old file or none,
never a truncated one: every output (JSON, tables, HTML, PNG/SVG figures, card
snippets) goes through a temporary file in the same folder and :func:`os.replace`.
A target that is not a regular file (a folder, a device such as ``/dev/full``, a FIFO,
or a link to one) is refused before anything is written: a rename would replace the
node itself. :func:`check_output` adds the rule of the commands whose output path the
user names (``-o``, ``--plot``): never one of the campaign's inputs, and an existing
file only when demcal wrote one of its kind (or with ``--force``).
"""

from __future__ import annotations

import io
import os
import stat
import uuid
from pathlib import Path

from demcal.errors import ConfigError

#: Bytes that a file of each kind demcal writes carries near its start (the first
#: :data:`_SIGNATURE_BYTES`): how an existing file is known to be demcal's output.
SIGNATURES = {
    "design": (b"# demcal design",),  # demcal.doe.io.write_design_csv
    "card": (b'"card_version"', b"# demcal material card"),  # JSON, LIGGGHTS and EDEM cards
    "figure": (b"Matplotlib",),  # matplotlib's PNG "Software" text and SVG comment
}
_SIGNATURE_BYTES = 16384


def special_file(path) -> str | None:
    """What ``path`` is when it exists but is not a regular file (links followed):
    "a folder", "a device", "a FIFO", "a socket"; None for a regular or missing file."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    return "a socket" if stat.S_ISSOCK(mode) else "not a regular file"


def refuse_special(path, option: str = "") -> None:
    """One sentence if ``path`` (given as ``option``, when named) exists and is not a
    regular file (links followed)."""
    kind = special_file(path)
    if kind is not None:
        what = "is a folder" if kind == "a folder" else f"is {kind}, not a regular file"
        raise ConfigError(f"{option + ' ' if option else ''}{path} {what}; give a file path.")


def written_by_demcal(path, kind: str) -> bool:
    """Whether the regular file ``path`` starts like an output of ``kind`` (a key of
    :data:`SIGNATURES`) that demcal writes."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(_SIGNATURE_BYTES)
    except OSError:
        return False
    return any(mark in head for mark in SIGNATURES[kind])


def inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies below it (both taken as they are)."""
    return path == folder or folder in path.parents


def check_output(path, kind: str, *, inputs=(), force: bool = False, option: str = "-o",
                 of: str = "the campaign") -> Path:
    """Refuse the output path ``path`` of ``kind`` before any work is done.

    Refused, each with one sentence naming the path: a target that is not a regular
    file; one of ``inputs`` (files, or folders whose contents are all inputs), links
    followed on both sides, even with ``force``; an existing file that demcal did not
    write as ``kind`` (:data:`SIGNATURES`), unless ``force``. ``of`` names whose inputs
    they are in the sentence. Returns ``path``.
    """
    path = Path(path)
    refuse_special(path, option)
    target = path.resolve()
    for item in inputs:
        item = Path(item)
        if inside(target, item.resolve()):
            where = (f"lies inside {item}, an input of {of}" if target != item.resolve() else
                     f"is an input of {of}" + (f" ({item})" if os.path.normpath(item) != os.path.normpath(path) else ""))
            raise ConfigError(f"{option} {path} {where}; give another output path (an output never replaces an input).")
    if path.exists() and not force and not written_by_demcal(path, kind):
        raise ConfigError(f"{option} {path} exists and is not a {_KIND_NAMES[kind]} that demcal wrote; "
                          "give another path, move that file away, or pass --force to replace it.")
    return path


_KIND_NAMES = {"design": "design CSV", "card": "material card", "figure": "figure"}


def write_atomic(path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a
    rename, so ``path`` holds either its old or its new content, whole; the temporary
    file is removed if anything fails. Text is written as UTF-8. A file-system error
    names ``path``, never the temporary file; a ``path`` that exists and is not a
    regular file is refused (:func:`refuse_special`)."""
    path = Path(path)
    refuse_special(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        with open(tmp, "xb") as handle:
            handle.write(payload)
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            tmp.unlink()
        except OSError:
            pass
        if isinstance(exc, OSError) and exc.errno is not None:
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        raise
    return path


def save_figure(fig, path, fmt: str | None = None, dpi: int | None = None) -> Path:
    """Render a matplotlib figure to bytes, then write them with :func:`write_atomic`
    (``fmt`` from the suffix unless given)."""
    path = Path(path)
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt or (path.suffix.lower().lstrip(".") or "png"),
                **({"dpi": dpi} if dpi is not None else {}))
    return write_atomic(path, buf.getvalue())
