"""No command writes through a symbolic link into another folder: a batch folder's part folders
and files, a ``nudge study`` folder's, an analysis's files and a plot's ``figures/`` that are links
are refused in one ``Error:`` line naming the link and its target, before anything is written
(:func:`nudgecli.run_folder_state.refuse_links`, as for a run folder)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.errors import RunFolderError


def _elsewhere(tmp_path: Path, name: str) -> tuple[Path, dict[str, bytes]]:
    """Another folder (``mine.txt`` in it) or file the link points at, and what it holds."""
    target = tmp_path / "elsewhere" / name
    if "." in name:
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(b"mine")
        return target, {name: b"mine"}
    target.mkdir(parents=True)
    (target / "mine.txt").write_bytes(b"mine")
    return target, {"mine.txt": b"mine"}


def _held(target: Path) -> dict[str, bytes]:
    if target.is_file():
        return {target.name: target.read_bytes()}
    return {p.name: p.read_bytes() for p in target.iterdir()}


@pytest.mark.parametrize("name", ["tasks", "analyses", "figures", "people", "batch.json", "experiment.toml",
                                  "checksums.sha256"])
@pytest.mark.parametrize("how", [(), ("--force",), ("--resume",)])
def test_a_batch_refuses_a_linked_folder_or_file(tmp_path: Path, name: str, how: tuple[str, ...]) -> None:
    target, held = _elsewhere(tmp_path, name)
    out = tmp_path / "batch"
    out.mkdir()
    (out / name).symlink_to(target)
    result = nudge("replicate", "smoke", "-R", "1", "--participants", "2", "--out", out, *how)
    line = one_error_line(result.output)
    assert f"{out / name} is a symbolic link (to {target})" in line
    assert _held(target) == held and (out / name).is_symlink()
    assert not (out / "batch.json").exists() or name == "batch.json"  # refused before the batch started


@pytest.mark.parametrize("name", ["trials", "calibration", "questionnaires.csv", "manifest.json"])
def test_a_live_study_refuses_a_linked_folder_or_file(tmp_path: Path, name: str) -> None:
    from nudgecli.live.app import build_session

    target, held = _elsewhere(tmp_path, name)
    out = tmp_path / "live"
    out.mkdir()
    (out / name).symlink_to(target)
    with pytest.raises(RunFolderError, match="is a symbolic link") as refused:
        build_session("smoke", "P01", out=out)
    assert f"{out / name} is a symbolic link (to {target})" in str(refused.value)
    assert "\n" not in str(refused.value)
    assert _held(target) == held and sorted(p.name for p in out.iterdir()) == [name]


@pytest.mark.parametrize("name", ["stats.json", "metrics.csv", "stats.csv", "summary.md"])
def test_an_analysis_refuses_a_linked_file(analysed_smoke_run: Path, tmp_path: Path, name: str) -> None:
    target, held = _elsewhere(tmp_path, name)
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    (run / name).unlink(missing_ok=True)
    (run / name).symlink_to(target)
    line = one_error_line(nudge("analyze", run, "--bootstrap", "100").output)
    assert f"{run / name} is a symbolic link (to {target})" in line
    assert _held(target) == held and (run / name).is_symlink()


def test_a_plot_refuses_a_linked_figures_folder(analysed_smoke_run: Path, tmp_path: Path) -> None:
    target, held = _elsewhere(tmp_path, "figures")
    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    shutil.rmtree(run / "figures", ignore_errors=True)
    (run / "figures").symlink_to(target, target_is_directory=True)
    line = one_error_line(nudge("plot", run).output)
    assert f"{run / 'figures'} is a symbolic link (to {target})" in line
    assert _held(target) == held
