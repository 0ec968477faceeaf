"""A batch says what its plan's ``[filters]`` left out of its replications, as ``nudge analyze``
says it of a run: one ``Note:`` per metric summed over replications, through the batch's log."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from nudgecli.report.plan_filters import replications_left_out_line
from nudgecli.report.plans import AnalysisPlan
from nudgecli.report.replication import analyse_replication
from nudgecli.runs.batch_kinds import replicate
from nudgecli.runs.batch_tasks import merge_analysis_chunks

PAPER_PLAN = Path(__file__).parents[1] / "analysis" / "paper.toml"


def _plan(tmp_path: Path, filters: str) -> Path:
    """The paper plan with ``filters`` as its ``[filters]`` table."""
    text = PAPER_PLAN.read_text(encoding="utf-8").replace("[filters]", f"[filters]\n{filters}", 1)
    path = tmp_path / "filtering.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_batch_says_once_what_its_plans_filters_left_out(tmp_path: Path) -> None:
    lines: list[str] = []
    plan = _plan(tmp_path, "human_turns = 0")  # every smoke trial has a turn: each value is left out
    replicate("smoke", 2, tmp_path / "batch", seed=5, participants=2, plan=str(plan), log=lines.append)
    said = [line for line in lines if "[filters]" in line]
    assert len(said) == 1, lines
    assert said[0] == (f"Note: plan {plan}'s [filters] left out human_turns values (above 0) in 2 of 2 "
                       "replications (32 of 32 values); each trial stays in its other metrics")


def test_a_replications_document_names_what_the_filters_removed_and_only_then() -> None:
    table = pd.DataFrame({"participant": np.repeat(np.arange(6), 2), "condition": np.tile(["a", "b"], 6),
                          "value": np.arange(12, dtype=float)})
    removing = AnalysisPlan(conditions=("a", "b"), bootstrap={"resamples": 100}, filters={"value": 8.5})
    document = analyse_replication(table, removing, ["value"])
    assert document["filters"] == [{"metric": "value", "removed": 3, "values": 12, "maximum": 8.5}]
    keeping = AnalysisPlan(conditions=("a", "b"), bootstrap={"resamples": 100}, filters={"value": 100})
    unfiltered = analyse_replication(table, keeping, ["value"])
    assert set(unfiltered) == {"conditions", "metrics"}  # the shipped tables' documents, as before
    assert replications_left_out_line([unfiltered, unfiltered], "paper") is None


def test_merged_chunks_keep_what_each_chunks_filters_removed() -> None:
    removed = {"metric": "mode_switches", "removed": 3, "values": 8, "maximum": 10.0}
    first = {"conditions": ["a", "b"], "metrics": [{"metric": "mode_switches"}], "filters": [removed]}
    second = {"conditions": ["a", "b"], "metrics": [{"metric": "human_turns"}]}
    assert merge_analysis_chunks([first, second])["filters"] == [removed]
    assert "filters" not in merge_analysis_chunks([second, second])
