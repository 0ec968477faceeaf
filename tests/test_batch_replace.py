"""Replacing a batch folder (``--force``): every output of the old batch goes, whatever its kind,
before any work (an interrupted replacement leaves none of the old tables behind); files a user
put there stay."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from batch_helpers import REPLICATE, USERS_FILES, an_old_batch, nudge
from cli_helpers import files_of

from nudgecli.run_folder_names import FIGURES_DIR
from nudgecli.runs import batch as batch_module
from nudgecli.runs.batch_folder import BATCH_FIGURES, BATCH_TABLES, prepare_folder

# --- 1. a replaced batch leaves none of its outputs --------------------------------------------


def test_replacing_a_batch_removes_every_table_and_figure_of_any_kind(tmp_path: Path) -> None:
    folder = tmp_path / "out"
    an_old_batch(folder)
    assert prepare_folder(folder, {"kind": "replicate"}, resume=False, force=True) == "new"
    assert files_of(folder) == USERS_FILES


def test_the_declared_outputs_are_the_tables_and_figures_the_kinds_write() -> None:
    # batch_kinds refuses to write one not declared; these are the stems its three kinds write
    assert set(BATCH_TABLES) == {"replications", "conditions", "summary", "power", "smallest_n", "sweep",
                                 "points", "sensitivity"}
    assert set(BATCH_FIGURES) == {"forest", "power", "sweep", "sensitivity"}


def test_replicate_force_over_a_power_batch_leaves_no_power_table(tmp_path: Path) -> None:
    out = tmp_path / "p1"
    made = nudge("power", "smoke", "--participants", "2,3", "-R", "2", "--out", str(out))
    assert made.exit_code == 0, made.output
    assert {"power.csv", "smallest_n.csv", "figures/power.png"} <= set(files_of(out))
    replaced = nudge(*REPLICATE, "--out", str(out), "--force")
    assert replaced.exit_code == 0, replaced.output
    left = set(files_of(out))
    assert not {"power.csv", "smallest_n.csv", "figures/power.png"} & left
    assert {"replications.csv", "conditions.csv", "summary.csv", "figures/forest.png"} <= left


def test_an_interrupted_replacement_leaves_none_of_the_old_tables(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "f2"
    made = nudge(*REPLICATE, "--seed", "9", "--out", str(out))
    assert made.exit_code == 0, made.output

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(batch_module, "_run_graph", interrupted)
    stopped = nudge(*REPLICATE, "--seed", "1", "--out", str(out), "--force")
    assert stopped.exit_code != 0
    manifest = json.loads((out / "batch.json").read_text())
    assert manifest["status"] == "interrupted" and manifest["batch"]["seed"] == 1
    assert not any((out / f"{stem}.csv").exists() for stem in BATCH_TABLES)
    assert not (out / FIGURES_DIR / "forest.png").exists()


