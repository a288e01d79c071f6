"""HtmlReport writes every file (HTML, table CSV/JSON, figure PNG/SVG) through a
temporary file in the same folder and a rename: a report interrupted while writing
(disk full, Ctrl-C) leaves each earlier file whole, never half-written, and no
temporary file behind."""

import errno
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from demcal import _files as html_module  # noqa: E402  (where the report writes through)
from demcal.report.html import HtmlReport  # noqa: E402


def _figure():
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, 1])
    return fig


def _table(value: float = 1.5) -> pd.DataFrame:
    return pd.DataFrame({"x": [value, 2.0]}, index=pd.Index(["a", "b"], name="row"))


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def test_every_file_is_renamed_into_place_from_the_same_folder(tmp_path, monkeypatch):
    renamed = []
    real = os.replace

    def spy(src, dst):
        renamed.append((os.fspath(src), os.fspath(dst)))
        real(src, dst)

    monkeypatch.setattr(html_module.os, "replace", spy)
    rep = HtmlReport("t", tmp_path, figure_formats=("png", "svg"))
    rep.table(_table(), "numbers")
    fig = _figure()
    rep.figure(fig, "line")
    plt.close(fig)
    rep.write()
    written = _files(tmp_path)
    assert written == ["figures/line.png", "figures/line.svg", "report.html",
                       "tables/numbers.csv", "tables/numbers.json"]
    targets = sorted(os.path.relpath(dst, tmp_path).replace(os.sep, "/") for _, dst in renamed)
    assert targets == written
    for src, dst in renamed:
        assert os.path.dirname(src) == os.path.dirname(dst) and src != dst
    assert (tmp_path / "figures" / "line.svg").read_text().lstrip().startswith(("<?xml", "<svg"))
    assert (tmp_path / "figures" / "line.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_failed_write_keeps_the_old_file_whole_and_leaves_no_temporary(tmp_path, monkeypatch):
    HtmlReport("t", tmp_path).table(_table(1.5), "numbers")
    old_csv = (tmp_path / "tables" / "numbers.csv").read_text()
    old_json = (tmp_path / "tables" / "numbers.json").read_text()

    def disk_full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device", os.fspath(dst))

    monkeypatch.setattr(html_module.os, "replace", disk_full)
    with pytest.raises(OSError):
        HtmlReport("t", tmp_path).table(_table(9.25), "numbers")
    assert (tmp_path / "tables" / "numbers.csv").read_text() == old_csv
    assert (tmp_path / "tables" / "numbers.json").read_text() == old_json
    assert _files(tmp_path) == ["tables/numbers.csv", "tables/numbers.json"]


def test_a_new_report_replaces_the_files_of_the_old(tmp_path):
    HtmlReport("t", tmp_path).table(_table(1.5), "numbers")
    HtmlReport("t", tmp_path).table(_table(9.25), "numbers")
    assert "9.25" in (tmp_path / "tables" / "numbers.csv").read_text()
    assert json.loads((tmp_path / "tables" / "numbers.json").read_text())[0]["x"] == 9.25
    assert _files(tmp_path) == ["tables/numbers.csv", "tables/numbers.json"]


def test_written_files_are_readable_by_others(tmp_path):
    """The temporary file is made with the usual permissions (not mkstemp's 0600)."""
    rep = HtmlReport("t", tmp_path)
    rep.table(_table(), "numbers")
    path = rep.write()
    reference = tmp_path / "plain.txt"
    reference.write_text("x")
    for p in (path, tmp_path / "tables" / "numbers.csv"):
        assert p.stat().st_mode & 0o777 == reference.stat().st_mode & 0o777
