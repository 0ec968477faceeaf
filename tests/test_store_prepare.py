"""The prepare rule of a folder about to be written (:func:`nudgecli.store.prepare_mode`), as each
of its callers uses it: ``nudge simulate`` (defaults), the batches (``kind="batch"``; a forced
non-empty folder is written into, not cleared) and ``nudge study`` (no ``--force``, its
participant locks are its own, "nothing to resume" before "not empty")."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.errors import RunFolderError
from nudgecli.run_folder_names import LOCK
from nudgecli.runs.batch_folder import prepare_folder
from nudgecli.store import prepare_mode


def _folder(tmp_path: Path, *names: str) -> Path:
    folder = tmp_path / "out"
    folder.mkdir()
    for name in names:
        (folder / name).write_text("x")
    return folder


def test_a_folder_that_holds_work_is_resumed_replaced_or_refused(tmp_path: Path) -> None:
    folder = _folder(tmp_path, "batch.json")
    assert prepare_mode(folder, "sweep, complete", resume=True, force=False, kind="batch") == "resume"
    assert prepare_mode(folder, "sweep, complete", resume=False, force=True, kind="batch") == "replace"
    with pytest.raises(RunFolderError) as refused:
        prepare_mode(folder, "sweep, complete", resume=False, force=False, kind="batch")
    assert str(refused.value) == (f"{folder}: already holds a batch (sweep, complete); use --resume to "
                                  "finish it, --force to replace it, or choose another --out")


def test_a_folder_with_other_files_needs_force_and_the_lock_does_not_count(tmp_path: Path) -> None:
    assert prepare_mode(_folder(tmp_path, LOCK), None, resume=False, force=False) == "new"
    assert prepare_mode(tmp_path / "missing", None, resume=False, force=False) == "new"
    (tmp_path / "out" / "notes.txt").write_text("mine")
    folder = tmp_path / "out"
    assert prepare_mode(folder, None, resume=False, force=True) == "overwrite"
    with pytest.raises(RunFolderError, match=r"not empty; choose another --out or use --force$"):
        prepare_mode(folder, None, resume=False, force=False)
    with pytest.raises(RunFolderError, match=r"exists and is not empty; choose another --out$"):
        prepare_mode(folder, None, resume=False, force=False, can_force=False)


def test_resume_with_nothing_there_is_refused_in_each_callers_order(tmp_path: Path) -> None:
    with pytest.raises(RunFolderError, match=r"nothing to resume \(no batch there\); drop --resume"):
        prepare_mode(tmp_path / "missing", None, resume=True, force=False, kind="batch")
    folder = _folder(tmp_path, "notes.txt")
    with pytest.raises(RunFolderError, match="not empty"):  # simulate, batches: the contents first
        prepare_mode(folder, None, resume=True, force=False)
    with pytest.raises(RunFolderError, match=r"nothing to resume \(no run there\)"):  # nudge study
        prepare_mode(folder, None, resume=True, force=False, resume_first=True, can_force=False)


def test_own_files_are_those_the_caller_names(tmp_path: Path) -> None:
    folder = _folder(tmp_path, ".nudge-participant-0001.lock")
    with pytest.raises(RunFolderError, match="not empty"):
        prepare_mode(folder, None, resume=False, force=False)
    locks_are_own = prepare_mode(folder, None, resume=False, force=False,
                                 own_file=lambda name: name.endswith(".lock"))
    assert locks_are_own == "new"


def test_a_forced_batch_writes_into_a_non_empty_folder_without_clearing_it(tmp_path: Path) -> None:
    folder = _folder(tmp_path, "notes.txt")
    assert prepare_folder(folder, {"kind": "sweep"}, resume=False, force=True) == "new"
    assert (folder / "notes.txt").read_text() == "x"
    (folder / "batch.json").write_text('{"batch": {"kind": "sweep"}, "status": "complete"}')
    (folder / "tasks").mkdir()
    assert prepare_folder(folder, {"kind": "sweep"}, resume=True, force=False) == "resume"
    with pytest.raises(RunFolderError, match="holds a sweep batch, not a power batch"):
        prepare_folder(folder, {"kind": "power"}, resume=True, force=False)
    assert prepare_folder(folder, {"kind": "power"}, resume=False, force=True) == "new"
    assert not (folder / "batch.json").exists() and not (folder / "tasks").exists()
    assert (folder / "notes.txt").is_file()


# --- atomic writes -----------------------------------------------------------------------------


def test_an_atomic_file_gets_the_umasks_permissions_and_a_failed_one_leaves_nothing(tmp_path: Path) -> None:
    import os
    import stat

    from nudgecli.errors import WriteError
    from nudgecli.store import atomic_path, write_text_atomic

    umask = os.umask(0o022)
    os.umask(umask)
    if 0o666 & ~umask == 0o600:
        pytest.skip("under this umask a plain file is 0600 too")
    write_text_atomic(tmp_path / "a.txt", "x")
    # mkstemp makes 0600 files; a written file has what open() gives under the umask
    assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o666 & ~umask

    (tmp_path / "b.txt").write_text("old")

    def fail(path: Path) -> None:
        path.write_text("half")
        raise OSError(28, "No space left on device")

    with pytest.raises(WriteError, match="No space left on device"), atomic_path(tmp_path / "b.txt") as tmp:
        fail(tmp)
    assert (tmp_path / "b.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]  # no temporary left


def test_force_removes_the_old_runs_figures_and_keeps_a_persons_file(tmp_path: Path) -> None:
    # the old run's figures beside the new run's tables would show a run the folder no longer holds
    from nudgecli.config import load_experiment
    from nudgecli.runs.study import run_study

    out = tmp_path / "run"
    run_study(load_experiment("smoke"), out, participants=1)
    figures = out / "figures"
    figures.mkdir()
    for name in ("fig3.png", "fig5.PDF", "trajectory.svg", "notes.txt"):
        (figures / name).write_text("old")
    run_study(load_experiment("smoke"), out, participants=1, seed=3, force=True)
    assert sorted(p.name for p in figures.iterdir()) == ["notes.txt"]
    (figures / "notes.txt").unlink()
    (figures / "fig4.png").write_text("old")
    run_study(load_experiment("smoke"), out, participants=1, seed=4, force=True)
    assert not figures.exists()
