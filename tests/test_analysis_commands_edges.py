"""Small defects of the analysis commands: the D(s) bench rows' ``ok`` needs both targets, ``nudge
compare`` says when it sets a table beside itself, the pilots' diagonals are compared at full
precision, and validate's |G| axis has whole-number ticks."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from test_report_compare import synthetic

from nudgecli import api
from nudgecli.bench.model import speedup_ok
from nudgecli.bench.targets import (
    GRID_SPEEDUP_TARGET,
    GRID_TIME_TARGET_S,
    WINDOW_SPEEDUP_TARGET,
    WINDOW_TIME_TARGET_S,
)
from nudgecli.report.validation_figure import match_rate_panel
from nudgecli.sim.real_population import PILOT_DIAGONALS, coverage_table

# --- bench: ratio and time --------------------------------------------------------------------

def test_a_d_s_row_is_ok_only_when_both_its_ratio_and_its_time_are_met() -> None:
    # DESIGN 8: the full grid >= 500x AND <= 2 ms; a 4.9 ms exact time over a slow baseline is not ok
    assert (GRID_SPEEDUP_TARGET, GRID_TIME_TARGET_S) == (500.0, 0.002)
    assert not speedup_ok(0.0049, 0.0049 * 600, GRID_SPEEDUP_TARGET, GRID_TIME_TARGET_S)
    assert speedup_ok(0.0019, 0.0019 * 600, GRID_SPEEDUP_TARGET, GRID_TIME_TARGET_S)
    assert not speedup_ok(0.0019, 0.0019 * 400, GRID_SPEEDUP_TARGET, GRID_TIME_TARGET_S)
    # the window: >= 5000x AND <= 0.1 ms
    assert (WINDOW_SPEEDUP_TARGET, WINDOW_TIME_TARGET_S) == (5000.0, 0.0001)
    assert not speedup_ok(0.0002, 0.0002 * 6000, WINDOW_SPEEDUP_TARGET, WINDOW_TIME_TARGET_S)
    assert speedup_ok(0.00008, 0.00008 * 6000, WINDOW_SPEEDUP_TARGET, WINDOW_TIME_TARGET_S)


# --- compare: a table beside itself -------------------------------------------------------------

SELF_NOTE = "the table is compared with itself"


def _tables(tmp_path: Path) -> tuple[Path, Path, Path]:
    simulated = tmp_path / "sim.csv"
    synthetic(n_participants=3, trials=4).to_csv(simulated, index=False)
    copy = tmp_path / "copy.csv"
    shutil.copy(simulated, copy)
    real = tmp_path / "real.csv"
    synthetic(n_participants=3, trials=4, shift=4.0, seed=9, prefix="r").to_csv(real, index=False)
    return simulated, copy, real


def test_compare_notes_a_file_beside_itself_or_its_copy(tmp_path: Path) -> None:
    simulated, copy, real = _tables(tmp_path)
    same = api.compare(simulated, simulated, resamples=0)
    assert [n for n in same.notes if SELF_NOTE in n] == [
        f"{simulated} and {simulated} are the same file: the table is compared with itself, so every "
        "distance is 0; give the real people's metrics table as REAL"]
    copied = api.compare(simulated, copy, resamples=0)
    assert [n for n in copied.notes if SELF_NOTE in n and "hold the same trials" in n]
    assert not [n for n in api.compare(simulated, real, resamples=0).notes if SELF_NOTE in n]


def test_compare_notes_a_run_beside_its_own_metrics(analysed_smoke_run: Path) -> None:
    result = api.compare(analysed_smoke_run, analysed_smoke_run / "metrics.csv", resamples=0)
    assert [n for n in result.notes if "hold the same trials" in n]


def test_a_changed_value_is_another_table(tmp_path: Path) -> None:
    simulated, copy, _ = _tables(tmp_path)
    table = pd.read_csv(copy)
    table["completion_time"] += 1.0
    table.to_csv(copy, index=False)
    assert not [n for n in api.compare(simulated, copy, resamples=0).notes if SELF_NOTE in n]


# --- plot-population: the pilots at full precision ---------------------------------------------------

def test_a_simulated_person_at_a_pilots_value_is_inside_the_pilots_range() -> None:
    ceiling = (1 + 0.01) / 1.04  # the estimator's largest diagonal: deepaktest's Hard Sip
    assert PILOT_DIAGONALS["deepaktest"]["Hard Sip"] == pytest.approx(ceiling, rel=1e-12)
    rows = [(p, "fixed_rate", "Hard Sip", d) for p, d in enumerate([ceiling, ceiling, 0.96, 0.90])]
    table = coverage_table(pd.DataFrame(rows, columns=["participant", "stream", "label", "diagonal"]))
    fixed = table[table["stream"] == "fixed_rate"].iloc[0]
    assert fixed["real_inside"] == pytest.approx(3 / 4)  # 0.90 is below andrewtest's 0.954
    assert fixed["covers_high"]


# --- validate: |G| ticks ------------------------------------------------------------------------

def test_the_goals_axis_has_whole_number_ticks() -> None:
    rates = {"match_rate": 0.9, "match_rate_excluding_near_ties": 0.95, "truth_optimal_rate": 0.97,
             "regularised_match_rate": 0.92}
    summary = {"by_goals": {"3": rates, "4": rates}, "queries": 20, "match_rate": 0.9}
    ax = match_rate_panel(summary, ax=Figure().subplots())
    ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
    assert ticks and np.allclose(ticks, np.round(ticks)), ticks
