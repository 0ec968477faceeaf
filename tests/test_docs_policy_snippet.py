"""docs/policies.md shows the shipped ``experiments/policies/threshold.py`` as it is: its copy
lacked the file's ``weight`` range check, which the same page relies on (``--set
policies.threshold.params.weight=2`` writes nothing)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "policies.md"
SHIPPED = ROOT / "experiments" / "policies" / "threshold.py"
#: The sentence the copy follows on the page.
ANCHOR = "(`experiments/policies/threshold.py`, shipped):"
#: What the page leaves out of the file: its docstring, up to and with this line.
FUTURE = "from __future__ import annotations\n\n"


def _block_after(page: str, anchor: str, language: str) -> str:
    """The first ``language`` fenced block after ``anchor``."""
    found = re.search(rf"```{language}\n(.*?)```", page[page.index(anchor):], re.S)
    assert found, anchor
    return found.group(1)


def test_the_pages_threshold_policy_is_the_shipped_file() -> None:
    shipped = SHIPPED.read_text(encoding="utf-8")
    code = shipped[shipped.index(FUTURE) + len(FUTURE):]
    assert _block_after(PAGE.read_text(encoding="utf-8"), ANCHOR, "python") == code


def test_the_page_relies_on_the_check_it_shows() -> None:
    page = PAGE.read_text(encoding="utf-8")
    shown = _block_after(page, ANCHOR, "python")
    assert "--set policies.threshold.params.weight=2" in page
    assert "if not 0.0 <= weight <= 1.0:" in shown
