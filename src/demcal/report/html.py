"""A small HTML report builder, rendered with jinja2.

A report is a list of blocks (headings, paragraphs, tables, figures, a table of
contents, the answer-first summary) rendered into one HTML page by the templates in
``demcal/report/templates`` (autoescaped: every text is escaped, only the templates
write markup). Each table is also written next to the page as ``tables/<name>.csv``
and ``tables/<name>.json``.

Figures are rendered once each. With ``link_figures`` the PNG goes to
``figures/<name>.png`` and the page refers to it (a light page; the folder is the
report); without, the page embeds that one PNG (base64), and ``figure_formats`` adds
print files (PNG at ``file_dpi``, SVG). Every file is written atomically
(:func:`write_atomic`): a report interrupted while writing leaves each earlier file whole.

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
import io
import json
import re
from datetime import datetime, timezone
from functools import lru_cache
from pathlib import Path

from demcal._files import write_atomic  # noqa: F401  (re-exported: report code writes through it)

import pandas as pd

from demcal.report.figures import figure_png_bytes
from demcal.rsm.tables import display_table, format_number  # noqa: F401  (one formatter: CLI and report)


@lru_cache(maxsize=1)
def environment():
    """The jinja2 environment of the report templates (package data), autoescaping on."""
    from jinja2 import Environment, PackageLoader, StrictUndefined

    return Environment(loader=PackageLoader("demcal.report", "templates"), autoescape=True,
                       undefined=StrictUndefined, trim_blocks=True, lstrip_blocks=True)


def _macro(name: str):
    return getattr(environment().get_template("blocks.html.j2").module, name)


def _figure_bytes(fig, fmt: str, dpi: int) -> bytes:
    if fmt not in ("png", "svg", "pdf"):
        from demcal.errors import ConfigError

        raise ConfigError(f"cannot write a figure as '.{fmt}'; use png or svg.")
    buf = io.BytesIO()
    fig.savefig(buf, format=fmt, dpi=dpi)
    return buf.getvalue()


def compact_png(png: bytes) -> bytes:
    """``png`` with at most 256 colours (a palette PNG): plots and photos at screen
    resolution look the same and take a third of the bytes. Returned unchanged when the
    palette one is not smaller."""
    from PIL import Image

    with Image.open(io.BytesIO(png)) as image:
        dpi = image.info.get("dpi")
        small = image.convert("RGB").quantize(colors=256)
        buf = io.BytesIO()
        small.save(buf, format="png", optimize=True, **({"dpi": dpi} if dpi else {}))
    out = buf.getvalue()
    return out if len(out) < len(png) else png


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
        Without ``link_figures``: files written for each figure besides the embedded PNG
        ("png", "svg"), at ``file_dpi``.
    dpi : int
        Resolution of the PNG the page shows (110 dpi keeps it small).
    file_dpi : int
        Resolution of the print PNG files of ``figure_formats`` (300 dpi).
    link_figures : bool
        Write each figure once, as ``figures/<name>.png`` at ``dpi`` with at most 256
        colours, and refer to it from the page instead of embedding it.
    """

    def __init__(self, title: str, out_dir, figure_formats=("png", "svg"), dpi: int = 110,
                 file_dpi: int = 300, link_figures: bool = False):
        self.title = title
        self.figure_formats = tuple(figure_formats)
        self.dpi = dpi
        self.file_dpi = file_dpi
        self.link_figures = link_figures
        self.out_dir = Path(out_dir)
        self.blocks: list[dict] = []
        self._names: set[str] = set()
        self._ids: set[str] = set()
        self.out_dir.mkdir(parents=True, exist_ok=True)

    def _unique(self, name: str) -> str:
        base = _slug(name)
        cand, i = base, 2
        while cand in self._names:
            cand, i = f"{base}_{i}", i + 1
        self._names.add(cand)
        return cand

    def anchor(self, text: str) -> str:
        """A unique ``id`` for a heading of ``text``."""
        base = "s-" + _slug(text).lower()[:60]
        cand, i = base, 2
        while cand in self._ids:
            cand, i = f"{base}-{i}", i + 1
        self._ids.add(cand)
        return cand

    # -- blocks -------------------------------------------------------------------
    def section(self, title: str, level: int = 2, anchor: str | None = None) -> str:
        """A heading (level 2 = section, 3 = subsection) with the id ``anchor`` (default
        one made from the title); returns the id."""
        level = min(max(int(level), 2), 4)
        if anchor is None:
            anchor = self.anchor(title)
        else:
            self._ids.add(anchor)
        self.blocks.append({"kind": "heading", "level": level, "text": str(title), "id": anchor})
        return anchor

    def paragraph(self, text: str, css_class: str | None = None) -> None:
        """A paragraph of plain text (escaped)."""
        self.blocks.append({"kind": "paragraph", "text": str(text), "cls": css_class})

    def note(self, text: str) -> None:
        """A highlighted remark."""
        self.paragraph(text, "note")

    def warning(self, text: str) -> None:
        """A red box: something that must be read before the results are trusted."""
        self.paragraph(text, "warning")

    def code(self, text: str) -> None:
        """Preformatted text (equations, command lines)."""
        self.blocks.append({"kind": "code", "text": str(text)})

    def bullets(self, items) -> None:
        self.blocks.append({"kind": "bullets", "items": [str(i) for i in items]})

    def contents(self) -> None:
        """The table of contents: the level-2 and level-3 headings that follow it."""
        self.blocks.append({"kind": "toc"})

    def block(self, kind: str, **fields) -> None:
        """A block a template of that ``kind`` lays out (``summary``, ``image_table``)."""
        self.blocks.append({"kind": kind, **fields})

    def table(self, df: pd.DataFrame, name: str, caption: str | None = None, digits: int = 4,
              index: bool = True, write_files: bool = True, headings: dict | None = None,
              values: dict | None = None) -> str:
        """A table from a DataFrame; also written as ``tables/<name>.csv`` and ``.json``.

        ``headings`` maps a column (or the index name) to the heading the page shows
        (a label with its unit), ``values`` a column to ``{value: text shown}`` (a
        response's label for its name); the files keep the names. Returns the unique
        name used for the files.
        """
        name = self._unique(name)
        if write_files:
            tdir = self.out_dir / "tables"
            tdir.mkdir(exist_ok=True)
            records = df.reset_index() if index else df
            text = json.dumps(json.loads(records.to_json(orient="records", double_precision=15)), indent=1)
            write_atomic(tdir / f"{name}.csv", df.to_csv(index=index))
            write_atomic(tdir / f"{name}.json", text)
        headings = headings or {}
        shown = display_table(df)  # Design-Expert headers and term labels; the files keep machine names
        columns = [headings.get(raw, col) for raw, col in zip(df.columns, shown.columns)]
        head = []
        if index:
            head.append((str(headings.get(df.index.name, shown.index.name) or ""), "t"))
        head += [(str(c), None) for c in columns]
        rows = []
        values = values or {}
        for idx, r in shown.iterrows():
            cells = [(str(idx), "t")] if index else []
            for raw, c, v in zip(df.columns, shown.columns, r):
                text = values[raw].get(v, v) if raw in values and isinstance(v, str) else v
                cells.append((format_number(text, digits, str(c)), "t" if isinstance(v, str) else None))
            rows.append(cells)
        self.blocks.append({"kind": "table", "caption": caption, "head": head, "rows": rows,
                            "link": name if write_files else None})
        return name

    def figure(self, fig, name: str, caption: str | None = None, write_files: bool = True) -> str:
        """A matplotlib figure, rendered once: linked as ``figures/<name>.png`` or embedded
        as base64 PNG (at ``dpi``; then also saved in ``figure_formats`` at ``file_dpi``)."""
        name, src = self._render(fig, name, self.figure_formats if write_files else ())
        self.blocks.append({"kind": "figure", "src": src, "alt": name, "caption": caption})
        return name

    def figure_html(self, fig, name: str, alt: str) -> str:
        """The ``<img>`` of a matplotlib figure placed as :meth:`figure` places it, for a
        caller that lays figures out itself (side by side in a table); its print file is a
        PNG only (at ``file_dpi``, when the report writes figure files): such figures are
        pictures -- a photo, thousands of spheres -- that a vector file would only make large."""
        name, src = self._render(fig, name, tuple(f for f in self.figure_formats if f == "png"))
        return _macro("img")(src, alt)

    def picture_html(self, data: bytes, name: str, alt: str, suffix: str = ".png") -> str:
        """The ``<img>`` of a picture file's bytes (a run's measurement picture, a photo):
        copied to ``figures/<name><suffix>`` with ``link_figures``, else embedded."""
        name = self._unique(name)
        suffix = suffix.lower()
        if self.link_figures:
            fdir = self.out_dir / "figures"
            fdir.mkdir(exist_ok=True)
            write_atomic(fdir / f"{name}{suffix}", data)
            src = f"figures/{name}{suffix}"
        else:
            mime = "image/jpeg" if suffix in (".jpg", ".jpeg") else "image/png"
            src = f"data:{mime};base64,{base64.b64encode(data).decode('ascii')}"
        return _macro("img")(src, alt)

    def _render(self, fig, name: str, formats) -> tuple[str, str]:
        """The figure's unique name and the ``src`` of its image."""
        name = self._unique(name)
        fdir = self.out_dir / "figures"
        if self.link_figures:
            fdir.mkdir(exist_ok=True)
            write_atomic(fdir / f"{name}.png", compact_png(figure_png_bytes(fig, self.dpi)))
            return name, f"figures/{name}.png"
        png = compact_png(figure_png_bytes(fig, self.dpi))
        if formats:
            fdir.mkdir(exist_ok=True)
            for fmt in formats:
                write_atomic(fdir / f"{name}.{fmt}", _figure_bytes(fig, fmt, self.file_dpi))
        return name, "data:image/png;base64," + base64.b64encode(png).decode("ascii")

    # -- output -------------------------------------------------------------------
    def to_html(self) -> str:
        stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        toc = []
        for k, block in enumerate(self.blocks):
            if block["kind"] == "toc":
                toc = [b for b in self.blocks[k + 1:] if b["kind"] == "heading" and b["level"] <= 3]
                break
        page = environment().get_template("report.html.j2")
        return page.render(title=self.title, stamp=stamp, blocks=self.blocks, toc=toc) + "\n"

    def write(self, filename: str = "report.html") -> Path:
        """Write the HTML file (atomically) and return its path."""
        return write_atomic(self.out_dir / filename, self.to_html())
