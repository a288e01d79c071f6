"""What a campaign reads and keeps, so that no output replaces it.

:func:`campaign_inputs` lists every file and folder a campaign depends on: its file, its
lab file and photos, the published table it re-analyses, the campaigns it takes values
from with their calibrations, and its work folder's store, runs and calibration. An
output path the user names (``demcal export -o``) is checked against it with
:func:`demcal._files.check_output` before anything is read or written.
"""

from __future__ import annotations

import glob
from pathlib import Path

#: What the work folder keeps that outputs must never replace (the store with SQLite's
#: side files, the runs, the calibration the cards are made from).
WORKDIR_INPUTS = ("store.sqlite", "store.sqlite-wal", "store.sqlite-shm", "store.sqlite-journal", "runs",
                  "calibration.json")


def campaign_inputs(campaign) -> list[Path]:
    """The files and folders ``campaign`` reads or keeps (see the module docstring)."""
    base = campaign.path.parent
    paths = [campaign.path, *(Path(campaign.workdir) / name for name in WORKDIR_INPUTS)]
    for extra in (campaign.lab_file, campaign.reference_table):
        if extra is not None:
            paths.append(Path(extra))
    for condition in campaign.conditions:
        if condition.photo is not None:
            paths.append(Path(condition.photo))
        photos = getattr(condition.sample, "repose_photos", None)
        for pattern in photos.patterns if photos is not None else ():  # excluded photos are the lab's too
            paths += [Path(p) for p in glob.glob(str(base / pattern))]
        if condition.upstream is not None:
            paths += [Path(condition.upstream.path), Path(condition.upstream.workdir) / "calibration.json"]
    return paths
