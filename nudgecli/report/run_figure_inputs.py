"""What ``nudge plot`` reads of a run folder beside its analysis: the trials, the layouts, the trial
Fig. 5 and the trajectory show and its participant's steps, and a path-world run's time limit.

A run is read through its manifest, as every reader of a run reads it: the parts it promises
(:meth:`~nudgecli.store.RunFolder.check_complete`, each checked against the SHA-256 it recorded)
and the experiment it records (:func:`~nudgecli.run_folder_config.run_experiment`), never a
``config.toml`` edited since (it is not vouched for).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.report.figures import TrialLayout
from nudgecli.report.trial_selection import choose_figure5_trial, trial_groups
from nudgecli.report.trial_steps import TrialKey
from nudgecli.run_folder_config import run_experiment
from nudgecli.store import RunFolder

#: The step-log columns the default rule of Fig. 5's trial reads (every participant's).
FIGURE5_CHOICE_COLUMNS = ("participant", "trial", "step", "turn", "belief", "event")


def layouts_by_trial(trials: pd.DataFrame, layouts: pd.DataFrame) -> dict[TrialKey, TrialLayout]:
    """``(participant, trial) -> TrialLayout`` through ``trials.layout``; the true goal is the trial's own.

    Parameters
    ----------
    trials
        The trials table (``participant``, ``trial``, ``layout``, ``true_goal``).
    layouts
        ``layouts.parquet`` (``layout``, ``goal_poses``, ``start_pose``).
    """
    poses = {int(row.layout): (np.asarray(row.goal_poses, dtype=float).reshape(-1, 3),
                               np.asarray(row.start_pose, dtype=float))
             for row in layouts.itertuples()}
    out = {}
    for p, t, lay, goal in zip(trials["participant"], trials["trial"], trials["layout"], trials["true_goal"],
                               strict=True):
        goals, start = poses[int(lay)]
        out[(int(p), int(t))] = TrialLayout(goals, start, int(goal))
    return out


def representative_trial(trials: pd.DataFrame) -> TrialKey:
    """The default trial to draw in the path world: the successful trial (else any) whose duration is
    the median one's (the lowest ``(participant, trial)`` among equals)."""
    pool = trials[trials["success"].astype(bool)] if trials["success"].astype(bool).any() else trials
    pool = pool.sort_values(["participant", "trial"], kind="stable")
    durations = pool["duration_s"].to_numpy(float)
    median = float(np.sort(durations)[(len(durations) - 1) // 2])
    row = pool.iloc[int(np.flatnonzero(durations == median)[0])]
    return int(row["participant"]), int(row["trial"])


def run_fields(run: RunFolder, trial: TrialKey | None) -> dict[str, Any]:
    """:class:`~nudgecli.report.plotting.FigureInputs`' fields of a run (none of a table; a live
    study: its trials recorded so far): trials, layouts, the trial shown (``trial``, else the default
    rule's) and its steps, a path-world run's time limit as its manifest records it; of a run without
    its step logs, why (``steps_missing``)."""
    manifest = run.read_manifest() if run.is_run() else None
    if manifest is None or not (run.has_completed_participant() or run.is_live(manifest)):
        why = f"{run.path} holds no step logs (no steps/part-*.parquet; a run kept without them)"
        return {} if manifest is None else {"steps_missing": why}
    if "participants" in manifest:
        run.check_complete()  # a damaged run named with the command that restores it, as analyze names it
    trials = run.read_trials()
    layout_table = run.read_layouts()
    fields: dict[str, Any] = {"trials": trials}
    if "waypoints" in layout_table.columns:  # the CIAA path world
        fields.update(path_layouts=layout_table, time_limit_s=float(run_experiment(run).study.time_limit_s))
        chosen = trial if trial is not None else representative_trial(trials)
    else:
        fields["layouts"] = layouts_by_trial(trials, layout_table)
        chosen = trial if trial is not None else choose_figure5_trial(_ChoiceSteps(run, trials), trials)
    known = chosen[0] in set(trials["participant"].astype(int))  # else nothing read: the caller names it
    fields["steps"] = run.read_table("steps", participants=[chosen[0]]) if known else pd.DataFrame()
    fields["trial"] = chosen
    return fields


class _ChoiceSteps(Mapping[TrialKey, pd.DataFrame]):
    """A run's trials -> their steps in :data:`FIGURE5_CHOICE_COLUMNS`, read a participant's part at
    a time as the default rule asks for the trials in order (300 paper participants' belief lists
    read at once were 1.1 GB). The trials are the trials table's of participants with a steps part."""

    def __init__(self, run: RunFolder, trials: pd.DataFrame) -> None:
        self.run = run
        keys = list(zip(trials["participant"].astype(int), trials["trial"].astype(int), strict=True))
        with_steps = {p for p in {int(p) for p, _ in keys} if run.part_path("steps", p).is_file()}
        self.trial_keys = [(int(p), int(t)) for p, t in keys if p in with_steps]
        self.participant: int | None = None
        self.steps: dict[TrialKey, pd.DataFrame] = {}

    def __getitem__(self, key: TrialKey) -> pd.DataFrame:
        if key[0] != self.participant:
            part = self.run.read_table("steps", FIGURE5_CHOICE_COLUMNS, participants=[key[0]])
            self.steps, self.participant = dict(trial_groups(part)), key[0]
        if key not in self.steps:  # a trial its participant's part lacks has no steps to measure
            return pd.DataFrame(columns=list(FIGURE5_CHOICE_COLUMNS))
        return self.steps[key]

    def __iter__(self) -> Iterator[TrialKey]:
        return iter(self.trial_keys)

    def __len__(self) -> int:
        return len(self.trial_keys)


__all__ = ["FIGURE5_CHOICE_COLUMNS", "layouts_by_trial", "representative_trial", "run_fields"]
