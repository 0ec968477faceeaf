"""docs/people.md's section on the population drawn from real people: each paragraph once, and the
real people's diagonal spans it quotes the ones the code compares with
(``nudgecli.sim.real_population.SIBLING_DIAGONAL_SPANS``)."""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

from nudgecli.sim.real_population import SIBLING_DIAGONAL_SPANS

PAGE = Path(__file__).resolve().parents[1] / "docs" / "people.md"


def paragraphs(text: str) -> list[str]:
    """The page's paragraphs and list items, white space collapsed (code blocks included)."""
    pieces = re.split(r"\n\s*\n|\n(?=- )", text)
    return [" ".join(piece.split()) for piece in pieces if piece.strip()]


def test_no_paragraph_is_written_twice() -> None:
    counts = Counter(p for p in paragraphs(PAGE.read_text(encoding="utf-8")) if len(p) > 80)
    assert [p[:80] for p, n in counts.items() if n > 1] == []


def test_the_real_spans_quoted_are_the_ones_the_coverage_is_measured_against() -> None:
    text = " ".join(PAGE.read_text(encoding="utf-8").split())
    spans = [f"{label} {low:.2f}-{high:.2f}" for label, (low, high) in SIBLING_DIAGONAL_SPANS.items()]
    assert f"diagonals span {', '.join(spans[:-1])} and {spans[-1]} (sibling study)" in text
    assert f"covers every real span given above ({', '.join(spans)})" in text
