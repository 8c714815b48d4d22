"""benchmarks/results/README.md says how every result file was made.

* Every file in benchmarks/results/ is covered by a row of the index (its exact name or a
  pattern: ``*``, ``?``, ``[…]`` as in fnmatch, ``{a,b}`` for either), so a new result
  file needs a row with the command that writes it.
* Every row's names match a file (no rows for files that are gone).
* Every doc section a row cites (``models.md, "Generalisation suite"``) exists, and the
  page's relative links resolve.
"""
from __future__ import annotations

import fnmatch
import re
from pathlib import Path

from helpers import doc_titles, norm_title

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
INDEX = RESULTS / "README.md"


def _expand(pattern: str) -> list[str]:
    """``a{b,c}d{,e}`` -> the names it stands for (braces need not nest)."""
    m = re.search(r"\{([^{}]*)\}", pattern)
    if not m:
        return [pattern]
    return [x for alt in m.group(1).split(",")
            for x in _expand(pattern[:m.start()] + alt + pattern[m.end():])]


def _rows() -> list[tuple[list[str], str]]:
    """(file patterns, cited-by cell) of every table row whose first cell names files."""
    rows = []
    for line in INDEX.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
        if len(cells) == 3 and cells[0].startswith("`"):
            rows.append((re.findall(r"`([^`]+)`", cells[0]), cells[2]))
    return rows


def _files() -> list[str]:
    return sorted(p.name for p in RESULTS.iterdir() if p.is_file() and p.name != "README.md")


def test_expand():
    assert _expand("a_{2d,3d}{,_q}.json") == ["a_2d.json", "a_2d_q.json", "a_3d.json", "a_3d_q.json"]
    assert _expand("x*.csv") == ["x*.csv"]


def test_every_result_file_is_indexed():
    patterns = [e for names, _ in _rows() for p in names for e in _expand(p)]
    assert len(patterns) > 40  # the parser still sees the table rows
    missing = [f for f in _files() if not any(fnmatch.fnmatchcase(f, p) for p in patterns)]
    assert not missing, ("benchmarks/results/ files without a row (file, command, cited by) in "
                         "benchmarks/results/README.md:\n" + "\n".join(missing))


def test_every_row_names_existing_files():
    files = _files()
    stale = [p for names, _ in _rows() for p in names
             if not any(fnmatch.fnmatchcase(f, e) for e in _expand(p) for f in files)]
    assert not stale, f"benchmarks/results/README.md lists files that do not exist: {stale}"


def test_cited_sections_exist():
    bad, n = [], 0
    for _, cited in _rows():
        for doc, titles in re.findall(r'(\w+)\.md, ((?:"[^"]+"(?:, )?)+)', cited):
            md = ROOT / "docs" / f"{doc}.md"
            if not md.exists():
                bad.append(f"docs/{doc}.md does not exist")
                continue
            have = doc_titles(md)
            for t in re.findall(r'"([^"]+)"', titles):
                n += 1
                if not any(h.startswith(norm_title(t)) for h in have):
                    bad.append(f'docs/{doc}.md has no section "{t}"')
    assert n > 30  # the parser still sees the citations
    assert not bad, "benchmarks/results/README.md cites sections that do not exist:\n" + "\n".join(bad)


def test_links_resolve():
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)\s]*)?\)", INDEX.read_text(encoding="utf-8"))
    bad = [t for t in links if "://" not in t and not (INDEX.parent / t).exists()]
    assert not bad, f"benchmarks/results/README.md links to files that do not exist: {bad}"
