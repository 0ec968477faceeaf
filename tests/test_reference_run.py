"""The reference reproduction can never go stale: `nudge run paper --seed 2022` reproduces the
committed results/paper/metrics.csv and stats.json exactly."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

REFERENCE = Path(__file__).resolve().parents[1] / "results" / "paper"


@pytest.mark.skipif(not (REFERENCE / "stats.json").is_file(), reason="results/paper is not in this checkout")
def test_nudge_run_paper_reproduces_the_reference(tmp_path: Path) -> None:
    out = tmp_path / "paper"
    runner = CliRunner()
    # `nudge run paper --seed 2022` is simulate + analyze + plot; the tables come from the first two
    result = runner.invoke(main, ["simulate", "paper", "--seed", "2022", "--workers", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["analyze", str(out)])
    assert result.exit_code == 0, result.output
    assert (out / "metrics.csv").read_text() == (REFERENCE / "metrics.csv").read_text(), (
        "results/paper/metrics.csv is stale: regenerate it with "
        "`nudge run paper --seed 2022 --out results/paper --force`")
    assert json.loads((out / "stats.json").read_text()) == json.loads((REFERENCE / "stats.json").read_text())
