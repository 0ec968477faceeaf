"""The tasks of a batch that run in a worker, and the worker's cache of study plans.

A participant task simulates one participant of a study with the study's plan (its layouts and
their solved goal MDPs, :class:`~nudgecli.sim.study.StudyPlan`), which each worker keeps in a
small cache keyed by what the plan depends on (:func:`layout_key`), so a plan is built once per
worker, not once per task, and computes the participant's step-based metrics with numpy
(:mod:`nudgecli.report.step_metrics`): a worker that runs only participant tasks never imports
pandas, and the process that writes the part makes the metrics table and the part's bytes
(:meth:`ParticipantMetrics.part`), except on :data:`PART_BUILDING_WORKERS` pool workers or more,
whose results come faster than one process builds parts. An analysis task computes a
replication's statistics. The graph that submits them is :mod:`nudgecli.runs.batch`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import pickle
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from nudgecli.config import ExperimentConfig
from nudgecli.report.step_metrics import (
    INPUT_STEP_COLUMNS,
    METRIC_STEP_COLUMNS,
    STEP_DEFINITIONS,
    STEP_TRIAL_COLUMNS,
    step_metric_arrays,
)
from nudgecli.runs.executors import HELD_AFFINITIES
from nudgecli.runs.solved_layouts import build_plan, remember_plan
from nudgecli.runs.study_tasks import (
    drew_from_global_rng,
    global_rng_warning,
    simulate_watched,
    tune_allocator,
)
from nudgecli.sim.policy_registry import not_applicable_of, run_conditions
from nudgecli.sim.study import ParticipantColumns, StudyPlan, trials_frame
from nudgecli.sim.twins import Twin

if TYPE_CHECKING:  # pandas and the statistics (scipy.stats, scikit-posthocs) load where used
    from pathlib import Path

    import pandas as pd

    from nudgecli.report.plans import AnalysisPlan
    from nudgecli.runs.batch import Graph, Study  # batch imports this module

#: Study plans (layouts + solved MDPs, about 20 MB at the paper's 48 layouts) a worker keeps; the
#: process pool's dispatch mirrors this cache.
PLAN_CACHE_SIZE = HELD_AFFINITIES

#: Sections that neither draw nor solve layouts (the study's layouts depend on ``[study]`` and
#: the seed, their MDPs on ``[model]``); every other section, present or future, is in the key.
_NOT_LAYOUT_SECTIONS = ("experiment", "interface", "inference", "disambiguation", "assistance", "population",
                        "calibration")


def layout_key(config: ExperimentConfig, seed: int) -> str:
    """What a study's layouts and their solved MDPs depend on, as a short hash."""
    data = config.model_dump(mode="json", exclude=set(_NOT_LAYOUT_SECTIONS))
    data["study"].pop("participants", None)
    text = f"{sorted(data.items())!r}\nseed = {seed}"
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]


_PLANS: OrderedDict[str, StudyPlan] = OrderedDict()
_PLANS_LOCK = threading.Lock()


def cached_plan(config: ExperimentConfig, seed: int) -> StudyPlan:
    """The study plan of ``(config, seed)`` from this process's cache, built on a miss.

    Keyed by :func:`layout_key`: studies that differ only in settings that do not touch the
    layouts (e.g. ``inference.kappa`` in a sweep) share one plan. Holds :data:`PLAN_CACHE_SIZE`
    plans at most (least recently used dropped), so a worker's memory does not grow with the batch.
    """
    key = layout_key(config, seed)
    with _PLANS_LOCK:  # a dask worker may run tasks in several threads
        plan = _PLANS.get(key)
        if plan is None:  # the layouts a sweep's other points drew are solved already
            plan = build_plan(config, seed)
        _remember_plan(key, plan)
    return dataclasses.replace(plan, config=config)


def _remember_plan(key: str, plan: StudyPlan) -> None:
    """Make ``plan`` the cache's most recent (dropping the oldest beyond ``PLAN_CACHE_SIZE``); the
    caller holds ``_PLANS_LOCK``."""
    _PLANS[key] = plan
    _PLANS.move_to_end(key)
    while len(_PLANS) > PLAN_CACHE_SIZE:
        _PLANS.popitem(last=False)


