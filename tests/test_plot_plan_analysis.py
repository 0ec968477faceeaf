"""``nudge plot SOURCE --plan PLAN`` analyses SOURCE first, and only once the plot's choices are checked.

A plot refused for its ``--trial`` or its ``--out`` leaves the existing analysis as it was (QA:
``--trial 9:9`` had already rewritten ``metrics.csv``, ``stats.json``, ``stats.csv`` and
``summary.md`` with the new plan's analysis before failing).
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.report.analysis import analyze
from nudgecli.runs.study import run_study

RECORDS = ("metrics.csv", "stats.json", "stats.csv", "summary.md", "manifest.json")


@pytest.fixture(scope="module")
def analysed_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke study analysed with the paper plan. Do not modify: tests work on copies."""
    run = run_study(load_experiment("smoke"), tmp_path_factory.mktemp("smoke") / "run")
    analyze(run.path, plan="paper")
    return run.path


def _nudge(*args: str | Path) -> Result:
    return CliRunner().invoke(main, [str(a) for a in args])


def _error_line(result: Result) -> str:
    assert result.exit_code == 1, (result.output, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    return lines[0]


def _digests(folder: Path) -> dict[str, str]:
    return {name: hashlib.sha256((folder / name).read_bytes()).hexdigest()
            for name in RECORDS if (folder / name).is_file()}


@pytest.mark.parametrize(("choice", "message"), [
    (["--trial", "9:9"], "--trial 9:9: no such trial"),
    (["--trial", "0:99"], "--trial 0:99: no such trial"),
    (["--out", "NONEMPTY"], "exists and is not empty"),
], ids=["unknown-participant", "unknown-trial", "out-not-empty"])
def test_a_plot_refused_for_its_choices_leaves_the_analysis_as_it_was(analysed_run, tmp_path, choice,
                                                                      message):
    run = shutil.copytree(analysed_run, tmp_path / "run")
    before = _digests(run)
    assert set(before) == set(RECORDS)
    (tmp_path / "NONEMPTY").mkdir()
    (tmp_path / "NONEMPTY" / "notes.txt").write_text("mine\n")
    args = [str(tmp_path / a) if a == "NONEMPTY" else a for a in choice]
    line = _error_line(_nudge("plot", run, "--plan", "study-code", "--formats", "png", *args))
    assert message in line
    assert _digests(run) == before and not (run / "figures").exists()


def test_a_plot_with_a_known_trial_still_analyses_with_the_plan(analysed_run, tmp_path):
    run = shutil.copytree(analysed_run, tmp_path / "run")
    before = _digests(run)
    result = _nudge("plot", run, "--plan", "study-code", "--formats", "png", "--trial", "1:7")
    assert result.exit_code == 0, result.output
    assert _digests(run)["stats.json"] != before["stats.json"]
    assert "plan: study-code" in (run / "summary.md").read_text(encoding="utf-8")
