"""Mends of a second review of recent changes: what a run's ``--force`` removes of its old
analysis is the one list of the files an analysis writes, and the live page's kept answers."""

from __future__ import annotations

from pathlib import Path

from cli_helpers import copy_run, nudge

from nudgecli.run_folder_names import ANALYSIS_FILES, ANALYSIS_PLAN_COPY


def test_a_forced_simulation_removes_every_file_its_old_analysis_wrote(tmp_path: Path,
                                                                      analysed_smoke_run: Path) -> None:
    run = copy_run(analysed_smoke_run, tmp_path / "run")
    loose = tmp_path / "loose.toml"
    loose.write_text('name = "loose"\n\n[stats]\nkruskal_alpha = 0.9\nstar_thresholds = [0.9, 0.8, 0.7]\n')
    assert nudge("analyze", run, "--plan", loose, "--bootstrap", "100").exit_code == 0
    assert (run / ANALYSIS_PLAN_COPY).is_file()  # the plan the analysis under another plan kept
    forced = nudge("simulate", "smoke", "--participants", "1", "--seed", "5", "--out", run, "--force")
    assert forced.exit_code == 0, forced.output
    assert [name for name in ANALYSIS_FILES if (run / name).exists()] == []
