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


def _replication_row(replication: int, tested: bool) -> dict[str, Any]:
    """A :func:`~nudgecli.report.replication.replication_rows` row of ``completion_time``,
    ``disambiguation - control``: tested (rank_biserial computed) or not (every value NaN, named none)."""
    nan = float("nan")
    return {"point": 0, "replication": replication, "seed": replication, "participants": 3,
            "metric": "completion_time", "a": "disambiguation", "b": "control",
            "median_a": 20.0 if tested else nan, "median_b": 21.0 if tested else nan,
            "difference": -1.0 if tested else nan, "ci_low": -2.0 if tested else nan,
            "ci_high": 0.5 if tested else nan, "kruskal_p": 0.3 if tested else nan,
            "conover_p": 0.3 if tested else nan, "participant_p": nan,
            "effect_size_name": "rank_biserial" if tested else "none", "effect_size": -0.3 if tested else nan,
            "trial_significant": False, "trial_direction": -1 if tested else 0,
            "participant_significant": False, "participant_direction": 0}


def _some_tested_rows() -> pd.DataFrame:
    """Four replications of which only the second tested the pair (the others' runs ran out of time)."""
    return pd.DataFrame([_replication_row(r, r == 1) for r in range(4)])


def test_the_summary_names_the_effect_size_the_tested_replications_computed() -> None:
    from nudgecli.report.replication import summarise

    summary = summarise(_some_tested_rows())
    assert summary["tested"].tolist() == [1]
    assert summary["effect_size_name"].tolist() == ["rank_biserial"]  # was the first replication's: none
    untested = summarise(pd.DataFrame([_replication_row(r, False) for r in range(2)]))
    assert untested["effect_size_name"].tolist() == ["none"]


def test_a_finished_batch_resumed_says_its_tasks_are_done_not_eta_unknown() -> None:
    import io

    from nudgecli.runs.progress import Progress

    now = [0.0]
    progress = Progress("replicate", stream=io.StringIO(), clock=lambda: now[0])
    progress.tail_s = 2.0  # the tables and figures the resume still writes
    now[0] = 3.0
    line = progress.line(16, 16)  # every task was done before: no rate
    assert line == "replicate: 16/16 tasks (100%), done before, ETA 2 s"  # was "0.00 tasks/s, ETA unknown"
    assert "unknown" not in Progress("sweep", stream=io.StringIO()).line(4, 4)  # no tail known either


def _texts(ax: Any) -> list[str]:
    """Every text drawn in a panel and its y tick labels."""
    return [text.get_text() for text in ax.texts] + [label.get_text() for label in ax.get_yticklabels()]


def test_a_forest_panel_without_a_pooled_mean_says_why() -> None:
    from nudgecli.report.figures.replication import forest_panel, pairs_forest_panel
    from nudgecli.report.replication import summarise

    rows = _some_tested_rows()
    summary = summarise(rows)
    assert summary["difference"].isna().all()  # pooled over all four or none: no line to draw
    ax = forest_panel(rows, summary.iloc[0])
    assert "pooled: undefined (1 of 4 tested)" in _texts(ax)  # was nothing: no line and no word why
    three = pd.concat([rows, rows.assign(b="teleoperation", difference=0.5)], ignore_index=True)
    ax = pairs_forest_panel(three, summarise(three))
    labels = [label.get_text() for label in ax.get_yticklabels()]
    assert labels == ["disambiguation - control\npooled: undefined (1 of 4 tested)",
                      "disambiguation - teleoperation"]


def test_a_swept_parameter_of_one_value_draws_its_range_as_an_error_bar() -> None:
    from nudgecli.report.figures.replication import sweep_panel, sweep_values

    group = pd.DataFrame({"inference.kappa": [0.6] * 5, "difference": [0.1, 0.2, 0.3, 0.4, 0.5]})
    stats = sweep_values(group, "inference.kappa")
    ax = sweep_panel(group, "inference.kappa")
    # was a band from fill_between over one x: no width, nothing drawn
    assert len(ax.containers) == 1
    (segments,) = [c.get_segments() for c in ax.containers[0].lines[2]]
    assert [segments[0][0][1], segments[0][1][1]] == pytest.approx([stats["low"][0], stats["high"][0]])
    assert stats["high"][0] > stats["low"][0]


def test_the_docs_say_the_forest_plot_colours_the_participant_level_verdict() -> None:
    from nudgecli.report.figures.replication import forest_panel
    from nudgecli.report.replication import summarise

    docs = (Path(__file__).parents[1] / "docs" / "batches.md").read_text(encoding="utf-8")
    said = " ".join(docs.split("`figures/forest.png` shows", 1)[1].split(";", 1)[0].split())
    # was "coloured by significance": the trial-level verdict colours nothing
    assert "coloured by its participant-level (Wilcoxon) verdict only" in said
    rows = pd.DataFrame([_replication_row(r, True) for r in range(2)])
    _, labels = forest_panel(rows, summarise(rows).iloc[0]).get_legend_handles_labels()
    assert labels == ["not significant", "significant (participant level)"]
