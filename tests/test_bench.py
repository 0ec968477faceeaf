"""``nudge bench``: rows, table and the command (no timing assertions)."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from nudgecli import bench
from nudgecli.bench import analyze, common, scale
from nudgecli.bench import model as figures
from nudgecli.cli import main
from nudgecli.errors import NudgeError


def test_run_bench_rows_have_the_columns() -> None:
    options = common.BenchOptions(repeats=1, baseline_repeats=1, mc_states=2)
    # the window figure's baseline is a full 75-state per-sample run (about a second); the grid
    # and VI figures are cheap at these options
    rows = bench.run_bench(options, figures=[figures.figure_grid, figures.figure_value_iteration])
    assert [set(row) for row in rows] == [set(common.COLUMNS)] * 2
    grid, vi = rows
    assert grid["ratio"] == pytest.approx(grid["baseline_s"] / grid["time_s"])
    assert "scaled linearly" in grid["note"]
    assert vi["baseline_s"] is None and vi["ratio"] is None
    assert "305 sweeps" in vi["note"]
    table = bench.format_table(rows)
    assert table.splitlines()[0].split() == ["what", "time", "baseline", "ratio", "memory", "target", "ok"]
    assert "value iteration" in table


def _fake_figure(options: common.BenchOptions) -> dict[str, Any]:
    return {"what": "fake", "time_s": 2e-5, "baseline_s": 0.5, "ratio": 25_000.0, "peak_mb": None,
            "target": ">= 5000x", "ok": True, "note": "a note"}


def _fake_study_figure(options: common.BenchOptions) -> dict[str, Any]:
    return {"what": f"fake study of {options.study_experiment}", "time_s": 3.0, "baseline_s": None,
            "ratio": None, "peak_mb": 200.0, "target": "<= 20 s", "ok": True, "note": ""}


def test_bench_command_formats(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bench, "FIGURES", [_fake_figure])
    runner = CliRunner()
    result = runner.invoke(main, ["bench", "--format", "json"])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert rows == [_fake_figure(common.BenchOptions())]
    result = runner.invoke(main, ["bench"])
    assert result.exit_code == 0
    assert "fake" in result.stdout and "20.0 us" in result.stdout and "25,000x" in result.stdout
    assert "yes" in result.stdout and "a note" in result.stdout


def test_format_seconds_units() -> None:
    rows = [{"what": "a", "time_s": 1.5, "baseline_s": 0.0025, "ratio": None, "peak_mb": 1234.4,
             "target": "-", "ok": False, "note": ""}]
    line = bench.format_table(rows).splitlines()[2]
    assert "1.50 s" in line and "2.50 ms" in line and "1,234 MB" in line and "NO" in line


def _check_types(row: dict[str, Any]) -> None:
    assert list(row) == list(common.COLUMNS)
    assert isinstance(row["what"], str) and isinstance(row["target"], str) and isinstance(row["note"], str)
    assert isinstance(row["time_s"], float) and row["time_s"] > 0
    for key in ("baseline_s", "ratio", "peak_mb"):
        assert row[key] is None or isinstance(row[key], float)
    assert isinstance(row["ok"], bool)


def test_study_figures_on_the_smoke_preset(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # smoke: 8 layouts, 8 trials per participant; one participant keeps the subprocess short
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # where the study's run folder goes
    options = common.BenchOptions(study_experiment="smoke", study_participants=1, study_workers=2,
                                  study_repeats=1)
    logged: list[str] = []
    rows = bench.run_bench(options, figures=bench.STUDY_FIGURES, progress=logged.append)
    assert logged == ["bench: study_setup", "bench: trials", "bench: study", "bench: cli_startup",
                      "bench: pool_ready", "bench: worker_ready"]
    for row in rows:
        _check_types(row)
    setup, trials, study, startup, pool, worker = rows
    assert setup["what"] == "study setup: 8 layouts' value iteration"
    assert setup["baseline_s"] is None and setup["ratio"] is None and setup["peak_mb"] is None
    assert "(8 x 50 ms)" in setup["target"] and "'smoke' (seed 7)" in setup["note"]
    assert trials["what"] == "trials, simulated s per wall s"
    assert trials["baseline_s"] > 0
    assert trials["ratio"] == pytest.approx(trials["baseline_s"] / trials["time_s"])
    assert trials["target"] == ">= 1,000x; <= 3.50 ms per trial" and "8 trials" in trials["note"]
    assert study["what"] == "smoke-scale study (8 trials), 2 workers"
    assert study["baseline_s"] is None and study["ratio"] is None
    assert study["peak_mb"] is not None and study["peak_mb"] > 0
    assert "1 participants" in study["note"] and "upper bound" in study["note"]
    assert startup["what"] == "nudge --help (start-up)" and startup["ok"] == (startup["time_s"] <= 0.3)
    assert "nudgecli.runs.study_tasks" in worker["note"] and "nudgecli.runs.batch" in worker["note"]
    assert pool["what"] == "worker ready (local pool, fork)" and pool["note"].startswith("2 pool workers")
    assert list(tmp_path.iterdir()) == []  # the study's temporary folder is removed
    assert json.loads(json.dumps(rows)) == rows
    table = bench.format_table(rows)
    assert "smoke-scale study" in table and " MB " in table


def test_select_figures_groups() -> None:
    assert bench.select_figures("all") == bench.FIGURES
    assert bench.select_figures("study") == bench.STUDY_FIGURES
    model = bench.select_figures("model")
    assert model == [figures.figure_window, figures.figure_grid, figures.figure_value_iteration]
    assert not set(model) & set(bench.STUDY_FIGURES)
    with pytest.raises(ValueError, match="only must be"):
        bench.select_figures("everything")


def test_scale_worker_counts_hold_one_and_never_exceed_the_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(scale, "available_cores", lambda: 16)
    assert scale.scale_worker_counts() == list(range(1, 17))
    # 1 is always timed (every efficiency is against it); repeats and order do not matter
    assert scale.scale_worker_counts([16, 4, 8, 4]) == [1, 4, 8, 16]
    names = [f.__name__ for f in scale.scale_figures([2, 16])]
    assert names[:4] == ["figure_scale_study_1", "figure_scale_study_2", "figure_scale_study_16",
                         "figure_scale_study_dask"]
    assert names[4:8] == ["figure_scale_sweep_1", "figure_scale_sweep_2", "figure_scale_sweep_16",
                          "figure_scale_sweep_dask"]
    for wrong in ([0, 2], [17]):
        with pytest.raises(NudgeError, match=r"from 1 to the 16 cores.*\(not " + str(wrong[0]) + r"\)"):
            scale.scale_worker_counts(wrong)


def test_bench_scale_workers_option(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(scale, "available_cores", lambda: 4)
    chosen: list[Any] = []
    monkeypatch.setattr(bench, "run_bench", lambda options, figures, progress: chosen.append(figures) or [])
    runner = CliRunner()
    result = runner.invoke(main, ["bench", "--only", "scale", "--scale-workers", "4,2", "--format", "json"])
    assert result.exit_code == 0, result.output
    assert [f.__name__ for f in chosen[0]][:3] == ["figure_scale_study_1", "figure_scale_study_2",
                                                   "figure_scale_study_4"]
    result = runner.invoke(main, ["bench", "--only", "scale", "--scale-workers", "1,8"])
    assert result.exit_code == 1 and "Error: --scale-workers 1,8: every count" in result.output
    result = runner.invoke(main, ["bench", "--scale-workers", "1,2"])  # not the scale figures
    assert result.exit_code == 2 and "add --only scale" in result.output
    result = runner.invoke(main, ["bench", "--only", "scale", "--scale-workers", "two"])
    assert result.exit_code == 2 and "--scale-workers: 'two': give comma-separated integers" in result.output
    result = runner.invoke(main, ["bench", "--only", "scale", "--scale-workers", ","])  # no count at all
    assert result.exit_code == 1 and "Error: --scale-workers: no worker count given" in result.output


def test_bench_command_only(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bench, "FIGURES", [_fake_figure, _fake_study_figure])
    monkeypatch.setattr(bench, "STUDY_FIGURES", [_fake_study_figure])
    runner = CliRunner()
    for only, expected in (("model", ["fake"]), ("study", ["fake study of paper"]),
                           ("all", ["fake", "fake study of paper"])):
        result = runner.invoke(main, ["bench", "--format", "json", "--only", only])
        assert result.exit_code == 0, result.output
        assert [row["what"] for row in json.loads(result.stdout)] == expected
    result = runner.invoke(main, ["bench", "--only", "study", "--study-repeats", "2"])
    assert result.exit_code == 0, result.output
    assert "200 MB" in result.stdout and "fake study of paper" in result.stdout
    result = runner.invoke(main, ["bench", "--only", "nothing"])
    assert result.exit_code == 2


def test_the_analyze_figure_is_its_own_group_and_runs_on_a_small_table() -> None:
    assert bench.select_figures("analyze") == [analyze.figure_analyze]
    assert analyze.figure_analyze not in bench.select_figures("all")
    table = analyze.synthetic_metrics_table(1000, 10)
    assert len(table) == 1000 and table.groupby(["participant", "condition"]).size().eq(50).all()
    row = analyze.figure_analyze(common.BenchOptions(analyze_rows=1000, analyze_participants=10))
    assert set(row) == set(common.COLUMNS) and row["peak_mb"] > 0 and "1,000-row" in row["what"]


def test_replicate_throughput_counts_every_trial_of_the_batch(monkeypatch: pytest.MonkeyPatch,
                                                              tmp_path: Path) -> None:
    # smoke: 2 participants x 2 conditions x 4 trials = 16 trials a study; 2 studies = 32 trials
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    options = common.BenchOptions(throughput_experiment="smoke", throughput_replications=2, study_workers=1)
    row = scale.figure_replicate_throughput(options)
    _check_types(row)
    assert row["what"] == "replicate smoke -R 2, 1 workers, end to end"
    assert row["baseline_s"] == pytest.approx(32 / 1_000_000 * 3600)
    per_hour = float(row["note"].split(" trials per hour")[0].replace(",", ""))
    assert per_hour == pytest.approx(32 / row["time_s"] * 3600, rel=1e-3)
    assert row["ok"] == (per_hour >= 1_000_000)
    assert scale.figure_replicate_throughput in bench.select_figures("scale")
    assert list(tmp_path.iterdir()) == []



def test_a_scale_batch_runs_in_a_child_of_its_own(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # The batch runs in a fresh Python, so its forked workers carry none of what this process loaded
    # for other figures: a worker started from here would hold this test process's pages.
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    ballast = np.ones(300 * 2**20 // 8)  # 300 MB resident here, which a worker forked from here would hold
    options = common.BenchOptions(scale_studies=2)
    row = scale.scale_figure("sweep", 2)(options)
    _check_types(row)
    assert row["what"] == "scale: 2 smoke studies, 2 worker(s)"
    assert row["baseline_s"] == scale._SCALE_TIMES[("sweep", repr(options))]  # the 1-worker run
    assert 0 < row["peak_mb"] < 300 and ballast.sum() == ballast.size
    own, workers = scale._SCALE_CPU[("sweep", 2)]
    # the batch's own process runs the analyses beside the workers: for two tiny studies, most of the CPU
    assert own > 0 and workers > 0 and f"workers {workers:.2f} s" in row["note"]
    assert f"the batch's process {own:.2f} s, its analyses included" in row["note"]
    assert list(tmp_path.iterdir()) == []


def test_small_ratios_keep_their_decimals() -> None:
    # a throughput at 0.46 of its target read "0x" when every ratio was rounded to a whole number
    rows = [{"what": w, "time_s": 1.0, "baseline_s": 1.0, "ratio": r, "peak_mb": None, "target": "-",
             "ok": True, "note": ""} for w, r in (("small", 0.4607), ("large", 25_000.0))]
    small, large = bench.format_table(rows).splitlines()[2:4]
    assert "0.46x" in small and "25,000x" in large


def test_bench_warns_where_child_pythons_would_compile_the_package(tmp_path) -> None:
    # With PYTHONDONTWRITEBYTECODE and no cached bytecode, every child Python compiles the package
    # and each start-up figure carries it (0.4-0.5 s of the paper study on a 2-core machine)
    import py_compile

    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    modules = [package / "__init__.py", package / "sub" / "a.py"]
    for module in modules:
        module.write_text("x = 1\n")
    off = {"PYTHONDONTWRITEBYTECODE": "1"}
    assert common.uncompiled_modules_warning(package, {}) is None  # the children write their cache
    warning = common.uncompiled_modules_warning(package, off)
    assert warning is not None and "2 of pkg's 2 modules" in warning and "compileall" in warning
    py_compile.compile(str(modules[0]))
    assert "1 of pkg's 2 modules" in str(common.uncompiled_modules_warning(package, off))
    py_compile.compile(str(modules[1]))
    assert common.uncompiled_modules_warning(package, off) is None
