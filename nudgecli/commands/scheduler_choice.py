"""Which dask scheduler a command runs on: ``--scheduler`` as given; else the address in
``DASK_SCHEDULER_ADDRESS``, unless ``--workers`` is given (a flag on the command line wins over
the environment, which a researcher may have set for another tool and no longer sees).

An address from the environment is checked here, so that a refusal names the variable: the
option the person did not type would only confuse.
"""

from __future__ import annotations

import click
from click.core import ParameterSource

from nudgecli.commands.common import info
from nudgecli.errors import ConfigError

#: The environment variable ``--scheduler`` falls back to (dask's own name for it).
SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"


def chosen_scheduler(ctx: click.Context, scheduler: str | None) -> str | None:
    """The scheduler address the command of ``ctx`` runs on, or None for local workers.

    Parameters
    ----------
    ctx
        The command's context: its ``--workers`` and ``--scheduler`` and where each came from.
    scheduler
        The ``--scheduler`` value as click read it (from the command line or :data:`SCHEDULER_ENV`).

    Raises
    ------
    ConfigError
        An address from :data:`SCHEDULER_ENV` (and no ``--workers``) where no dask scheduler
        answers, or dask.distributed is not installed: the message names the variable.
    """
    if scheduler is None or ctx.get_parameter_source("scheduler") is not ParameterSource.ENVIRONMENT:
        return scheduler
    if ctx.get_parameter_source("workers") is ParameterSource.COMMANDLINE:
        info(f"Note: --workers given: running on local workers, not on the dask scheduler {SCHEDULER_ENV} "
             f"names ({scheduler})")
        return None
    check_environment_scheduler(scheduler)
    return scheduler


def check_environment_scheduler(address: str) -> None:
    """Refuse the address of :data:`SCHEDULER_ENV` where no dask scheduler answers, naming the variable.

    The same probe as ``--scheduler``'s (:func:`nudgecli.runs.study.probe_scheduler`, within
    :data:`~nudgecli.runs.study.SCHEDULER_TIMEOUT_S` seconds).

    Raises
    ------
    ConfigError
        dask.distributed is not installed, or no dask scheduler answers at ``address``.
    """
    unset = f"unset {SCHEDULER_ENV} (or give --workers N) to run on local workers"
    try:
        import distributed  # noqa: F401 - the probe's and the client's package
    except ImportError:  # pragma: no cover - depends on the optional extra
        raise ConfigError(f"{SCHEDULER_ENV}={address} (from the environment) needs dask.distributed: "
                          f"pip install 'nudgecli[cluster]', or {unset}") from None
    from nudgecli.runs import study

    problem = study.probe_scheduler(address, study.SCHEDULER_TIMEOUT_S)
    if problem is not None:
        raise ConfigError(f"{SCHEDULER_ENV}={address} (from the environment): {problem}; give the address of "
                          f"a running dask scheduler, e.g. tcp://host:8786, or {unset}")
