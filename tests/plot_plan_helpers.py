"""A plan file of its own star rule, and the star rule ``nudge plot`` hands the drawing: for the
tests of plotting an analysis under the plan it was made with."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge

#: A plan file whose star rule differs from every preset's: a plot under the paper plan draws
#: other stars and letters.
LOOSE_PLAN = """name = "loose"
description = "stars at p < .9/.8/.7"

[stats]
kruskal_alpha = 0.9
star_thresholds = [0.9, 0.8, 0.7]
"""


def star_rule_plotted(monkeypatch: pytest.MonkeyPatch, *args: str | Path) -> Any:
    """``nudge plot ARGS``'s star rule, as given to the drawing (nothing drawn)."""
    given: dict[str, Any] = {}

    def plot_folder(*_: Any, **options: Any) -> list[Path]:
        given.update(options)
        return []

    monkeypatch.setattr("nudgecli.report.plotting.plot_folder", plot_folder)
    result = nudge("plot", *args)
    assert result.exit_code == 0, result.output
    return given["star_rule"]
