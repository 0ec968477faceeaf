"""``nudge plot``: read what a run (or an analysed metrics table) holds and draw its figures.

The drawing itself is :mod:`nudgecli.report.figures`; this module only finds the inputs:
``metrics.csv`` and ``stats.json`` (from ``nudge analyze``), the step log, the trial table, the
layouts (mapped to each participant's trials) and ``questionnaires.csv`` when present.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.errors import ConfigError, RunFolderError
from nudgecli.report import figures
from nudgecli.store import RunFolder

FORMATS = ("png", "pdf", "svg")


def parse_formats(text: str) -> tuple[str, ...]:
    """``"png,pdf"`` -> ``("png", "pdf")``, or a ``ConfigError`` naming the bad format."""
    chosen = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    bad = [f for f in chosen if f not in FORMATS]
    if bad or not chosen:
        raise ConfigError(f"--formats {text!r}: choose from {', '.join(FORMATS)} (comma-separated)")
    return chosen


def parse_trial(text: str | None) -> tuple[int, int] | None:
    """``"PARTICIPANT:TRIAL"`` -> ``(participant, trial)``."""
    if text is None:
        return None
    try:
        participant, trial = (int(v) for v in text.split(":"))
    except ValueError:
        raise ConfigError(f"--trial {text!r}: expected PARTICIPANT:TRIAL, e.g. --trial 0:12") from None
    return participant, trial


def layouts_by_trial(trials: pd.DataFrame, layouts: pd.DataFrame) -> dict[tuple[int, int], Any]:
    """``(participant, trial) -> (goal_poses (G, 3), start_pose (3,))`` through ``trials.layout``."""
    poses = {int(row.layout): (np.asarray(row.goal_poses, dtype=float).reshape(-1, 3),
                               np.asarray(row.start_pose, dtype=float))
             for row in layouts.itertuples()}
    return {(int(p), int(t)): poses[int(lay)]
            for p, t, lay in zip(trials["participant"], trials["trial"], trials["layout"], strict=True)}


def plot_folder(source: str | Path, out: str | Path | None = None, formats: Sequence[str] = ("png", "pdf"),
                trial: tuple[int, int] | None = None) -> list[Path]:
    """Draw every figure the folder's data allow; return the files written.

    Parameters
    ----------
    source
        A run folder analysed with ``nudge analyze``, or the ``--out`` folder of an analysed
        metrics table (box plots only).
    out
        Where the figures go [default: ``SOURCE/figures``].
    formats
        File formats.
    trial
        ``(participant, trial)`` for Fig. 5 and the trajectory [default: chosen by
        :func:`nudgecli.report.figures.choose_figure5_trial`].
    """
    folder = Path(source)
    run = RunFolder(folder)
    if not folder.is_dir():
        what = "a file, not a folder" if folder.exists() else "no such folder"
        raise RunFolderError(f"{folder}: {what}; give a run folder made by `nudge simulate`")
    from nudgecli.report.analysis import analysed_metrics_path, read_analysed_metrics

    metrics_path = analysed_metrics_path(folder)
    if not run.is_run() and metrics_path is None:
        raise RunFolderError(f"{folder}: not a run folder (no manifest.json) and no metrics.csv; "
                             "run `nudge simulate` and `nudge analyze` first")
    if metrics_path is None or not (folder / "stats.json").is_file():
        raise RunFolderError(f"{folder}: no metrics yet; run `nudge analyze {folder}` first")
    metrics = read_analysed_metrics(metrics_path)
    stats = json.loads((folder / "stats.json").read_text(encoding="utf-8"))
    steps = trials = layouts = None
    if run.is_run() and run.completed_participants():
        trials = run.read_trials()
        steps = run.read_steps()
        layouts = layouts_by_trial(trials, run.read_layouts())
    if trial is not None and trials is not None:
        known = set(zip(trials["participant"], trials["trial"], strict=True))
        if trial not in known:
            last_participant, last_trial = trials["participant"].max(), trials["trial"].max()
            raise ConfigError(f"--trial {trial[0]}:{trial[1]}: no such trial in {folder} "
                              f"(participants 0-{last_participant}, trials 0-{last_trial})")
    questionnaires = None
    if (folder / "questionnaires.csv").is_file():
        questionnaires = pd.read_csv(folder / "questionnaires.csv")
    target = Path(out) if out is not None else folder / "figures"
    return figures.plot_run(metrics, stats, steps, layouts, target, formats, trial, trials=trials,
                            questionnaires=questionnaires, questionnaire_stats=stats)
