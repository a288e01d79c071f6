"""Writing output files whole or not at all (ground floor: any package may use it).

A full disk, a killed process or a read-only folder must leave the old file or none,
never a truncated one: every output (JSON, tables, HTML, PNG/SVG figures, card
snippets) goes through a temporary file in the same folder and :func:`os.replace`.
"""

from __future__ import annotations

import io
import os
import uuid
from pathlib import Path


def write_atomic(path, data: str | bytes) -> Path:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a
    rename, so ``path`` holds either its old or its new content, whole; the temporary
    file is removed if anything fails. Text is written as UTF-8."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex[:8]}.tmp")
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    try:
        with open(tmp, "xb") as handle:
            handle.write(payload)
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except FileNotFoundError:
            pass
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
