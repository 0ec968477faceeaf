"""Every relative link in the README and in docs/ points at a file that exists, and every
``#anchor`` at a heading of its page (GitHub's slug rule), so the manual never sends a reader
to nothing."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")


def heading_slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to '-'."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """The anchors of a page's headings (outside code fences)."""
    found, fence = set(), False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            fence = not fence
        elif not fence and re.match(r"#{1,6} ", line):
            found.add(heading_slug(line.lstrip("#")))
    return found


def relative_links(page: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(encoding="utf-8"), flags=re.S)
    return [t for t in LINK.findall(text) if not re.match(r"[a-z]+:", t)]


def test_the_slug_rule_matches_githubs() -> None:
    # hand-checked against anchors GitHub renders for these headings
    assert heading_slug(" A person in the loop: `nudge study`") == "a-person-in-the-loop-nudge-study"
    assert heading_slug("Scale (`nudge bench --only scale`)") == "scale-nudge-bench---only-scale"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_relative_link_resolves(page: Path) -> None:
    broken = []
    for target in relative_links(page):
        path_part, _, anchor = target.partition("#")
        dest = (page.parent / path_part).resolve() if path_part else page
        if not dest.exists() or (anchor and dest.suffix == ".md" and anchor not in anchors(dest)):
            broken.append(target)
    assert broken == [], f"{page.name}: links to nothing: {broken}"


def test_the_readme_is_a_short_guide_that_points_to_every_page() -> None:
    # issue 22: the README is a user guide (at most 20 KB) with a table of contents; the rest is docs/
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.encode()) <= 20_000
    assert "## Contents" in text
    linked = {Path(t.partition("#")[0]).name for t in relative_links(ROOT / "README.md")
              if t.startswith("docs/")}
    assert {p.name for p in (ROOT / "docs").glob("*.md")} <= linked


@pytest.mark.parametrize("page", sorted((ROOT / "docs").glob("*.md")), ids=lambda p: p.name)
def test_every_docs_page_opens_with_the_question_it_answers(page: Path) -> None:
    lines = page.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("# ") and lines[1] == ""
    assert lines[2].startswith("*") and lines[2].endswith("?*"), f"{page.name}: no opening question"
