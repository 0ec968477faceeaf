"""``nudge bench``: rows, table and the command (no timing assertions)."""

from __future__ import annotations

import json
from typing import Any

import pytest
from click.testing import CliRunner

from nudgecli import bench
from nudgecli.cli import main


def test_run_bench_rows_have_the_columns() -> None:
    options = bench.BenchOptions(repeats=1, baseline_repeats=1, mc_states=2)
    # the window figure's baseline is a full 75-state per-sample run (about a second); the grid
    # and VI figures are cheap at these options
    rows = bench.run_bench(options, figures=[bench.figure_grid, bench.figure_value_iteration])
    assert [set(row) for row in rows] == [set(bench.COLUMNS)] * 2
    grid, vi = rows
    assert grid["ratio"] == pytest.approx(grid["baseline_s"] / grid["time_s"])
    assert "scaled linearly" in grid["note"]
    assert vi["baseline_s"] is None and vi["ratio"] is None
    assert "305 sweeps" in vi["note"]
    table = bench.format_table(rows)
    assert table.splitlines()[0].split() == ["what", "time", "baseline", "ratio", "target", "ok"]
    assert "value iteration" in table


def _fake_figure(options: bench.BenchOptions) -> dict[str, Any]:
    return {"what": "fake", "time_s": 2e-5, "baseline_s": 0.5, "ratio": 25_000.0, "target": ">= 5000x",
            "ok": True, "note": "a note"}


def test_bench_command_formats(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bench, "FIGURES", [_fake_figure])
    runner = CliRunner()
    result = runner.invoke(main, ["bench", "--format", "json"])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert rows == [_fake_figure(bench.BenchOptions())]
    result = runner.invoke(main, ["bench"])
    assert result.exit_code == 0
    assert "fake" in result.stdout and "20.0 us" in result.stdout and "25,000x" in result.stdout
    assert "yes" in result.stdout and "a note" in result.stdout


def test_format_seconds_units() -> None:
    rows = [{"what": "a", "time_s": 1.5, "baseline_s": 0.0025, "ratio": None, "target": "-", "ok": False,
             "note": ""}]
    line = bench.format_table(rows).splitlines()[2]
    assert "1.50 s" in line and "2.50 ms" in line and "NO" in line
