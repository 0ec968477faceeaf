"""A batch folder as a finished batch left it, with files of the user's own, for the tests of
replacing and refusing batch folders."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.run_folder_names import FIGURES_DIR
from nudgecli.runs.batch_folder import BATCH_FIGURES, BATCH_TABLES, PART_RECORD

#: A small replicate batch (the smoke experiment, 2 studies of 2 participants).
REPLICATE = ("replicate", "smoke", "-R", "2", "--participants", "2")
#: What :func:`an_old_batch` puts there of the user's own.
USERS_FILES = {"notes.txt": b"mine", "figures/sketch.png": b"mine too"}


def nudge(*args: str):
    return CliRunner().invoke(main, [*args])


def a_finished_replicate(folder: Path) -> Path:
    """:data:`REPLICATE` run to its end into ``folder`` (a module's fixture makes it once)."""
    done = nudge(*REPLICATE, "--out", str(folder))
    assert done.exit_code == 0, done.output
    return folder


def an_old_batch(folder: Path, kind: str = "power") -> None:
    """A folder holding every output any batch kind writes, as a finished ``kind`` batch left it,
    and two files of the user's own (one among the figures)."""
    (folder / "tasks" / "study").mkdir(parents=True)
    (folder / "tasks" / "study" / "part-0000.parquet").write_text("part")
    (folder / "analyses").mkdir()
    (folder / "analyses" / "study-n0002.json").write_text("{}")
    (folder / FIGURES_DIR).mkdir()
    for stem in BATCH_TABLES:
        (folder / f"{stem}.csv").write_text("old table")
    for stem in BATCH_FIGURES:
        (folder / FIGURES_DIR / f"{stem}.png").write_text("old figure")
    (folder / PART_RECORD).write_text("")
    (folder / "batch.json").write_text(json.dumps({"batch": {"kind": kind}, "status": "complete"}))
    (folder / "notes.txt").write_text("mine")
    (folder / FIGURES_DIR / "sketch.png").write_text("mine too")


def notes_a_sweep_tells(sweep: Path, out: Path, monkeypatch) -> tuple[str, ...]:
    """The notes ``nudge sweep`` hands its batch to tell (the batch stopped before anything is built)."""
    import pytest

    from nudgecli.runs import batch_kinds

    given: dict[str, tuple[str, ...]] = {}

    def no_run(batch, *args, **kwargs):
        given["notes"] = batch.notes
        raise KeyboardInterrupt

    monkeypatch.setattr(batch_kinds, "run_batch", no_run)
    with pytest.raises(KeyboardInterrupt):
        batch_kinds.sweep(str(sweep), out)
    return given["notes"]



def a_sweep_study(folder: Path, sweep: str) -> Path:
    """``folder``: the sweep file ``my.toml`` (``sweep``) naming ``exp.toml`` beside it, the smoke
    preset's copy."""
    from nudgecli.config_files import resolve_preset

    folder.mkdir()
    shutil.copy(resolve_preset("smoke", "experiments"), folder / "exp.toml")
    (folder / "my.toml").write_text(sweep)
    return folder