def install_plan(plan: StudyPlan) -> None:
    """Put a study's plan, built elsewhere, into this process's cache (:func:`cached_plan` finds it)."""
    with _PLANS_LOCK:
        _remember_plan(layout_key(plan.config, plan.seed), plan)


def install_plan_of_files(config: ExperimentConfig, seed: int, paths: Sequence[str]) -> None:
    """:func:`install_plan` of the study's plan assembled here from its solved layouts, pickled in
    the files ``paths`` in chunk order (:func:`~nudgecli.runs.study.solve_layout_chunk_into`)."""
    chunks = []
    for path in paths:
        with open(path, "rb") as handle:
            chunks.append(pickle.load(handle))
    plan = StudyPlan.assemble(config, seed, chunks)
    remember_plan(plan)
    install_plan(plan)


@dataclasses.dataclass
class ParticipantMetrics:
    """One participant's per-trial metrics as a participant task returns them (plain values and
    numpy arrays, so the worker needs no pandas).

    Attributes
    ----------
    trials
        The participant's trial table, one row (dict) per trial.
    values
        The step-based metrics of :func:`~nudgecli.report.step_metrics.step_metric_arrays`,
        ``(T,)`` each, in the trials' order.
    definitions
        The analysis plan's metric definitions (:func:`metric_definitions`).
    drew_from_global_rng
        Whether the participant's trials drew from numpy's or Python's global random generator
        (:func:`~nudgecli.runs.study_tasks.simulate_watched`, the run's check): the batch warns once.
    """

    trials: list[dict[str, Any]]
    values: dict[str, np.ndarray]
    definitions: dict[str, str]
    #: the metrics table and its Parquet bytes, once :meth:`part` has built them
    built: tuple[pd.DataFrame, bytes] | None = None
    drew_from_global_rng: bool = False

    def part(self) -> tuple[pd.DataFrame, bytes]:
        """The metrics table (:meth:`frame`) and the bytes of its part
        (:func:`~nudgecli.runs.batch_folder.parquet_bytes`), built once, where first asked for."""
        if self.built is None:
            from nudgecli.runs.batch_folder import parquet_bytes

            frame = self.frame()
            self.built = (frame, parquet_bytes(frame))
        return self.built

    def frame(self) -> pd.DataFrame:
        """The metrics table (:func:`nudgecli.report.metrics.metrics_frame`): one row per trial,
        ``participant, condition, block, trial`` and the metrics."""
        from nudgecli.report.metrics import metrics_frame

        from_trials: dict[str, Any] = {key: self.definitions[key] for key in ("success", "completion_time")}
        return metrics_frame(trials_frame(self.trials), self.values, **from_trials)


def metric_definitions(analysis: AnalysisPlan) -> dict[str, str]:
    """The analysis plan's metric definitions (``engagement``, ``strength``, ``mode_switches``,
    ``success``, ``completion_time``) as plain text, what a participant task is given."""
    return analysis.metrics.model_dump(exclude={"include"})


#: The step-log columns a participant task keeps: those its metrics read (the rest is not formatted
#: at all, a third of the log's columns are kept).
TASK_STEP_COLUMNS = METRIC_STEP_COLUMNS + INPUT_STEP_COLUMNS


def simulate_task_participant(plan: StudyPlan, index: int) -> ParticipantColumns:
    """A participant task's trial loop: the participant's trials and the step-log columns its
    metrics read (:data:`TASK_STEP_COLUMNS`), as plain columns (no frames), watched for draws from
    a global random generator as a run's participant is
    (:func:`~nudgecli.runs.study_tasks.simulate_watched`)."""
    return simulate_watched(plan, index, step_log_columns=TASK_STEP_COLUMNS)


def participant_metrics(plan: StudyPlan, index: int, definitions: Mapping[str, str]) -> ParticipantMetrics:
    """One participant's per-trial metrics under the metric definitions (:func:`metric_definitions`).

    Returns
    -------
    ParticipantMetrics
        Its :meth:`~ParticipantMetrics.frame` is :func:`nudgecli.report.metrics.trial_metrics` of the
        participant's trial table and step log.
    """
    result = simulate_task_participant(plan, index)
    keys = {name: [row[name] for row in result.trials] for name in STEP_TRIAL_COLUMNS}
    chosen: dict[str, Any] = {name: definitions[name] for name in STEP_DEFINITIONS}
    values = step_metric_arrays(keys, result.steps, **chosen)
    return ParticipantMetrics(result.trials, values, dict(definitions),
                              drew_from_global_rng=drew_from_global_rng(result))


