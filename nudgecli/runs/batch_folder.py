"""The batch folder: its manifest's name, the part files of its tasks, and the prepare rule.

Every result of a batch is written by the process that runs it as an atomic part file: a
participant task's per-trial metrics under ``tasks/<study>/``, an analysis's statistics under
``analyses/``. ``--resume`` recomputes exactly the tasks whose part is missing or unreadable
(:func:`nudgecli.run_folder_record.readable_parquet`, :func:`readable_stats`), so an interrupted
batch finishes without recomputing a finished task. The graph and its execution are in
:mod:`nudgecli.runs.batch`.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import RunFolderError
from nudgecli.parquet_reader import read_parquet
from nudgecli.run_folder_names import FIGURES_DIR
from nudgecli.run_folder_record import part_name
from nudgecli.store import prepare_mode

BATCH_MANIFEST = "batch.json"


def task_part(folder: Path, study: str, participant: int) -> Path:
    """The part file of a participant task."""
    return folder / "tasks" / study / part_name(participant)


def analysis_part(folder: Path, analysis: str) -> Path:
    """The part file of an analysis."""
    return folder / "analyses" / f"{analysis}.json"


def readable_stats(path: Path) -> bool:
    """Whether ``path`` holds an analysis's stats document: a JSON object with a list of
    ``conditions`` and of ``metrics`` (anything else, e.g. a damaged or edited file, is
    recomputed by ``--resume``)."""
    if not path.is_file():
        return False
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(document, dict) and isinstance(document.get("conditions"), list) and \
        isinstance(document.get("metrics"), list) and all(isinstance(m, dict) for m in document["metrics"])


def read_json(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text(encoding="utf-8"))


def read_study_metrics(folder: Path, study: str, participants: int,
                       kept: Mapping[int, pd.DataFrame] | None = None) -> pd.DataFrame:
    """The per-trial metrics of a study's first ``participants``, in participant order.

    ``kept`` holds parts this process has just written, by participant (the frames it wrote,
    equal to what reading them gives); the others are read from their files.
    """
    kept = kept or {}
    frames = [kept.get(i) for i in range(participants)]
    frames = [read_parquet(task_part(folder, study, i)) if f is None else f for i, f in enumerate(frames)]
    return pd.concat(frames, ignore_index=True)


def prepare_folder(folder: Path, description: dict[str, Any], resume: bool, force: bool) -> str:
    """Make ``folder`` ready for the batch; ``"new"`` or ``"resume"`` (same description required).

    The rule is the run folder's (:func:`nudgecli.store.prepare_mode`); a folder that is not empty
    but holds no batch is written into with ``force``, not cleared."""
    manifest, old = folder / BATCH_MANIFEST, None
    if manifest.is_file():
        try:
            old = json.loads(manifest.read_text(encoding="utf-8"))
        except ValueError as exc:
            raise RunFolderError(f"{manifest}: unreadable ({exc}); use --force to start again") from None
    held = None if old is None else f"{old.get('batch', {}).get('kind')}, {old.get('status')}"
    mode = prepare_mode(folder, held, resume, force, kind="batch")
    if old is not None and mode == "resume":
        if old.get("batch") != json.loads(json.dumps(description)):
            raise RunFolderError(f"{folder}: holds a different batch (experiment, design, seed, "
                                 "replications or plan); resume it with the same settings, or use --force")
        return "resume"
    if mode == "replace":
        for name in ("tasks", "analyses", FIGURES_DIR):
            shutil.rmtree(folder / name, ignore_errors=True)
        manifest.unlink()
    folder.mkdir(parents=True, exist_ok=True)
    return "new"
