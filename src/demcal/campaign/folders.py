"""A run's artifact folder: made under a temporary name, moved into place whole.

Artifacts go to ``runs/.<name>.tmp-*`` (:func:`temp_dir`, :func:`temp_name`) and are
renamed into ``runs/<name>`` (:func:`publish_dir`; the store does it inside the
transaction that records the run, through :class:`_Swap`, which can put everything
back); JSON files are written through a temporary file and a rename
(:func:`write_json_atomic`).
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import uuid
from pathlib import Path
from typing import Any


def temp_dir(runs_dir: Path, name: str) -> Path:
    """A fresh temporary folder for a run's artifacts, next to its final place."""
    path = runs_dir / temp_name(name)
    path.mkdir(parents=True)
    return path


def temp_name(name: str) -> str:
    """The name of a new temporary folder for run folder ``name`` (``.<name>.tmp-<hex>``)."""
    return f".{name}.tmp-{uuid.uuid4().hex[:8]}"


class _Swap:
    """Folder ``tmp`` moved into ``final``'s place; the folder it replaces is kept aside
    until :meth:`keep`, so that :meth:`undo` can put everything back."""

    def __init__(self, tmp: Path, final: Path):
        self.tmp, self.final, self.old = Path(tmp), Path(final), None
        if self.final.exists():
            self.old = self.final.with_name(f".{self.final.name}.old-{uuid.uuid4().hex[:8]}")
            os.replace(self.final, self.old)
        try:
            os.replace(self.tmp, self.final)
        except BaseException:
            if self.old is not None:
                os.replace(self.old, self.final)
            raise

    def undo(self) -> None:
        with contextlib.suppress(OSError):  # a later runner reruns the run and publishes again
            os.replace(self.final, self.tmp)
            if self.old is not None:
                os.replace(self.old, self.final)

    def keep(self) -> None:
        if self.old is not None:
            shutil.rmtree(self.old, ignore_errors=True)


def publish_dir(tmp: Path, final: Path) -> None:
    """Move a completed artifact folder into place (replacing an older one)."""
    _Swap(tmp, final).keep()


def write_json_atomic(path: Path, data: Any) -> None:
    """Write JSON to ``path`` through a temporary file and a rename."""
    from demcal._files import write_atomic

    # a full disk: neither a partial file nor a 0-byte temporary stays
    write_atomic(path, json.dumps(data, indent=2, sort_keys=True, default=_json_default))


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")