#: From this many pool workers on, participant tasks build their parts in their workers
#: (:func:`run_participant_task`'s ``build_part``): a part takes the writing process 10-15 ms
#: (its table, then Parquet), a ``smoke`` participant a worker about 45 ms, so from about four
#: workers on one process could not keep up. Below it, workers never import pandas and pyarrow
#: (about 75 MB each).
PART_BUILDING_WORKERS = 4


def run_participant_task(config: ExperimentConfig, seed: int, index: int, definitions: Mapping[str, str],
                         people: Sequence[Twin] = (), build_part: bool = False) -> ParticipantMetrics:
    """A participant task, with this worker's cached plan of the study (``people``: the batch's
    twins of real people, :attr:`~nudgecli.sim.study.StudyPlan.people`); ``build_part``: its part
    built here (:meth:`ParticipantMetrics.part`), and only that sent back."""
    tune_allocator()
    plan = cached_plan(config, seed)
    metrics = participant_metrics(dataclasses.replace(plan, people=tuple(people)) if people else plan, index,
                                  definitions)
    if not build_part:
        return metrics
    return ParticipantMetrics([], {}, metrics.definitions, metrics.part(), metrics.drew_from_global_rng)


def warn_global_rng(warned: bool, result: ParticipantMetrics, config: ExperimentConfig, where: object,
                    log: Callable[[str], None] | None) -> bool:
    """Tell ``log`` once, as a run does, that a participant task of the batch ``where`` drew from a
    global random generator (``result``'s :attr:`~ParticipantMetrics.drew_from_global_rng`; the
    run's line, :func:`~nudgecli.runs.study_tasks.global_rng_warning`, of its study's ``config``);
    whether it has been told (``warned``: by an earlier task). The batch's tables stay as computed."""
    if warned or log is None or not result.drew_from_global_rng:
        return warned
    log(global_rng_warning(config, where))
    return True


def run_quietly(prepare: Callable[[], object]) -> None:
    """Run a batch command's ``prepare`` (:func:`~nudgecli.runs.batch.run_batch`) beside its workers;
    a failure is the command's to meet after the batch."""
    with contextlib.suppress(Exception):
        prepare()


def run_analysis_task(metrics: pd.DataFrame, analysis: AnalysisPlan, names: Sequence[str],
                      study_conditions: Sequence[str] = (),
                      not_applicable: Mapping[str, Sequence[str]] | None = None) -> dict[str, Any]:
    """An analysis task: the replication's statistics of the metrics ``names``
    (:func:`~nudgecli.report.replication.analyse_replication`; the study's conditions give their
    order after the plan's; ``not_applicable``: metric -> the conditions left out of its tests).
    A replication's metrics may be split over several tasks, whose documents
    :func:`merge_analysis_chunks` joins."""
    tune_allocator()
    from nudgecli.report.replication import analyse_replication

    return analyse_replication(metrics, analysis, names, study_conditions, not_applicable or {})


def import_analysis_modules() -> None:
    """Import what :func:`run_analysis_task` uses (pandas, pyarrow, scipy.special and the report's
    modules: about half a second), so that a process's first analysis does not pay for it."""
    import scipy.special  # noqa: F401

    import nudgecli.report.analysis
    import nudgecli.report.replication  # noqa: F401


def analysis_design(config: ExperimentConfig,
                    analysis: AnalysisPlan) -> tuple[tuple[str, ...], dict[str, tuple[str, ...]]]:
    """A study's conditions and, per metric, those for which it is not applicable under the plan
    (constant by its policies, or success defined by an inferred goal a condition never infers):
    what :func:`run_analysis_task` takes after the metrics' names, so that a replication's document
    is the ``stats.json`` ``nudge analyze`` writes for the study's run folder under the plan."""
    return run_conditions(config), not_applicable_of(config, success=analysis.metrics.success)


