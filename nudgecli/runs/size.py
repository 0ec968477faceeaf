"""The size guard: how much a command will compute, checked before any work is done.

``nudge simulate``, ``run``, ``replicate``, ``power`` and ``sweep`` count their trials from the
settings alone (constant memory: no task list, no graph) and refuse more than
:data:`MAX_TRIALS_WITHOUT_YES` unless ``--yes`` is given, so a typo such as
``--participants 100000000`` or ``-R 1000000000000`` fails at once with one line instead of
filling memory or running for years. ``plot-population`` counts its calibrations
(:data:`MAX_CALIBRATIONS_WITHOUT_YES`) and ``validate`` its queries
(:data:`MAX_QUERIES_WITHOUT_YES`) the same way; bootstrap resamples have a hard cap
(:data:`nudgecli.report.plans.MAX_RESAMPLES`).
"""

from __future__ import annotations

from nudgecli.config import ExperimentConfig
from nudgecli.errors import ConfigError

#: Simulated trials above which a command needs ``--yes`` (``confirm=True``).
MAX_TRIALS_WITHOUT_YES = 200_000
#: Simulated participants ``plot-population`` calibrates without ``--yes`` (about 0.15 s each).
MAX_CALIBRATIONS_WITHOUT_YES = 10_000
#: Queries (worlds x states x readings) ``validate`` runs without ``--yes`` (about 50 us each).
MAX_QUERIES_WITHOUT_YES = 10_000_000


def trials_per_participant(config: ExperimentConfig) -> int:
    """Trials each participant does (every layout of every condition once)."""
    return len(config.study.conditions) * config.study.trials_per_condition


def check_size(count: int, confirm: bool, *, limit: int | None = None, work: str = "simulate {} trials",
               details: str = "", fix: str = "fewer participants") -> None:
    """Refuse to do more than ``limit`` units of work without ``confirm``.

    Parameters
    ----------
    count
        How much the command would do (trials by default).
    confirm
        ``--yes`` was given.
    limit
        The most without ``confirm`` [default: :data:`MAX_TRIALS_WITHOUT_YES`].
    work
        What it would do, with ``{}`` for the count, e.g. "calibrate {} simulated participants".
    details
        The size in other words (tasks, time, disk), added to the message.
    fix
        What to reduce instead, e.g. "fewer replications, participants or design points".

    Raises
    ------
    ConfigError
        ``count`` is above the limit and ``confirm`` is false.
    """
    most = MAX_TRIALS_WITHOUT_YES if limit is None else limit
    if count > most and not confirm:
        extra = f"; {details}" if details else ""
        doing = work.format(f"{count:,}")
        raise ConfigError(f"this would {doing} (more than {most:,}{extra}); pass --yes to run it, "
                          f"or use {fix}")
