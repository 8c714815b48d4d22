"""The product says what is true now: no history in the code, the tests or the docs.

* No references to work sessions, training stages by number, issue numbers, a design
  file the repository does not have, or dates in README.md, docs/, dcdc/ (code and the
  built-in scene files, which ``dcdc scene copy`` hands to users), tests/, examples/ and
  configs/ (the models' training recipes).
  The history is in git and CHANGELOG.md (not scanned).
* Every docs section the code cites by title (``docs/sph.md, "Closed containers"``)
  exists: a heading of that file, or a paragraph that opens with that title in bold or
  italics, starts with it.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest
from helpers import doc_titles, norm_title

ROOT = Path(__file__).resolve().parents[1]

HISTORY = [
    (re.compile(r"\b[Ss]essions? \d"), "a work session"),
    # a training stage by number ("stage 3h"); a curriculum's stages are a feature, not history
    (re.compile(r"(?<!curriculum )\b[Ss]tages? \d+[a-z]?\b"), "a training stage"),
    (re.compile(r"\b[Ii]ssues? #?\d"), "an issue number"),
    (re.compile(r"\bDESIGN(?: §|\.md)"), "a design file the repository does not have"),
    (re.compile(r"\b20\d\d-\d\d-\d\d\b"), "a date"),
]

# Pages being rewritten as a manual: expected to fail until that lands; strict, so the
# test says so when a page becomes clean (then drop it from this list).
PENDING: set[str] = set()


def _files() -> list[str]:
    out = ["README.md"]
    out += sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))
    for d in ("dcdc", "tests", "examples", "configs"):
        out += sorted(str(p.relative_to(ROOT)) for p in (ROOT / d).rglob("*")
                      if p.suffix in (".py", ".toml", ".html", ".md") and p.is_file()
                      and "__pycache__" not in p.parts)
    return out


def _hits(rel: str) -> list[str]:
    hits = []
    for n, line in enumerate((ROOT / rel).read_text(encoding="utf-8").splitlines(), 1):
        for pat, what in HISTORY:
            m = pat.search(line)
            if m:
                hits.append(f"{rel}:{n}: {what}: {m.group(0)!r} in {line.strip()[:100]!r}")
    return hits


def _params():
    for rel in _files():
        if Path(rel).name == Path(__file__).name:
            continue  # this file names the patterns
        marks = [pytest.mark.xfail(strict=True, reason=f"{rel} is being rewritten without "
                                   "history; remove it from PENDING once clean")] \
            if rel in PENDING else []
        yield pytest.param(rel, marks=marks, id=rel)


@pytest.mark.parametrize("rel", list(_params()))
def test_no_history(rel):
    hits = _hits(rel)
    assert not hits, ("history in the product (say what is true now; the history is in git "
                      "and CHANGELOG.md):\n" + "\n".join(hits))


def test_the_scanner_finds_history():
    line = "fixed in session 4, shipped as stage 3h for issue 8 (DESIGN §2, 2026-12-04)"
    found = {what for pat, what in HISTORY if pat.search(line)}
    assert len(found) == len(HISTORY)
    assert not any(pat.search("curriculum stage 0 selects no trajectory") for pat, _ in HISTORY)


# ---------------------------------------------------------------- doc citations by title
CITATION = re.compile(r'docs/(\w+)\.md((?:[,;:]?[ \t]*"[^"\n]*(?:\n[ \t]*#?[ \t]*[^"\n]*)?")+)')


def citations():
    """(file:line, doc, title) of every ``docs/X.md, "Title"`` in dcdc/."""
    for f in sorted((ROOT / "dcdc").rglob("*")):
        if f.suffix not in (".py", ".toml", ".html") or "__pycache__" in f.parts:
            continue
        text = f.read_text(encoding="utf-8")
        for m in CITATION.finditer(text):
            where = f"{f.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}"
            for t in re.findall(r'"([^"]*)"', m.group(2)):
                yield where, m.group(1), re.sub(r"\s*\n\s*#?\s*", " ", t)


def test_doc_citations_name_sections_that_exist():
    found = list(citations())
    assert len(found) > 20  # the scanner still sees the code's citations
    titles: dict[str, list[str] | None] = {}
    bad = []
    for where, doc, title in found:
        md = ROOT / "docs" / f"{doc}.md"
        if doc not in titles:
            titles[doc] = doc_titles(md) if md.exists() else None
        if titles[doc] is None:
            bad.append(f"{where}: docs/{doc}.md does not exist")
        elif not any(t.startswith(norm_title(title)) for t in titles[doc]):
            bad.append(f'{where}: docs/{doc}.md has no section "{title}"')
    assert not bad, "citations of doc sections that do not exist:\n" + "\n".join(bad)


# ---------------------------------------------------------------- the front page and links
def test_readme_is_a_front_page():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines; details belong in docs/"


LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)\s]*)?\)")


@pytest.mark.parametrize("rel", ["README.md", "CHANGELOG.md", "benchmarks/README.md"]
                         + sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md")))
def test_relative_links_resolve(rel):
    page = ROOT / rel
    bad = [t for t in LINK.findall(page.read_text(encoding="utf-8"))
           if "://" not in t and not t.startswith("mailto:") and not (page.parent / t).exists()]
    assert not bad, f"{rel} links to files that do not exist: {bad}"