def merge_analysis_chunks(documents: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The stats document of a replication from its chunks' documents (:func:`run_analysis_task`
    of one metrics table and plan, each with a consecutive chunk of the metrics), in chunk order.

    Each metric is analysed on its own (:func:`~nudgecli.report.stats_document.analyze_metric`),
    so this is the document one task of all the metrics makes, key for key (``filters``, what the
    plan's filters removed, joined in chunk order and kept only where some chunk has them).

    Raises
    ------
    ValueError
        No documents, or documents of different conditions (not of one table and plan).
    """
    if not documents:
        raise ValueError("no stats documents to merge")
    conditions = list(documents[0]["conditions"])
    if any(list(d["conditions"]) != conditions for d in documents):
        raise ValueError("stats documents of different conditions cannot be merged")
    merged: dict[str, Any] = {"conditions": conditions,
                              "metrics": [entry for d in documents for entry in d["metrics"]]}
    removed = [count for d in documents for count in d.get("filters", ())]
    return {**merged, "filters": removed} if removed else merged


def read_analyses(folder: Path, keys: Sequence[str], label: str,
                  log: Callable[[str], None] | None) -> dict[str, dict[str, Any]]:
    """The batch's analyses (key -> stats document, in ``keys``' order) read back from ``folder``,
    and one ``Note:`` to ``log`` of what the plan ``label``'s filters left out of them
    (:func:`~nudgecli.report.plan_filters.replications_left_out_line`), as ``nudge analyze`` says
    it of a run; no note where they removed no value."""
    from nudgecli.report.plan_filters import replications_left_out_line
    from nudgecli.runs.batch_folder import analysis_part, read_json

    stats = {key: read_json(analysis_part(folder, key)) for key in keys}
    line = replications_left_out_line(list(stats.values()), label)
    if line is not None and log is not None:
        log(f"Note: {line}")
    return stats


def shares_plan(study: Study, unfinished: int, studies: int, workers: int) -> bool:
    """Whether the study's layouts are solved in layout tasks and its plan sent to every worker.

    Only where several workers would otherwise each solve all of them: a grid-world study (the
    CIAA world has no MDPs to solve) with at least as many unfinished participant tasks as there
    are workers, in a batch of fewer ``studies`` (with work left) than workers, so that the
    study's tasks spread over most of them. With as many studies as workers, each study stays
    on one or two workers (the pool sends a study's tasks to the workers that hold its plan),
    and sending every plan to every worker would cost more than it saves.
    """
    return workers > 1 and unfinished >= workers and studies < workers and study.config.world.kind != "ciaa"


@dataclasses.dataclass
class TasksLeft:
    """What the batch in a folder has left to run: its ``record`` of the parts
    (:class:`~nudgecli.runs.part_record.PartRecord`, whose word on each part is the one kept),
    study key -> its participants without a part the record vouches for (``remaining``), and the
    analyses without one (``waiting``)."""

    record: Any
    remaining: dict[str, set[int]]
    waiting: list[Any]

    def at_once(self) -> int:
        """The tasks that can run at once: the participant tasks left and the analyses left whose
        participants are all done (the others wait for them); what a resumed batch's pool is sized
        by, so analyses left alone still spread over it."""
        return sum(map(len, self.remaining.values())) + sum(
            not any(i in self.remaining[a.study] for i in range(a.participants)) for a in self.waiting)


def tasks_left(folder: Path, graph: Graph) -> TasksLeft:
    """What the batch in ``folder`` has left of ``graph``'s tasks: each part checked once, by one
    record (:meth:`~nudgecli.runs.part_record.PartRecord.vouches`)."""
    from nudgecli.runs.batch_folder import PartRecord, analysis_part, readable_stats, task_part

    record = PartRecord(folder)
    remaining = {study.key: {i for i in range(study.participants)
                             if not record.vouches(task_part(folder, study.key, i))}
                 for study in graph.studies.values()}
    waiting = [a for a in graph.analyses.values()
               if not record.vouches(analysis_part(folder, a.key), readable_stats)]
    return TasksLeft(record, remaining, waiting)
