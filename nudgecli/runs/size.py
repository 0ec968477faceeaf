"""The size guard: how much a command will compute, checked before any work is done.

``nudge simulate``, ``run``, ``replicate``, ``power`` and ``sweep`` count their trials from the
settings alone (constant memory: no task list, no graph) and refuse more than
:data:`MAX_TRIALS_WITHOUT_YES` unless ``--yes`` is given, so a typo such as
``--participants 100000000`` or ``-R 1000000000000`` fails at once with one line instead of
filling memory or running for years. They count steps too (:func:`check_study_size`): a trial
runs up to ``floor(time_limit_s * rate_hz)`` steps and a participant's are held in memory
together (about 1 KB a step), so a high ``study.rate_hz`` or a long ``study.time_limit_s`` is
refused by name before anything is cleared or written. ``plot-population`` counts its calibrations
(:data:`MAX_CALIBRATIONS_WITHOUT_YES`) and ``validate`` its queries
(:data:`MAX_QUERIES_WITHOUT_YES`) the same way; bootstrap resamples have a hard cap
(:data:`nudgecli.report.plans.MAX_RESAMPLES`).
"""

from __future__ import annotations

import contextlib
from contextvars import ContextVar
from dataclasses import dataclass
from typing import TYPE_CHECKING

from nudgecli.cores import available_cores, pool_workers
from nudgecli.errors import ConfigError, outermost_name
from nudgecli.runs.progress import format_duration

if TYPE_CHECKING:  # the command line names the override (override_named) without loading the config
    from nudgecli.config import ExperimentConfig
    from nudgecli.runs.batch import Batch

#: Simulated trials above which a command needs ``--yes`` (``confirm=True``).
MAX_TRIALS_WITHOUT_YES = 200_000
#: Steps one participant may run at most (every trial to its time limit) without ``--yes``: they
#: are held in memory together, about 1 KB a step (``nudge simulate smoke --set
#: study.rate_hz=2000``: 668,048 steps, 560 MB more than at 10 Hz).
MAX_STEPS_PER_PARTICIPANT_WITHOUT_YES = 1_000_000
#: Steps a command may run at most without ``--yes``: the trial limit at the paper's 1,200 steps a
#: trial (120 s at 10 Hz).
MAX_STEPS_WITHOUT_YES = MAX_TRIALS_WITHOUT_YES * 1_200
#: Simulated participants ``plot-population`` calibrates without ``--yes`` (about 0.15 s each).
MAX_CALIBRATIONS_WITHOUT_YES = 10_000
#: Queries (worlds x states x readings) ``validate`` runs without ``--yes`` (about 50 us each).
MAX_QUERIES_WITHOUT_YES = 10_000_000


#: The command line's override of the guard, which its refusals name by default.
YES_OPTION = "--yes"
#: The override the refusals name, as the front end that called spells it (``None``: :data:`YES_OPTION`).
_OVERRIDE: ContextVar[str | None] = ContextVar("size_override", default=None)


def override_named(name: str) -> contextlib.AbstractContextManager[None]:
    """Within the block, the guard's refusals tell the person to pass ``name`` (the Python API's
    ``confirm=True``), unless a caller outside named one first: the command line, which calls the
    API, names :data:`YES_OPTION` around it, and the person at the outermost front end is told
    (:func:`~nudgecli.errors.outermost_name`)."""
    return outermost_name(_OVERRIDE, name)


# --- a batch's estimate (its "about ..."): the guard itself counts trials and steps ---------------

