"""docs/batches.md says what sensitivity.csv's ``conf`` is: SALib's half-width (1.96 times the
bootstrap standard deviation of the index), not an interval; NaN for Morris sigma and mu."""

from __future__ import annotations

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "batches.md"


def _sensitivity_entry() -> str:
    text = " ".join(DOC.read_text().split())
    found = re.search(r"for Sobol and Morris designs, `sensitivity.csv`:(.*?)- `figures/sweep.png`", text)
    assert found is not None
    return found.group(1)


def test_the_docs_say_what_conf_is() -> None:
    entry = _sensitivity_entry()
    assert "`conf`" in entry and "half-width" in entry and "1.96" in entry and "bootstrap" in entry
    assert "sigma and mu" in entry.split("`conf`", 1)[1]
    assert "with 95 % intervals" not in entry
