"""A small self-contained HTML report builder.

A report is a list of blocks (headings, paragraphs, tables, figures) written to one HTML
file with the figures embedded as base64 PNG, so the file can be mailed or archived on
its own. Each table is also written next to it as ``tables/<name>.csv`` and
``tables/<name>.json`` and each figure as ``figures/<name>.png`` and ``.svg``.
Every file is written atomically (:func:`write_atomic`): a report interrupted
while writing leaves each earlier file whole.

Example
-------
>>> rep = HtmlReport("Calibration", "out")          # doctest: +SKIP
>>> rep.section("ANOVA")
>>> rep.table(model.display_anova(), "anova_repose", caption="Table 5 re-analysed")
>>> rep.figure(predicted_vs_actual_figure(model), "pred_vs_actual", caption="Fig. 6")
>>> rep.write()                                      # -> out/report.html
"""

from __future__ import annotations

import base64
import html
import io
import json
import re
from datetime import datetime, timezone
from pathlib import Path

from demcal._files import write_atomic  # noqa: F401  (re-exported: report code writes through it)

import pandas as pd

from demcal.report.figures import figure_png_bytes
from demcal.rsm.tables import display_table, format_number  # noqa: F401  (one formatter: CLI and report)

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;
margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #446;padding-bottom:.2em}h2{margin-top:1.8em;color:#334}
h3{color:#445}table{border-collapse:collapse;margin:.6em 0 1.2em;font-size:.86em}
th,td{border:1px solid #ccd;padding:.25em .55em;text-align:right}
th{background:#eef}td.t,th.t{text-align:left}caption{caption-side:top;text-align:left;
font-weight:600;padding:.3em 0}figure{margin:1em 0}figcaption{font-size:.9em;color:#444}
img{max-width:100%}.note{background:#fff8e0;border-left:4px solid #e0b000;padding:.4em .8em}
.warning{background:#fdecea;border:1px solid #d93025;border-left:6px solid #d93025;color:#611a15;
padding:.4em .8em}.warning::before{content:"Warning: ";font-weight:700}
code,pre{background:#f4f4f8;padding:.1em .3em}pre{padding:.6em;overflow-x:auto;white-space:pre-wrap}
.small{font-size:.85em;color:#555}
"""


def _figure_bytes(fig, fmt: str, dpi: int) -> bytes:
    if fmt not in ("png", "svg", "pdf"):
        from demcal.errors import ConfigError

        raise ConfigError(f"cannot write a figure as '.{fmt}'; use png or svg.")
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=dpi)
    return buf.getvalue()


def _slug(name: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_-]+", "_", name).strip("_")
    return s or "item"


class HtmlReport:
    """Build an HTML report block by block and write it with its tables and figures.

    Parameters
    ----------
    title : str
        Report title (``<h1>``).
    out_dir : path
        Folder of the report; created if needed. Tables go to ``out_dir/tables``,
        figures to ``out_dir/figures``.
    figure_formats : tuple of str
        File formats written for each figure besides the embedded PNG ("png", "svg").
    dpi : int
        Resolution of the PNG embedded in the HTML (110 dpi keeps the file small).
    file_dpi : int
        Resolution of the PNG files in ``figures/`` (300 dpi, for print).
    """

    def __init__(self, title: str, out_dir, figure_formats=("png", "svg"), dpi: int = 110,
                 file_dpi: int = 300):
        self.title = title
        self.figure_formats = tuple(figure_formats)
        self.dpi = dpi
        self.file_dpi = file_dpi
        self.out_dir = Path(out_dir)
        self.blocks: list[str] = []
        self._names: set[str] = set()
        self.out_dir.mkdir(parents=True, exist_ok=True)

    def _unique(self, name: str) -> str:
        base = _slug(name)
        cand, i = base, 2
        while cand in self._names:
            cand, i = f"{base}_{i}", i + 1
        self._names.add(cand)
        return cand

    # -- blocks -------------------------------------------------------------------
    def section(self, title: str, level: int = 2) -> None:
        """A heading (level 2 = section, 3 = subsection)."""
        level = min(max(int(level), 2), 4)
        self.blocks.append(f"<h{level}>{html.escape(title)}</h{level}>")

    def paragraph(self, text: str, css_class: str | None = None) -> None:
        """A paragraph of plain text (escaped)."""
        cls = f' class="{css_class}"' if css_class else ""
        self.blocks.append(f"<p{cls}>{html.escape(text)}</p>")

    def note(self, text: str) -> None:
        """A highlighted remark."""
        self.paragraph(text, "note")

    def warning(self, text: str) -> None:
        """A red box: something that must be read before the results are trusted."""
        self.paragraph(text, "warning")

    def code(self, text: str) -> None:
        """Preformatted text (equations, command lines)."""
        self.blocks.append(f"<pre>{html.escape(text)}</pre>")

    def bullets(self, items) -> None:
        self.blocks.append("<ul>" + "".join(f"<li>{html.escape(str(i))}</li>" for i in items) + "</ul>")

    def raw(self, fragment: str) -> None:
        """Trusted HTML, inserted as is."""
        self.blocks.append(fragment)

    def table(self, df: pd.DataFrame, name: str, caption: str | None = None, digits: int = 4,
              index: bool = True, write_files: bool = True) -> str:
        """A table from a DataFrame; also written as ``tables/<name>.csv`` and ``.json``.

        Returns the unique name used for the files.
        """
        name = self._unique(name)
        if write_files:
            tdir = self.out_dir / "tables"
            tdir.mkdir(exist_ok=True)
            records = df.reset_index() if index else df
            text = json.dumps(json.loads(records.to_json(orient="records", double_precision=15)), indent=1)
            write_atomic(tdir / f"{name}.csv", df.to_csv(index=index))
            write_atomic(tdir / f"{name}.json", text)
        df = display_table(df)  # Design-Expert headers and term labels; the files keep machine names
        head = []
        if index:
            head.append(f'<th class="t">{html.escape(str(df.index.name or ""))}</th>')
        for c in df.columns:
            head.append(f"<th>{html.escape(str(c))}</th>")
        rows = []
        for idx, r in df.iterrows():
            cells = [f'<td class="t">{html.escape(str(idx))}</td>'] if index else []
            for c, v in zip(df.columns, r):
                txt = format_number(v, digits, str(c))
                cls = ' class="t"' if isinstance(v, str) else ""
                cells.append(f"<td{cls}>{html.escape(txt)}</td>")
            rows.append("<tr>" + "".join(cells) + "</tr>")
        cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
        link = (f'<div class="small">data: <a href="tables/{name}.csv">{name}.csv</a>, '
                f'<a href="tables/{name}.json">{name}.json</a></div>') if write_files else ""
        self.blocks.append(f"<table>{cap}<thead><tr>{''.join(head)}</tr></thead>"
                           f"<tbody>{''.join(rows)}</tbody></table>{link}")
        return name

    def figure(self, fig, name: str, caption: str | None = None, write_files: bool = True) -> str:
        """A matplotlib figure embedded as base64 PNG (at ``dpi``); also saved as PNG (at
        ``file_dpi``) and SVG files."""
        name, img = self._embed(fig, name, None, self.figure_formats if write_files else ())
        cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
        self.blocks.append(f"<figure>{img}{cap}</figure>")
        return name

    def figure_html(self, fig, name: str, alt: str) -> str:
        """The ``<img>`` of a matplotlib figure embedded as :meth:`figure` does, for a caller
        that lays figures out itself (side by side in a table); saved as a PNG file only (at
        ``file_dpi``, when the report writes figure files): such figures are pictures -- a
        photo, thousands of spheres -- that a vector file would only make large."""
        return self._embed(fig, name, alt, tuple(f for f in self.figure_formats if f == "png"))[1]

    def _embed(self, fig, name: str, alt: str | None, formats) -> tuple[str, str]:
        """The figure's unique name and its ``<img>`` (base64 PNG at ``dpi``; ``alt``
        default that name); also ``figures/<name>.<format>`` at ``file_dpi`` for each of
        ``formats``."""
        name = self._unique(name)
        png = figure_png_bytes(fig, self.dpi)
        if formats:
            fdir = self.out_dir / "figures"
            fdir.mkdir(exist_ok=True)
            for fmt in formats:
                write_atomic(fdir / f"{name}.{fmt}", _figure_bytes(fig, fmt, self.file_dpi))
        data = base64.b64encode(png).decode("ascii")
        return name, f'<img alt="{html.escape(alt or name)}" src="data:image/png;base64,{data}">'

    # -- output -------------------------------------------------------------------
    def to_html(self) -> str:
        stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        body = "\n".join(self.blocks)
        return (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
                f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
                f"<h1>{html.escape(self.title)}</h1><p class=\"small\">generated by demcal, {stamp}</p>\n"
                f"{body}\n</body></html>\n")

    def write(self, filename: str = "report.html") -> Path:
        """Write the HTML file (atomically) and return its path."""
        return write_atomic(self.out_dir / filename, self.to_html())