# The estimate's cost model, calibrated on 2026-11-29, 2-core machine (shared), from the CPU time of
# the command and its workers (resource.getrusage(RUSAGE_CHILDREN), best of 3) and the wall time from
# the last task's progress line to the exit (the tail), on smoke and paper:
#   replicate smoke -R 1 --workers 1                 2.02 s CPU, tail 1.22 s (1 study, 2 tasks, 16 trials)
#   replicate smoke -R 1 --set study.participants=20 2.47 s CPU (18 tasks, 144 trials more: 25 ms a task)
#   replicate smoke -R 4 / -R 40                     2.26 / 7.92 s CPU, tail 1.18 / 2.9-5.0 s
#   replicate paper -R 1 --workers 1                 2.83 s CPU, tail 1.24 s (9 tasks, 432 trials)
#   replicate paper -R 1 --set study.participants=2  2.16 s CPU (7 tasks, 336 trials fewer: 96 ms a task)
#   replicate paper -R 2 / -R 4 --workers 2          4.44 / 6.68 s CPU, tail 1.33 / 1.31 s
#   power smoke --participants 2,4 / 2,3,4,5,6 -R 3  2.95 / 3.47 s CPU, tail 2.41 / 3.18 s
# A smoke participant (8 trials) costs 25 ms and a paper one (48 trials) 96 ms: 1.8 ms a trial and
# 11 ms a participant. A paper study costs 1.1 s more than its trials and participants (-R 2 to
# -R 4), a smoke one about 0.05 s: its plan, which solves every layout. The estimate for
# replicate smoke -R 4 is then 0.8 + 4 x 0.048 + 8 x 0.011 + 64 x 0.0018 + 4 x 0.025 + 1.3 +
# 4 x 0.04 = 2.75 s (measured 2.5-4.1 s of wall time).

#: Seconds a batch command spends whatever its size before its workers run trials: the interpreter,
#: the imports and a worker's first task's loading (smoke -R 1 is 2.02 s of CPU, 1.22 s of it the tail).
SECONDS_FIXED = 0.8
#: Seconds of one study's plan (its layouts drawn and solved): a fixed part and a part per layout a
#: participant runs (the trials a participant does). Every worker that runs a study's participants
#: builds its plan, so the workers do not share it.
SECONDS_PER_STUDY = 0.02
SECONDS_PER_LAYOUT = 0.0035
#: Seconds of one participant task besides its trials: its draw, calibration and metrics, and its part
#: file, which the command's own process writes (so the workers do not share it either).
SECONDS_PER_TASK = 0.011
#: CPU seconds per simulated trial (the trial loop alone is 1.72 ms on 2026-11-29), shared by the
#: workers that run at once. Was 0.0025 end to end, with the per-study and per-task costs in it.
SECONDS_PER_TRIAL = 0.0018
#: CPU seconds of one analysis (7 metrics, 2000 bootstrap resamples, a paper-scale study: 0.020-
#: 0.024 s on 2026-11-29, 2-core machine; 0.043-0.055 s on 2026-11-28), shared by the workers.
SECONDS_PER_ANALYSIS = 0.025
#: Wall seconds after the last task (:func:`tail_seconds`): the batch's tables and its 300 dpi figure,
#: plus each analysis's rows read and drawn (replicate smoke -R 4: 1.2-1.4 s; -R 40: 2.9 s).
TAIL_SECONDS = 1.3
TAIL_SECONDS_PER_ANALYSIS = 0.04
#: A power batch's tail besides: its table's Clopper-Pearson intervals (scipy.stats imported for
#: them, about 1.0 s) and the power figure, a line per participant count (power smoke --participants
#: 2,4 -R 3: 2.4-3.0 s of tail; 2,3,4,5,6: 3.2 s).
POWER_TAIL_SECONDS = 1.0
POWER_TAIL_SECONDS_PER_LEVEL = 0.1
#: Bytes on disk: a participant task's part file (about 7 KB of Parquet overhead and 60 bytes per
#: trial, measured on ``smoke``) and an analysis (its JSON document, about 14 KB).
BYTES_PER_TASK = 7_000
BYTES_PER_TRIAL = 60
BYTES_PER_ANALYSIS = 14_000


