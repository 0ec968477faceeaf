"""``nudge simulate``'s per-condition summary lists the conditions in the toolkit's one order (the
paper's first, then the experiment's ``study.conditions``), as ``nudge analyze`` does, not in the
first participant's counterbalanced order of blocks."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from nudgecli import api
from nudgecli.api.run import Run
from nudgecli.runs.study import success_by_condition

#: The baselines experiment's conditions, in its study.conditions' order.
BASELINES = ["disambiguation", "control", "teleoperation", "blending", "mode-switch", "hindsight",
             "turn-taking"]


def _trials(order: list[str]) -> pd.DataFrame:
    """Two trials per condition, the conditions' blocks in ``order``."""
    rows = [{"condition": c, "success": i % 2 == 0, "timed_out": False, "duration_s": 10.0 + i}
            for c in order for i in range(2)]
    return pd.DataFrame(rows)


def test_the_summary_follows_the_experiment_order_not_the_first_blocks() -> None:
    blocks = ["turn-taking", "control", "hindsight", "disambiguation", "blending", "mode-switch",
              "teleoperation"]
    table = success_by_condition(_trials(blocks), BASELINES)
    assert list(table.index) == BASELINES
    assert table.index.name == "condition"
    assert table["trials"].tolist() == [2] * 7


def test_conditions_the_experiment_does_not_list_come_last_by_name() -> None:
    table = success_by_condition(_trials(["zeta", "control", "alpha", "disambiguation"]))
    assert list(table.index) == ["disambiguation", "control", "alpha", "zeta"]


def test_a_runs_summary_and_report_use_its_experiments_order(tmp_path: Path) -> None:
    config = api.experiment_config("baselines")
    assert list(config.study.conditions) == BASELINES
    blocks = list(reversed(BASELINES))
    run = Run(tmp_path, config, trials=_trials(blocks), participant_count=1)
    assert list(run.success().index) == BASELINES
    lines = run.report().splitlines()[3:]
    assert [line.split()[0] for line in lines] == BASELINES
