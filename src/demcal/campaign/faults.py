"""One sentence, with its fix, for a fault of the store or of the run folders.

:func:`store_error` turns an SQLite or file-system error (a damaged file, a folder
where the file should be, a read-only folder, a full disk, a lock held too long) into
one :class:`StoreError` sentence that names the file and what to do.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

from demcal.errors import DataError


class StoreError(DataError):
    """The store cannot be used: damaged, a folder, read-only, on a full disk, locked."""


#: How long a write waits for another runner's transaction [s].
BUSY_TIMEOUT_S = 60.0


def _fault(exc: BaseException) -> str:
    """What an SQLite or file-system error means for the user, in one word."""
    if isinstance(exc, OSError):
        code = exc.errno
        if code in (errno.ENOSPC, errno.EDQUOT):
            return "full"
        if code in (errno.EROFS, errno.EACCES, errno.EPERM):
            return "readonly"
        if code == errno.EISDIR:
            return "folder"
        return "io" if code == errno.EIO else "other"
    name = getattr(exc, "sqlite_errorname", None) or ""
    text = str(exc).lower()
    if name.startswith("SQLITE_FULL") or "disk is full" in text:
        return "full"
    if name.startswith(("SQLITE_CORRUPT", "SQLITE_NOTADB")) or "malformed" in text or "not a database" in text:
        return "damaged"
    if name.startswith(("SQLITE_READONLY", "SQLITE_PERM")) or "readonly" in text or "read-only" in text:
        return "readonly"
    if name.startswith(("SQLITE_BUSY", "SQLITE_LOCKED")) or "locked" in text:
        return "locked"
    if name.startswith("SQLITE_IOERR") or "disk i/o error" in text:
        return "io"
    if name.startswith("SQLITE_CANTOPEN") or "unable to open" in text:
        return "cantopen"
    return "other"


def _disk_nearly_full(folder: Path) -> bool:
    try:
        return shutil.disk_usage(folder).free < 1 << 20
    except OSError:
        return False


def _writable(path: Path) -> bool:
    """Whether this process may write ``path`` (or create it: its nearest existing folder)."""
    while not path.exists() and path.parent != path:
        path = path.parent
    return os.access(path, os.W_OK)


def _reason(exc: BaseException) -> str:
    text = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
    return " ".join(text.split()).rstrip(".") or type(exc).__name__


def store_error(exc: BaseException, path: str | Path, what: str = "the store") -> StoreError:
    """One sentence for an SQLite or file-system error of ``what`` at ``path``, with the fix.

    ``what`` names the thing (``"the store"``, ``"the run folders"``); ``path`` is the
    file or folder the user has to look at.
    """
    path = Path(path)
    blocker = next((p for p in path.parents if p.exists() and not p.is_dir()), None)
    if blocker is not None:  # the work folder (or a folder above it) is a file
        return StoreError(f"cannot write to {blocker}: {blocker} is a file, not a folder; choose another work "
                          f"folder ([campaign] workdir) or move the file away.")
    folder = path if path.is_dir() and what != "the store" else path.parent
    fault = _fault(exc)
    if fault in ("io", "other", "cantopen") and _disk_nearly_full(folder):
        fault = "full"
    if fault == "cantopen":
        fault = "folder" if path.is_dir() else "readonly" if not _writable(folder) else "other"
    if fault == "full":
        return StoreError(f"no space left on the disk that holds {what} {path}; free some space and "
                          f"run again (finished runs are kept).")
    if fault == "damaged":
        return StoreError(f"{what} {path} is damaged ({_reason(exc)}) and was left as it is; restore it "
                          f"from a backup, or move it away to start a new store (its runs are then "
                          f"simulated again).")
    if fault == "readonly":
        if not _writable(folder):
            while not folder.exists() and folder.parent != folder:
                folder = folder.parent
            where = f"the folder {folder} is read-only"
        elif path.exists() and not _writable(path):
            where = f"the file {path} is read-only"
        else:
            where = f"{folder} is read-only to this process"
        return StoreError(f"cannot write {what} {path}: {where}; make it writable or choose another "
                          f"work folder.")
    if fault == "folder":
        return StoreError(f"{path} is a folder, not a store file; move it away or choose another work folder.")
    if fault == "locked":
        return StoreError(f"{what} {path} stayed locked by another process for {BUSY_TIMEOUT_S:g} s; let the "
                          f"other demcal command finish (or stop it), then run again.")
    if fault == "io":
        return StoreError(f"cannot read or write {what} {path} (disk I/O error); check the disk and the "
                          f"folder, then run again.")
    return StoreError(f"cannot use {what} {path} ({_reason(exc)}); check the file and its folder, "
                      f"or choose another work folder.")
