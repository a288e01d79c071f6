"""The reference pages under docs/ and the README: each page short enough to read
(at most 400 lines), written about the project rather than about who did what when
(no session or issue narration; a study's history lives in its folder's README under
benchmarks/studies/), and every link and page mention pointing at something that exists:
relative links ``[text](path#anchor)``, ``docs/...md`` mentions, and the section a mention
quotes (``docs/performance.md, "Portable bits"``), also from the sources, tests, scripts,
benchmarks and examples."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted((ROOT / "docs").glob("**/*.md")) + [ROOT / "README.md"]
MAX_LINES = 400

#: narration of the project's own making; each pattern is case-insensitive
NARRATION = [
    re.compile(r"\bsessions?\b", re.I),                                    # "the eighth session"
    re.compile(r"\bissues?\s+#?\d+", re.I),                                # "issue 42"
    re.compile(r"\b(?:this|last|next|previous)\s+(?:week|session|round)\b", re.I),
    re.compile(r"\bwe\s+(?:tried|measured|ran|found|changed|did)\b", re.I),
    # "round 3" of the work; not "paired by round 0.966" nor "rounds 2-4" of a timing
    re.compile(r"\bround\s+\d+\b(?![.,]?\d)", re.I),
]
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
MENTION = re.compile(r"(?<![\w/.-])(docs/[\w./-]+?\.md)\b")
#: a page mention followed by the section it quotes: docs/x.md, "Section" / docs/x.md "Section"
SECTION = re.compile(r"(?<![\w/.-])(docs/[\w./-]+?\.md)(?:\]\([^)\s]*\))?`?,?\s+[\"“]([^\"”]+)[\"”]")


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _sections(page: Path) -> list[str]:
    """The headings and bold paragraph leads of a page, whitespace collapsed."""
    text = page.read_text(encoding="utf-8")
    heads = re.findall(r"^#{1,6}\s+(.*)$", text, re.M)
    bold = re.findall(r"\*\*(.+?)\*\*", re.sub(r"\s+", " ", text))
    return [" ".join(h.replace("`", "").split()) for h in heads + bold]


def _flatten(text: str) -> str:
    """Text with comment markers and line breaks folded, so a mention may wrap."""
    return re.sub(r"\s*\n\s*(?:#\s*|\*\s+)?", " ", text)


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_page_is_short(page):
    if page.name == "README.md" and page.parent == ROOT:
        return
    lines = len(page.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{_rel(page)} has {lines} lines (at most {MAX_LINES}): split it"


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_page_tells_no_history_of_its_making(page):
    hits = []
    for number, line in enumerate(page.read_text(encoding="utf-8").splitlines(), 1):
        for pattern in NARRATION:
            for m in pattern.finditer(line):
                hits.append(f"{_rel(page)}:{number}: {m.group(0)!r} in {line.strip()[:90]!r}")
    assert not hits, "\n".join(hits)


@pytest.mark.parametrize("text, narrated", [
    ("measured in the twentieth session", True),
    ("(issue 42)", True),
    ("Issue 16's gap", True),
    ("no issue at all", False),
    ("as last session showed", True),
    ("we tried a limiter", True),
    ("in round 3 of the work", True),
    ("paired by round 0.966 ± 0.023", False),
    ("wall in rounds 2-4", False),
    ("are rounded up to a multiple of k", False),
    ("the first round, with each tree's first compile", False),
])
def test_the_narration_patterns(text, narrated):
    assert any(p.search(text) for p in NARRATION) == narrated


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_relative_links_point_at_files(page):
    text = page.read_text(encoding="utf-8")
    text = re.sub(r"^```.*?^```", "", text, flags=re.M | re.S)   # not inside code blocks
    text = re.sub(r"`[^`\n]*`", "", text)                        # nor code spans
    bad = []
    for target in LINK.findall(text):
        if re.match(r"[a-z]+:", target):
            continue                                                 # http:, mailto:
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in {_slug(h) for h in re.findall(
                r"^#{1,6}\s+(.*)$", dest.read_text(encoding="utf-8"), re.M)}:
            bad.append(f"{target}: no such heading in {_rel(dest)}")
    assert not bad, f"{_rel(page)}: " + "; ".join(bad)


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_page_mentions_point_at_pages(page):
    missing = sorted({m for m in MENTION.findall(page.read_text(encoding="utf-8"))
                      if not (ROOT / m).is_file()})
    assert not missing, f"{_rel(page)} mentions missing pages: {missing}"


def _quoting_files():
    for folder in ("src", "tests", "scripts", "benchmarks", "examples", "docs"):
        for path in sorted((ROOT / folder).glob("**/*")):
            if (path.suffix in (".py", ".md", ".toml") and path.is_file()
                    and ".egg-info" not in path.as_posix() and path != Path(__file__).resolve()):
                yield path
    yield ROOT / "README.md"


def test_quoted_sections_exist():
    """``docs/x.md, "Section"`` names a heading (or a bold paragraph lead) of that page, in
    the docs, the README and the code's comments alike."""
    bad = []
    for path in _quoting_files():
        text = path.read_text(encoding="utf-8")
        if "benchmarks/studies/" in path.as_posix():
            text = text.split("\n## History", 1)[0]    # history quotes the pages as they stood
        for page, quoted in SECTION.findall(_flatten(text)):
            target = ROOT / page
            if not target.is_file():
                bad.append(f"{_rel(path)}: {page} does not exist")
                continue
            want = " ".join(quoted.replace("`", "").split())
            if not any(want in section for section in _sections(target)):
                bad.append(f"{_rel(path)}: {page} has no section {quoted!r}")
    assert not bad, "\n".join(bad)
