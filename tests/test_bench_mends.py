"""``nudge bench`` and the size guard's estimate: the doc's targets, the bench's failing children,
its options and the estimate's arithmetic (nothing is timed here)."""

from __future__ import annotations

import io
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from nudgecli import bench
from nudgecli.bench import common, pipeline, scale, targets
from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import WorkerLostError
from nudgecli.report.plans import AnalysisPlan
from nudgecli.runs import batch as batch_module

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_performance_doc_gives_the_study_target_the_code_checks() -> None:
    text = (DOCS / "performance.md").read_text(encoding="utf-8")
    study = next(line for line in text.splitlines() if line.startswith("| paper-scale study, 432 trials"))
    target = study.split("|")[2]
    seconds = float(re.search(r"<= ([\d.]+) s", target).group(1))  # type: ignore[union-attr]
    assert seconds == targets.STUDY_WALL_TARGET_S  # it said 20 s


@pytest.mark.parametrize("option", [["--scale-participants", "64"], ["--scale-studies", "4"],
                                    ["--scale-workers", "1,2"]])
def test_bench_refuses_scale_options_without_only_scale(option: list[str]) -> None:
    result = CliRunner().invoke(main, ["bench", "--only", "model", *option])
    assert result.exit_code == 2  # was 0: --scale-participants and --scale-studies were ignored
    assert f"{option[0]} times the scale figures: add --only scale" in result.output


