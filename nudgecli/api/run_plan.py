"""The analysis plan ``nudge run`` (:func:`nudgecli.api.simulate`, then
:func:`nudgecli.api.analyze_and_plot`) uses without ``--plan``, checked before anything is simulated."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from nudgecli.config import ExperimentConfig


def check_run_plan(experiment: ExperimentConfig, resumed: Path | None = None) -> None:
    """Refuse a run of ``experiment`` whose default plan (the one named like the experiment, else
    ``paper``) cannot analyse its conditions, before it is simulated: otherwise the whole study is
    simulated and only its analysis fails (:func:`nudgecli.runs.study.checked_default_plan`). A run
    ``resumed`` (``--resume`` into that folder) whose manifest records its plan is analysed with that
    one (:func:`nudgecli.api.analyze_and_plot`), not checked here.

    Raises
    ------
    ConfigError
        The plan's refusal and the fix: a plan for these conditions, given with ``--plan``.
    """
    from nudgecli.runs.study import checked_default_plan

    if resumed is not None and _recorded_plan(resumed) is not None:
        return
    checked_default_plan(experiment)


def _recorded_plan(folder: Path) -> object:
    """The ``plan`` the manifest in ``folder`` records (``None``: none, or no readable manifest)."""
    from nudgecli.errors import NudgeError
    from nudgecli.store import RunFolder

    run = RunFolder(folder)
    try:
        return run.read_manifest().get("plan") if run.is_run() else None
    except NudgeError:
        return None
