"""``nudge plot`` of a source it cannot draw a trial of: the shipped reference run (its metrics and
figures kept, its step logs left out) and a metrics table.

``--trial`` there is one ``Error:`` line naming why, and a plot of the reference run keeps the
Fig. 5 and trajectory its earlier plot drew from the step logs (``findings.md`` cites them), saying
so, where it used to remove them as figures of an earlier plot it did not draw again.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.run_folder_names import FIGURES_DIR, FIGURES_RECORD

REFERENCE = Path(__file__).parents[1] / "results" / "paper"
TABLE = Path(__file__).parent / "data" / "metrics_two_conditions.csv"
STEP_FIGURES = ("fig5.pdf", "fig5.png", "trajectory.pdf", "trajectory.png")


@pytest.fixture
def reference(tmp_path: Path) -> Path:
    """A copy of results/paper as shipped: its files and figures, no participant's parts."""
    copy = tmp_path / "reference"
    copy.mkdir()
    for path in REFERENCE.iterdir():
        if path.is_file():
            shutil.copy2(path, copy / path.name)
    shutil.copytree(REFERENCE / FIGURES_DIR, copy / FIGURES_DIR)
    assert all((copy / FIGURES_DIR / name).is_file() for name in STEP_FIGURES)
    return copy


@pytest.fixture
def table(tmp_path: Path) -> Path:
    source = tmp_path / "study.csv"
    shutil.copy(TABLE, source)
    assert CliRunner().invoke(main, ["analyze", str(source)]).exit_code == 0
    return source


def figures_of(folder: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in sorted((folder / FIGURES_DIR).iterdir())}


def test_trial_of_a_run_without_step_logs_is_one_error_and_changes_no_figure(reference):
    before = figures_of(reference)
    result = CliRunner().invoke(main, ["plot", str(reference), "--trial", "0:1"])
    assert result.exit_code != 0
    assert result.output.count("\n") == 1 and result.output.startswith("Error: --trial 0:1: ")
    assert f"{reference} holds no step logs" in result.output and "plot without --trial" in result.output
    assert figures_of(reference) == before


def test_a_plot_of_a_run_without_step_logs_keeps_its_step_figures_and_says_why(reference, table):
    before = figures_of(reference)
    result = CliRunner().invoke(main, ["plot", str(reference)])
    assert result.exit_code == 0, result.output
    after = figures_of(reference)
    assert {name: after.get(name) for name in STEP_FIGURES} == {name: before[name] for name in STEP_FIGURES}
    kept = [line for line in result.output.splitlines() if line.startswith("kept 4 figure file(s)")]
    assert len(kept) == 1 and ", ".join(STEP_FIGURES) in kept[0] and "holds no step logs" in kept[0]
    assert "removed" not in result.output
    # still recorded: a later plot of a table into the folder removes them as before
    record = json.loads((reference / FIGURES_DIR / FIGURES_RECORD).read_text())
    assert set(STEP_FIGURES) <= set(record["written"]) and set(STEP_FIGURES) <= set(record["sha256"])
    other = CliRunner().invoke(main, ["plot", str(table), "--out", str(reference / FIGURES_DIR), "--force"])
    assert other.exit_code == 0, other.output
    assert not any((reference / FIGURES_DIR / name).exists() for name in STEP_FIGURES)


@pytest.mark.parametrize("given", ["table", "folder"])
def test_trial_of_a_metrics_table_is_one_error(table, given):
    source = table if given == "table" else table.parent / "study-analysis"
    result = CliRunner().invoke(main, ["plot", str(source), "--trial", "0:1"])
    assert result.exit_code != 0
    assert result.output == (f"Error: --trial 0:1: {source}: the analysis of a metrics table holds no "
                             "trial's steps, so no trial's Fig. 5 or trajectory can be drawn; plot without "
                             "--trial\n")
    assert not (table.parent / "study-analysis" / FIGURES_DIR).exists()


def test_trial_of_a_table_with_plan_is_refused_before_the_analysis_is_written_again(table):
    stats = table.parent / "study-analysis" / "stats.json"
    before = stats.read_bytes()
    result = CliRunner().invoke(main, ["plot", str(table.parent / "study-analysis"), "--plan", "study-code",
                                       "--trial", "0:1"])
    assert result.exit_code != 0 and "the analysis of a metrics table holds no trial's steps" in result.output
    assert stats.read_bytes() == before


def test_the_api_refuses_a_trial_of_a_table(table):
    from nudgecli.api.figures import plot
    from nudgecli.errors import ConfigError

    with pytest.raises(ConfigError, match="holds no trial's steps"):
        plot(table, "fig4", trial=(0, 1))