def _killed_child(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every bench child "runs" and is killed (-9), as the kernel's out-of-memory killer does."""
    def run(command: list[str], *, check: bool = False, **kwargs: Any) -> subprocess.CompletedProcess[str]:
        if check:  # what subprocess.run does
            raise subprocess.CalledProcessError(-9, command)
        return subprocess.CompletedProcess(command, -9, "", "")
    monkeypatch.setattr(common.subprocess, "run", run)


def test_a_child_exiting_non_zero_is_one_error_naming_the_figure() -> None:
    with pytest.raises(WorkerLostError, match=r"trials figure.s child process failed with exit status 3,"):
        common.run_child([sys.executable, "-c", "import sys; sys.exit(3)"], "trials")


@pytest.mark.parametrize("measure", [
    lambda: common.best_child_time(["-c", "pass"], 1, "nudge --help start-up"),
    lambda: common.run_child_script("pass", [], "paper-scale study"),
    lambda: pipeline._time_batch(["replicate", "smoke", "-R", "1"], 1, 16, 1),
    lambda: scale.figure_replicate_throughput(common.BenchOptions()),
])
def test_a_killed_child_names_the_figure_and_memory(monkeypatch: pytest.MonkeyPatch, measure: Any) -> None:
    _killed_child(monkeypatch)  # was a RuntimeError or subprocess.CalledProcessError: a traceback
    with pytest.raises(WorkerLostError, match=r"exit status -9 \(killed, perhaps for memory\)"):
        measure()


def test_bench_prints_a_killed_child_as_one_error_line(monkeypatch: pytest.MonkeyPatch) -> None:
    _killed_child(monkeypatch)
    monkeypatch.setattr(bench, "select_figures",
                        lambda only, counts: [lambda options: common.run_child_script("pass", [], "study")])
    result = CliRunner().invoke(main, ["bench", "--only", "study"])
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert "Error: bench: the study figure's child process failed with exit status -9" in result.output


def test_the_two_throughput_rows_name_the_issue_of_their_target(monkeypatch: pytest.MonkeyPatch) -> None:
    # both time replicate paper -R 20 --workers 2, against targets ten times apart
    monkeypatch.setattr(scale, "run_child", lambda *args, **kwargs: None)
    scale_row = scale.figure_replicate_throughput(common.BenchOptions())
    assert scale_row["target"] == ">= 1,000,000 trials/h (issue 23)"
    timing = pipeline.BatchTiming(20, 8640, 20.0, 40.0, None)
    measured = pipeline.PipelineMeasurement("paper", 2, 0.004, {20: timing}, timing)
    assert pipeline.throughput_row(measured)["target"] == ">= 10,000,000 trials/h (issue 39)"


#: Wall seconds measured on 2026-11-29 on the 2-core machine (quiet), and each batch's shape:
#: (experiment, participant counts, replications, workers, kind).
MEASURED_WALL_S = [
    (("smoke", (2,), 4, 1, "replicate"), 2.9),  # 2.9-4.1 s; the estimate said "about 1 s"
    (("smoke", (2,), 40, 1, "replicate"), 9.9),  # "about 5 s"
    (("smoke", (2, 4), 3, 1, "power"), 4.1),  # 3.2-5.0 s; "about 2 s"
    (("paper", (9,), 2, 2, "replicate"), 4.95),  # "about 2 s"
]


@pytest.mark.parametrize(("shape", "wall_s"), MEASURED_WALL_S)
def test_the_size_estimate_is_within_30_percent_of_the_measured_time(
        monkeypatch: pytest.MonkeyPatch, shape: tuple[str, tuple[int, ...], int, int, str],
        wall_s: float) -> None:
    monkeypatch.setattr("nudgecli.runs.size.available_cores", lambda: 2)
    experiment, counts, replications, workers, kind = shape
    batch = batch_module.Batch(kind, batch_module.single_point(load_experiment(experiment), counts),
                               replications, 1, AnalysisPlan())
    estimate = batch_module.estimate_batch(batch, workers)
    assert estimate.seconds == pytest.approx(wall_s, rel=0.3)  # was about half


def test_the_tail_grows_with_the_analyses_and_a_power_batchs_levels() -> None:
    from nudgecli.runs import size

    assert size.tail_seconds(4) == pytest.approx(size.TAIL_SECONDS + 4 * size.TAIL_SECONDS_PER_ANALYSIS)
    power = size.tail_seconds(6, power_levels=2) - size.tail_seconds(6)
    assert power == pytest.approx(size.POWER_TAIL_SECONDS + 2 * size.POWER_TAIL_SECONDS_PER_LEVEL)
    smoke = size.size_estimate(4, 8, 4, 64, 1)  # replicate smoke -R 4: the plans and tasks count too
    trials_and_analyses = 64 * size.SECONDS_PER_TRIAL + 4 * size.SECONDS_PER_ANALYSIS
    assert smoke.seconds - smoke.tail_seconds > size.SECONDS_FIXED + trials_and_analyses
    on_scheduler = size.size_estimate(3, 12, 6, 96, 2, power_levels=2).on("tcp://127.0.0.1:8786")
    assert on_scheduler.power_levels == 2
    assert on_scheduler.tail_seconds == pytest.approx(size.tail_seconds(6, 2))


def test_the_progress_eta_adds_the_tail_after_the_last_task() -> None:
    from nudgecli.runs.progress import Progress

    now = [0.0]
    progress = Progress("replicate", stream=io.StringIO(), clock=lambda: now[0])
    progress.line(0, 10)
    now[0] = 5.0
    assert progress.line(5, 10).endswith("ETA 5 s")  # no tail known: the tasks only
    progress.tail_s = 2.0
    assert progress.line(5, 10).endswith("ETA 7 s")
    assert progress.line(10, 10).endswith("(100%), 2.00 tasks/s, ETA 2 s")  # was "ETA 0 s"


class _GraphReachedError(Exception):
    pass


def test_a_batch_tells_its_progress_line_the_tail(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from nudgecli.runs.progress import Progress

    seen: list[float] = []

    def run_graph(*args: Any) -> None:  # stops the batch where its tasks would start
        seen.append(progress.tail_s)
        raise _GraphReachedError

    monkeypatch.setattr(batch_module, "_run_graph", run_graph)
    progress = Progress("replicate", stream=io.StringIO())
    batch = batch_module.Batch("power", batch_module.single_point(load_experiment("smoke"), (2, 4)), 3, 1,
                               AnalysisPlan())
    with pytest.raises(_GraphReachedError):
        batch_module.run_batch(batch, tmp_path / "out", workers=1, progress=progress)
    assert seen == [pytest.approx(batch_module.estimate_batch(batch, 1).tail_seconds)] and seen[0] > 0