@dataclass(frozen=True)
class SizeEstimate:
    """How big a batch is, and its cost from the figures ``nudge bench`` measures (the constants above).

    ``workers`` is the pool the batch starts: the workers asked for, but no more than its
    tasks left to run (:func:`nudgecli.cores.pool_workers`); ``seconds`` shares the work among as
    many of them as there are ``cores`` to run them (:func:`nudgecli.cores.available_cores`). On a
    dask scheduler (``on_scheduler``), whose workers are counted only once it is connected, the
    seconds are those of one worker. ``tail_seconds``, part of ``seconds``, is the time after the
    last task (:func:`tail_seconds`: the tables and figures), which a progress line's ETA adds.
    """

    studies: int
    participant_tasks: int
    analyses: int
    trials: int
    seconds: float
    bytes: int
    workers: int
    cores: int = 1
    on_scheduler: bool = False
    power_levels: int = 0
    tail_seconds: float = 0.0

    def describe(self) -> str:
        if self.on_scheduler:
            where = "on one worker (less on the scheduler's workers)"
        elif self.workers > self.cores:  # told, not refused: more workers than cores is only slower
            where = f"on {self.workers} worker(s) sharing {self.cores} cores (more workers run no faster)"
        else:
            where = f"on {self.workers} worker(s)"
        return (f"{self.studies:,} studies, {self.participant_tasks:,} participant tasks + {self.analyses:,} "
                f"analyses, {self.trials:,} trials; about {format_duration(self.seconds)} {where} and "
                f"{self.bytes / 1e6:.1f} MB on disk")

    def on(self, scheduler: str | None) -> SizeEstimate:
        """This estimate where the batch runs: on this machine's pool (no ``scheduler``) as it is,
        else on a dask scheduler's workers, whose number is not known before it is connected."""
        if scheduler is None:
            return self
        return size_estimate(self.studies, self.participant_tasks, self.analyses, self.trials, 1,
                             on_scheduler=True, power_levels=self.power_levels)


def size_estimate(studies: int, participant_tasks: int, analyses: int, trials: int,
                  workers: int, tasks_left: int | None = None, *, on_scheduler: bool = False,
                  power_levels: int = 0) -> SizeEstimate:
    """A batch's :class:`SizeEstimate` from its counts (:func:`nudgecli.runs.batch.estimate_batch`)
    for ``workers`` asked for: the pool is no larger than the participant tasks it runs
    (``tasks_left`` where given: what a resumed batch can run at once, else all of them), and no
    more of its workers run at once than there are cores (on a scheduler: one worker's time).
    ``power_levels``: the participant counts of a power batch (0 for any other kind).

    The seconds are :data:`SECONDS_FIXED`, the studies' plans and the participant tasks' own work
    (not shared by the workers), the trials and analyses shared by the workers that run at once,
    then the tail (:func:`tail_seconds`).
    """
    pool = pool_workers(workers, participant_tasks if tasks_left is None else tasks_left)
    cores = available_cores()
    running = 1 if on_scheduler else min(pool, cores)
    layouts = trials / participant_tasks if participant_tasks else 0.0  # a participant's trials
    plans = studies * (SECONDS_PER_STUDY + layouts * SECONDS_PER_LAYOUT)
    serial = plans + participant_tasks * SECONDS_PER_TASK
    shared = trials * SECONDS_PER_TRIAL + analyses * SECONDS_PER_ANALYSIS
    tail = tail_seconds(analyses, power_levels)
    seconds = SECONDS_FIXED + serial + shared / running + tail
    size = participant_tasks * BYTES_PER_TASK + trials * BYTES_PER_TRIAL + analyses * BYTES_PER_ANALYSIS
    return SizeEstimate(studies, participant_tasks, analyses, trials, seconds, size, pool, cores,
                        on_scheduler, power_levels, tail)


def tail_seconds(analyses: int, power_levels: int = 0) -> float:
    """Seconds a batch command runs after its last task: its tables and figure, each analysis's rows,
    and for a power batch (``power_levels`` participant counts, else 0) its intervals and figure."""
    power = POWER_TAIL_SECONDS + power_levels * POWER_TAIL_SECONDS_PER_LEVEL if power_levels else 0.0
    return TAIL_SECONDS + analyses * TAIL_SECONDS_PER_ANALYSIS + power


def trials_per_participant(config: ExperimentConfig) -> int:
    """Trials each participant does (every layout of every condition once)."""
    return len(config.study.conditions) * config.study.trials_per_condition


def steps_per_trial(config: ExperimentConfig) -> int:
    """The most steps a trial runs: its time limit in steps, as the protocol counts them
    (``nudgecli.sim.protocol.ProtocolSettings.time_limit_steps``)."""
    return config.study.time_limit_steps


