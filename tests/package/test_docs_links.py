"""The README stays short, and every link of the README, of ``docs/`` and of ``benchmarks/README.md`` resolves.

The README is read in two minutes (issue #34): at most :data:`README_MAX_LINES` lines, none over
:data:`LINE_MAX_CHARS` characters, and at most :data:`FIRST_SECTIONS_MAX_NUMBERS` numbers before its second
section ends (what it is and how to run it; results live in ``docs/results.md``). Every relative link resolves:
the file exists, and so does the heading an anchor names (GitHub's heading anchors). ``docs/README.md`` indexes
every page of ``docs/``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *ROOT.glob("benchmarks/README.md")]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")
NUMBER = re.compile(r"\d+(?:[.,]\d+)*")
README_MAX_LINES = 200
LINE_MAX_CHARS = 200
FIRST_SECTIONS_MAX_NUMBERS = 10


def anchor(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation but ``-`` and ``_`` dropped, spaces to ``-``."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """The anchors of every heading of a Markdown file (outside code blocks), duplicates numbered."""
    seen: dict[str, int] = {}
    out = set()
    fenced = False
    for line in path.read_text().splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        match = None if fenced else HEADING.match(line)
        if match:
            base = anchor(match.group(1))
            count = seen.get(base, 0)
            seen[base] = count + 1
            out.add(base if count == 0 else f"{base}-{count}")
    return out


def links(path: Path) -> list[str]:
    """The link targets of a Markdown file, outside code blocks and inline code."""
    out, fenced = [], False
    for line in path.read_text().splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            line = re.sub(r"`[^`]*`", "", line)
            out += [a or b for a, b in LINK.findall(line)]
    return out


def first_sections(text: str, sections: int = 2) -> str:
    """The text of a Markdown document up to the end of its ``sections``-th ``## `` section (the title and the
    lines before the first ``## `` heading count as the first), code blocks included.

    :param text: the document's text.
    :param sections: how many sections to keep.
    """
    kept, seen, fenced = [], 1, False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        if not fenced and line.startswith("## "):
            seen += 1
            if seen > sections:
                break
        kept.append(line)
    return "\n".join(kept)


def test_anchor_follows_githubs_rule():
    assert anchor("Evaluating SPARK") == "evaluating-spark"
    assert anchor("`ours`: SPARK, stage by stage") == "ours-spark-stage-by-stage"
    assert anchor("SPARK import (`spark-bench import spark --runs SPARK/output`)") == \
        "spark-import-spark-bench-import-spark---runs-sparkoutput"


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_link_resolves(document):
    broken = []
    for target in links(document):
        if re.match(r"^[a-z]+://|^mailto:", target):
            continue
        file_part, _, fragment = target.partition("#")
        path = (document.parent / file_part).resolve() if file_part else document
        if not path.exists():
            broken.append(f"{target}: no such file")
        elif fragment and path.suffix == ".md" and fragment not in anchors(path):
            broken.append(f"{target}: no heading #{fragment} in {path.name}")
    assert not broken, f"{document.relative_to(ROOT)}: " + "; ".join(broken)


def test_the_first_sections_counter_sees_numbers_and_stops_at_the_third_section():
    text = "# t\nA 3D tool.\n## Set-up (Python 3.11)\n```\n## 7 in code\n```\n## Next\n4 5 6\n"
    assert NUMBER.findall(first_sections(text)) == ["3", "3.11", "7"]


def test_the_readme_is_short():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"
    long = [f"line {k}: {len(line)} characters" for k, line in enumerate(lines, 1) if len(line) > LINE_MAX_CHARS]
    assert not long, "README.md lines over the limit: " + "; ".join(long)


def test_the_readme_opens_with_few_numbers():
    numbers = NUMBER.findall(first_sections((ROOT / "README.md").read_text()))
    assert len(numbers) <= FIRST_SECTIONS_MAX_NUMBERS, f"README's first two sections hold {numbers}"


def test_the_docs_index_names_every_page():
    index = ROOT / "docs" / "README.md"
    linked = {(index.parent / target.partition("#")[0]).resolve() for target in links(index)}
    missing = [p.name for p in DOCUMENTS if p.parent == index.parent and p != index and p.resolve() not in linked]
    assert not missing, f"docs/README.md does not link {missing}"
    assert "docs/README.md" in links(ROOT / "README.md"), "README.md must link the docs index"
