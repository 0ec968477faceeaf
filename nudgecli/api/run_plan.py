"""The analysis plan ``nudge run`` (:func:`nudgecli.api.simulate`, then
:func:`nudgecli.api.analyze_and_plot`) uses without ``--plan``, checked before anything is simulated."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from nudgecli.config import ExperimentConfig


def check_run_plan(experiment: ExperimentConfig, resumed: Path | None = None) -> None:
    """Refuse a run of ``experiment`` whose plan cannot analyse its conditions, before it is
    simulated: otherwise the whole study is simulated and only its analysis fails. The plan is the
    default one (named like the experiment, else ``paper``:
    :func:`nudgecli.runs.study.checked_default_plan`); for a run ``resumed`` (``--resume`` into that
    folder) the one its analysis will take, as :func:`nudgecli.api.analyze_and_plot` does: the plan
    its manifest records (:func:`~nudgecli.report.recorded_plans.plan_of_source`; ``nudge simulate``
    records the default one), else the default.

    Raises
    ------
    ConfigError
        The plan's refusal and the fix: a plan for these conditions, given with ``--plan``; or a
        recorded plan file's copy that was edited or lost.
    """
    from nudgecli.config_files import resolve_plan
    from nudgecli.errors import ConfigError
    from nudgecli.run_folder_names import MANIFEST
    from nudgecli.runs.study import checked_default_plan, checked_plan, own_plan_advice

    default = resolve_plan(None, experiment=experiment.experiment.name, world=experiment.world.kind)
    plan = _resumed_plan(resumed) if resumed is not None else None
    if plan is None or plan == default:
        checked_default_plan(experiment)
        return
    try:
        checked_plan(plan, [experiment])
    except ConfigError as exc:
        advice = own_plan_advice(experiment.study.conditions)
        raise ConfigError(f"{exc} (it is the plan {resumed} records in its {MANIFEST}, which its analysis "
                          f"keeps); nothing more was simulated: {advice}") from None


def _resumed_plan(folder: Path) -> str | None:
    """The plan the analysis of the run in ``folder`` takes without ``--plan`` (``None``: no run there,
    or a manifest that cannot be read, which the resume refuses itself, naming what is wrong)."""
    from nudgecli.errors import RunFolderError
    from nudgecli.report.recorded_plans import plan_of_source
    from nudgecli.store import RunFolder

    if not RunFolder(folder).is_run():
        return None
    try:  # a recorded plan file's copy, edited or lost, is refused here (ConfigError) as its analysis would
        return plan_of_source(folder)
    except RunFolderError:
        return None