def check_study_size(config: ExperimentConfig, participants: int, confirm: bool, *,
                     fix: str = "fewer participants") -> None:
    """Refuse a study too large without ``confirm``: its trials, then its steps (trials run to
    their time limit), for one participant (memory) and for all of them (time and disk).

    Parameters
    ----------
    config
        The experiment (its design, ``study.rate_hz`` and ``study.time_limit_s``).
    participants
        Participants of one study.
    confirm
        ``--yes`` was given.
    fix
        What to reduce instead of the participants or trials.

    Raises
    ------
    ConfigError
        Above :data:`MAX_TRIALS_WITHOUT_YES` trials, :data:`MAX_STEPS_PER_PARTICIPANT_WITHOUT_YES`
        steps of one participant or :data:`MAX_STEPS_WITHOUT_YES` steps in all, without ``confirm``.
    """
    trials = trials_per_participant(config)
    check_size(participants * trials, confirm, fix=fix)
    check_steps(config, participants * trials * steps_per_trial(config), confirm, fix=fix)


def check_batch_size(batch: Batch, estimate: SizeEstimate, confirm: bool) -> None:
    """:func:`check_study_size` of a batch: its trials (``estimate``), then the steps of its
    studies, one per distinct experiment and replication (as :func:`nudgecli.runs.batch.build_graph`
    shares them), named by the experiment whose participants run the most."""
    from nudgecli.runs.batch import study_key  # batch imports this module

    fix = "fewer replications, participants or design points"
    check_size(estimate.trials, confirm, details=estimate.describe(), fix=fix)
    studies: dict[str, tuple[ExperimentConfig, int]] = {}  # one replication's: key -> (experiment, people)
    for point in batch.points:
        key = study_key(point.config, 0)
        known = studies.get(key, (point.config, 0))
        studies[key] = (known[0], max(known[1], max(point.participants)))
    steps = batch.replications * sum(n * trials_per_participant(c) * steps_per_trial(c)
                                     for c, n in studies.values())
    longest = max((config for config, _ in studies.values()),
                  key=lambda c: trials_per_participant(c) * steps_per_trial(c))
    check_steps(longest, steps, confirm, fix=fix)


def check_steps(config: ExperimentConfig, total_steps: int, confirm: bool, *,
                fix: str = "fewer participants") -> None:
    """Refuse, without ``confirm``, more steps for one participant of ``config`` than
    :data:`MAX_STEPS_PER_PARTICIPANT_WITHOUT_YES` (held in memory together), then more than
    :data:`MAX_STEPS_WITHOUT_YES` in all (``total_steps``: every trial of the command to its time
    limit); the message names ``config``'s rate and time limit."""
    trials = trials_per_participant(config)
    steps = trials * steps_per_trial(config)
    study = config.study
    why = (f"{trials} trials of up to {steps_per_trial(config):,} steps: study.time_limit_s = "
           f"{study.time_limit_s:g} s at study.rate_hz = {study.rate_hz:g}")
    slower = "a lower study.rate_hz or a shorter study.time_limit_s"
    check_size(steps, confirm, limit=MAX_STEPS_PER_PARTICIPANT_WITHOUT_YES,
               work="simulate up to {} steps for one participant",
               details=f"{why}; about 1 KB each in memory", fix=slower)
    check_size(total_steps, confirm, limit=MAX_STEPS_WITHOUT_YES,
               work="simulate up to {} steps", details=why, fix=f"{slower}, or {fix}")


def check_size(count: int, confirm: bool, *, limit: int | None = None, work: str = "simulate {} trials",
               details: str = "", fix: str = "fewer participants") -> None:
    """Refuse to do more than ``limit`` units of work without ``confirm``.

    Parameters
    ----------
    count
        How much the command would do (trials by default).
    confirm
        ``--yes`` was given (the message names it, or the override of :func:`override_named`).
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
        override = _OVERRIDE.get() or YES_OPTION
        raise ConfigError(f"this would {doing} (more than {most:,}{extra}); pass {override} to run it, "
                          f"or use {fix}")
