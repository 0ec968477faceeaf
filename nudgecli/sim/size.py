"""The size guard: how many trials a command will simulate, checked before any work is done.

``nudge simulate``, ``run``, ``replicate``, ``power`` and ``sweep`` count their trials from the
settings alone (constant memory: no task list, no graph) and refuse more than
:data:`MAX_TRIALS_WITHOUT_YES` unless ``--yes`` is given, so a typo such as
``--participants 100000000`` or ``-R 1000000000000`` fails at once with one line instead of
filling memory or running for years.
"""

from __future__ import annotations

from nudgecli.config import ExperimentConfig
from nudgecli.errors import ConfigError

#: Simulated trials above which a command needs ``--yes`` (``confirm=True``).
MAX_TRIALS_WITHOUT_YES = 200_000


def trials_per_participant(config: ExperimentConfig) -> int:
    """Trials each participant does (every layout of every condition once)."""
    return len(config.study.conditions) * config.study.trials_per_condition


def check_size(trials: int, confirm: bool, *, details: str = "", fix: str = "fewer participants") -> None:
    """Refuse to simulate more than :data:`MAX_TRIALS_WITHOUT_YES` trials without ``confirm``.

    Parameters
    ----------
    trials
        How many trials the command would simulate.
    confirm
        ``--yes`` was given.
    details
        The size in other words (tasks, time, disk), added to the message.
    fix
        What to reduce instead, e.g. "fewer replications, participants or design points".

    Raises
    ------
    ConfigError
        ``trials`` is above the limit and ``confirm`` is false.
    """
    if trials > MAX_TRIALS_WITHOUT_YES and not confirm:
        extra = f"; {details}" if details else ""
        raise ConfigError(f"this would simulate {trials:,} trials (more than {MAX_TRIALS_WITHOUT_YES:,}"
                          f"{extra}); pass --yes to run it, or use {fix}")
