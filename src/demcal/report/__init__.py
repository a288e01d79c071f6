"""Reports: figures (:mod:`demcal.report.figures`), a self-contained HTML builder
(:mod:`demcal.report.html`) and the re-analysis of the reference paper
(:func:`demcal.report.paper.write_paper_report`)."""

from demcal.report.html import HtmlReport, format_number

__all__ = ["HtmlReport", "format_number", "write_paper_report"]


def write_paper_report(out_dir):
    """Re-analyse the reference paper's Tables 4 and 8 into ``out_dir/report.html``."""
    from demcal.report.paper import write_paper_report as _write

    return _write(out_dir)
