"""The analysis plan ``nudge run`` (:func:`nudgecli.api.simulate`, then
:func:`nudgecli.api.analyze_and_plot`) uses without ``--plan``, checked before anything is simulated."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from nudgecli.config import ExperimentConfig


def check_run_plan(experiment: ExperimentConfig) -> None:
    """Refuse a run of ``experiment`` whose default plan (the one named like the experiment, else
    ``paper``) cannot analyse its conditions, before it is simulated: otherwise the whole study is
    simulated and only its analysis fails (:func:`nudgecli.runs.study.checked_default_plan`).

    Raises
    ------
    ConfigError
        The plan's refusal and the fix: a plan for these conditions, given with ``--plan``.
    """
    from nudgecli.runs.study import checked_default_plan

    checked_default_plan(experiment)
