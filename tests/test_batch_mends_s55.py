"""Mends of the batch commands' output (replicate, power, sweep): their JSON keeps every value as it
is, summaries name the effect size the tested replications computed, figures say what they cannot
draw, and a finished batch's progress line says it is done."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from click.testing import CliRunner

from nudgecli.cli import main


class _FinishedBatch:
    """What a batch command prints from (:class:`nudgecli.api.batches.Batch`), without running one."""

    def __init__(self, summary: pd.DataFrame, path: Path) -> None:
        self.summary = summary
        self.path = path
        self.computed = 0

    def text(self) -> str:
        return self.summary.to_string(index=False)


@pytest.mark.parametrize("command", ["replicate", "power", "sweep"])
def test_json_output_keeps_a_small_p_value_exactly(command: str, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    # pandas' to_json rounded to 10 decimals: the shipped baselines' median_conover_p of 3e-14 printed 0.0
    import nudgecli.api

    summary = pd.DataFrame([{"metric": "completion_time", "median_conover_p": 3.2e-12,
                             "effect_size": 0.123456789012345678, "difference_low": float("nan")}])

    def finished(**kwargs: Any) -> _FinishedBatch:
        return _FinishedBatch(summary, kwargs["out"])

    monkeypatch.setattr(nudgecli.api, command, finished)
    arguments = {"replicate": ["smoke", "-R", "2"], "power": ["smoke", "--participants", "2,3", "-R", "2"],
                 "sweep": ["sweep.toml"]}[command]
    result = CliRunner().invoke(main, [command, *arguments, "--out", str(tmp_path / "b"), "--format", "json"])
    assert result.exit_code == 0, result.output
    document = json.loads(result.stdout)
    assert document == [{"metric": "completion_time", "median_conover_p": 3.2e-12,
                         "effect_size": 0.123456789012345678, "difference_low": None}]
