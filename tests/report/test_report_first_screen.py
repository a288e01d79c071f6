"""The report answers first (issue 40, item 2): its first screen -- 1400 x 900 px in
headless Chromium -- holds each condition's calibrated values with their solution-set
ranges, the verification verdict, the simulations spent, the warnings and the material
card; the table of contents follows, the design, ANOVA and diagnostics after it.

The campaign is the one of test_report_honesty (design results written straight into
the store, three conditions, one of them out of reach, the tiny profile's warning).
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from demcal.rounding import measured, ranged
from test_report_honesty import built  # noqa: F401  (the module's fixture, built again here)

BROWSER = shutil.which("chromium") or shutil.which("chromium-browser")


def _summary(page: str) -> str:
    start = page.index('<section id="summary">')
    return page[start:page.index("</section>", start)]


def _heading(page: str, text: str) -> int:
    match = re.search(r"<h[2-4][^>]*>" + re.escape(text), page)
    assert match, text
    return match.start()


def test_the_summary_precedes_the_contents_and_the_design(built):  # noqa: F811
    campaign, cal, report, page = built
    summary = page.index('<section id="summary">')
    contents = page.index('<nav class="toc" id="contents">')
    assert summary < contents
    for heading in ("Lab data and targets", "Calibrated parameters", "Factors and levels", "Design and results",
                    "Response model of Repose angle [°]", "ANOVA for the full quadratic model",
                    "Diagnostics and figures"):
        assert contents < _heading(page, heading), heading
    assert _heading(page, "Calibrated parameters") < _heading(page, "Design and results")
    toc = page[contents:page.index("</nav>", contents)]
    assert 'href="#s-design_and_results"' in toc and 'href="#s-calibrated_parameters"' in toc


def test_the_summary_holds_every_conditions_values_ranges_and_verdict(built):  # noqa: F811
    campaign, cal, report, page = built
    summary = html.unescape(_summary(page))
    for f in campaign.factors:
        assert f"<th class=\"t\">{f.label}</th>" in summary
    for result in cal.conditions:
        row = summary[summary.index(f"<b>{result.condition.name}</b>"):]
        row = row[:row.index("</tr>")]
        for f in campaign.factors:  # to the digits the solution set's width supports (demcal.rounding)
            value, low, high = ranged(result.chosen[f.parameter], *result.factor_ranges[f.parameter])
            assert f"<b>{value}</b>" in row and f"set {low} to {high}" in row
        for v in result.verdicts:  # the lab's mean to its sd's precision, with the unit
            assert f"lab {measured(v.target, v.lab_sd, '°')}" in row
        assert result.loop.status in row  # nothing verified: the loop's word for it
    assert "Verification: Repose angle [°]" in summary
    assert "29 design runs at tiny, 29 in all" in summary
    (warning,) = [w for w in cal.warnings if "smoke test" in w]
    assert f'<p class="warning">{warning}</p>' in summary
    assert f"demcal export {campaign.path} --format json" in summary
    assert 'href="#s-material"' in summary and 'id="s-material"' in page


def test_headings_and_columns_carry_labels_and_units(built):  # noqa: F811
    campaign, cal, report, page = built
    text = html.unescape(page)
    assert "<th>target [°]</th>" in text and "<th>lab sd [°]</th>" in text
    assert '<td class="t">Repose angle [°]</td>' in text  # the response named by its label
    assert ">Response model of Repose angle [°]</h3>" in text
    assert "Response model of repose_angle_deg" not in text


@pytest.fixture(scope="module")
def linked(built, tmp_path_factory):  # noqa: F811
    """The same report with its figures as files (``demcal report``'s default)."""
    from demcal.report.campaign_report import write_report

    campaign, cal, _, _ = built
    return write_report(campaign, tmp_path_factory.mktemp("linked") / "report", [cal])


def test_the_page_is_light_and_refers_to_its_figures(built, linked):  # noqa: F811
    page = linked.read_text()
    sources = re.findall(r'<img alt="[^"]*" src="([^"]+)"', page)
    assert sources and all(s.startswith("figures/") and (linked.parent / s).is_file() for s in sources)
    assert "base64," not in page
    figures = sorted(p.name for p in (linked.parent / "figures").iterdir())
    assert len(figures) == len(sources)  # one file each: no print copies, no SVG
    size = linked.stat().st_size + sum(p.stat().st_size for p in (linked.parent / "figures").iterdir())
    embedded = built[2].stat().st_size
    assert size < 1_000_000 and embedded < 1_000_000, (size, embedded)


#: Appended to a copy of the page: writes where the summary's parts lie into the DOM,
#: which --dump-dom returns.
_PROBE = """<script>
window.addEventListener("load", () => {
  const box = e => { const r = e.getBoundingClientRect(); return [r.top + scrollY, r.bottom + scrollY]; };
  const all = s => Array.from(document.querySelectorAll(s)).map(box);
  const out = {height: innerHeight, width: innerWidth, rows: all("#summary tbody tr"),
               warnings: all("#summary p.warning"), facts: all("#summary p.small"),
               summary: box(document.querySelector("#summary")), toc: box(document.querySelector("nav.toc"))};
  const pre = document.createElement("pre"); pre.id = "probe"; pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


@pytest.mark.skipif(BROWSER is None, reason="headless Chromium is not installed (Debian: apt-get install -y chromium)")
def test_the_first_screen_in_headless_chromium(linked, tmp_path):
    flags = [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
             "--disable-background-networking", "--hide-scrollbars", "--window-size=1400,900"]
    shot = tmp_path / "first-screen.png"
    subprocess.run(flags + [f"--screenshot={shot}", linked.as_uri()], capture_output=True, timeout=120)
    from PIL import Image

    with Image.open(shot) as image:
        assert image.size == (1400, 900)
        assert np.asarray(image.convert("L"), dtype=float).std() > 10  # text and tables, not a blank page
    probe = linked.parent / "probe.html"
    probe.write_text(linked.read_text().replace("</body>", _PROBE + "</body>"))
    dom = subprocess.run(flags + ["--virtual-time-budget=5000", "--dump-dom", probe.as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    found = json.loads(html.unescape(re.search(r'<pre id="probe">(.*?)</pre>', dom, re.S).group(1)))
    assert found["width"] == 1400  # the layout's width (--dump-dom's viewport is shorter: window chrome)
    assert len(found["rows"]) == 3 and found["warnings"]
    parts = found["rows"] + found["warnings"] + found["facts"]
    assert max(bottom for _, bottom in parts) <= 900, found  # every condition, warning and the card link
    assert found["summary"][1] <= found["toc"][0]
