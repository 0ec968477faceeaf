"""A run folder and a batch folder are not mixed: ``simulate``/``run`` into a folder that holds a
batch (its ``batch.json``), or ``replicate``/``power``/``sweep`` into one that holds a run (its
``manifest.json``), is one ``Error:`` line naming the kind the folder holds and how to remove it,
``--force`` and ``--resume`` included, and the folder is left byte for byte as it was (was:
``--force`` wrote the new kind beside the old kind's files, and the mixed folder was then resumed
and analysed)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import copy_run, files_of, nudge, one_error_line

REPLICATE = ("replicate", "smoke", "-R", "2", "--participants", "2")
SIMULATE = ("simulate", "smoke", "--participants", "2")


@pytest.fixture(scope="module")
def folders(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("kinds")
    made = {"run": nudge(*SIMULATE, "--out", root / "run"),
            "batch": nudge(*REPLICATE, "--out", root / "batch")}
    for result in made.values():
        assert result.exit_code == 0, result.output
    return {"run": root / "run", "batch": root / "batch"}


@pytest.mark.parametrize("option", ["--force", "--resume"])
def test_a_batch_into_a_run_folder_is_refused_and_the_run_kept(tmp_path: Path, folders: dict[str, Path],
                                                              option: str) -> None:
    run = copy_run(folders["run"], tmp_path / "run")
    before = files_of(run)
    result = nudge(*REPLICATE, "--out", run, option)
    line = one_error_line(result.stderr)
    assert result.exit_code == 1
    assert f"{run}: holds a run (manifest.json), not a batch" in line and f"rm -r {run}" in line, line
    assert files_of(run) == before


@pytest.mark.parametrize("option", ["--force", "--resume"])
def test_a_run_into_a_batch_folder_is_refused_and_the_batch_kept(tmp_path: Path, folders: dict[str, Path],
                                                                option: str) -> None:
    batch = copy_run(folders["batch"], tmp_path / "batch")
    before = files_of(batch)
    result = nudge(*SIMULATE, "--out", batch, option)
    line = one_error_line(result.stderr)
    assert result.exit_code == 1
    assert f"{batch}: holds a batch (batch.json), not a run" in line and f"rm -r {batch}" in line, line
    assert files_of(batch) == before


def test_force_still_replaces_a_run_or_a_batch_of_its_own_kind(tmp_path: Path,
                                                               folders: dict[str, Path]) -> None:
    run, batch = copy_run(folders["run"], tmp_path / "run"), copy_run(folders["batch"], tmp_path / "batch")
    assert nudge(*SIMULATE, "--out", run, "--force").exit_code == 0
    assert nudge("power", "smoke", "--participants", "2", "-R", "2", "--out", batch, "--force").exit_code == 0
    assert not (run / "batch.json").exists() and not (batch / "manifest.json").exists()


def test_a_folder_holding_both_kinds_is_resumed_as_neither(tmp_path: Path, folders: dict[str, Path]) -> None:
    mixed = copy_run(folders["run"], tmp_path / "mixed")  # as --force across kinds left it before
    (mixed / "batch.json").write_bytes((folders["batch"] / "batch.json").read_bytes())
    before = files_of(mixed)
    for command in (SIMULATE, REPLICATE):
        result = nudge(*command, "--out", mixed, "--resume")
        assert result.exit_code == 1 and f"rm -r {mixed}" in one_error_line(result.stderr)
    assert files_of(mixed) == before
