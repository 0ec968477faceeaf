"""Analysis plans: which metrics, which definitions, which filters and which test settings.

A plan is a TOML file. Two presets ship with the package (``analysis/paper.toml`` and
``analysis/study-code.toml``, installed as ``nudgecli.presets.analysis``); any other plan is a
path to a TOML file. Layout::

    name = "paper"
    description = "..."
    conditions = ["disambiguation", "control"]   # order after the paper's two (a pair's "a" is the earlier)

    [metrics]
    include = ["assistance_engagement", ...]      # default: all known metrics; each once
    engagement = "per_step"                       # or "per_turn" (study software)
    strength = "per_step"                         # or "per_turn"
    mode_switches = "any_turn"                    # or "human_turn"
    success = "reached_goal"                      # or "last_inferred_goal"
    completion_time = "successful_trials"         # or "all_trials" (study software)

    [filters]                                     # metric = inclusive maximum, a finite number;
                                                  # larger -> missing (not of success or wrong_goal,
                                                  # true or false; not negative for a known metric)
    mode_switches = 10

    [stats]
    kruskal_alpha = 0.05
    posthoc = "conover"
    p_adjust = "holm"
    star_thresholds = [0.05, 0.01, 0.001]
    star_comparison = "<"                         # or "<="
    participant_aggregate = "median"

    [bootstrap]
    resamples = 2000
    level = 0.95
    seed = 0

    [questionnaires.labels]                      # axis labels of questionnaire items (figures)
    Q3 = "Q3: figured out my goal more easily"

Every definition's default is the paper's (the value shown above; the other is the study
software's): a plan of the study software's definitions states each (``analysis/study-code.toml``).
Conditions are ordered the same way everywhere: the paper's ``disambiguation`` and ``control``
first, then the plan's ``conditions``, then the rest by name; of a pair, ``a`` is the earlier
(differences are a - b).

Unknown keys are refused with a "did you mean" suggestion naming the file and the key; a
condition the data lacks, where the plan is meant for that data, by :func:`check_plan_conditions`.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, PrivateAttr, ValidationError, field_validator

from nudgecli.config_base import Section
from nudgecli.config_files import format_validation_error, list_presets, read_toml, resolve_preset
from nudgecli.errors import ConfigError, did_you_mean
from nudgecli.report.comparison_options import ComparisonOptions
from nudgecli.report.metric_names import METRIC_NAMES, NON_NEGATIVE_METRICS, TRUE_FALSE_METRICS

#: The most bootstrap resamples (a plan's, ``analyze --bootstrap``, ``compare --resamples``): each
#: resample holds a row of indices per participant in memory, so more would exhaust it.
MAX_RESAMPLES = 1_000_000

#: The fewest bootstrap resamples of an analysis (a plan's ``[bootstrap] resamples``, ``analyze
#: --bootstrap``): the interval's ends are percentiles of the resampled differences, and with
#: fewer resamples they are a few draws' values (one resample: the interval is a single point).
MIN_RESAMPLES = 100


def check_resamples(resamples: int | None, option: str, minimum: int = 0) -> None:
    """Refuse bootstrap resamples given as ``option`` above :data:`MAX_RESAMPLES` or below
    ``minimum`` (:data:`MIN_RESAMPLES` for an analysis), before any work.

    Raises
    ------
    ConfigError
        ``resamples`` is outside the bounds.
    """
    if resamples is not None and resamples > MAX_RESAMPLES:
        raise ConfigError(f"{option} {resamples:,}: at most {MAX_RESAMPLES:,} bootstrap resamples; "
                          "2000 is the usual number")
    if resamples is not None and resamples < minimum:
        raise ConfigError(f"{option} {resamples:,}: at least {minimum:,} bootstrap resamples (an interval "
                          "of fewer is a few resamples' values), as in a plan's [bootstrap] resamples; "
                          "2000 is the usual number")

#: The p-value adjustments ``statsmodels.stats.multitest.multipletests`` accepts, plus ``none``.
P_ADJUST_METHODS = (
    "none", "bonferroni", "sidak", "holm-sidak", "holm", "simes-hochberg", "hommel",
    "fdr_bh", "fdr_by", "fdr_tsbh", "fdr_tsbky",
)



class _Section(Section):
    """A plan's table: an experiment section's rules (unknown keys refused, numbers as written:
    ``kruskal_alpha = "0.05"`` or ``seed = true`` is refused, not read as 0.05 or 1)."""


class MetricDefinitions(_Section):
    """Which metrics to compute from a run folder, and which definition of each.

    ``engagement``/``strength``: ``per_step`` is the paper (fraction of / mean over the human's
    turn steps), ``per_turn`` the study software (mean over human turns of the per-turn value,
    0 strength for turns without assistance). ``mode_switches``: ``any_turn`` counts every human
    mode switch, ``human_turn`` only those inside the human's turns (the study software).
    ``success``: ``reached_goal`` is the simulator's verdict, ``last_inferred_goal`` the study
    software's proxy (the last inferred goal is the true goal). ``completion_time``:
    ``successful_trials`` follows the paper ("total time taken to complete the task
    successfully"; other trials have no value; success judged by the simulator's verdict under
    either ``success``, so a trial timed out is no completion), ``all_trials`` the study software.
    """

    include: tuple[str, ...] = METRIC_NAMES
    engagement: Literal["per_step", "per_turn"] = "per_step"
    strength: Literal["per_step", "per_turn"] = "per_step"
    mode_switches: Literal["any_turn", "human_turn"] = "any_turn"
    success: Literal["reached_goal", "last_inferred_goal"] = "reached_goal"
    completion_time: Literal["all_trials", "successful_trials"] = "successful_trials"

    @field_validator("include")
    @classmethod
    def _known_metrics(cls, names: tuple[str, ...]) -> tuple[str, ...]:
        for name in names:
            if name not in METRIC_NAMES:
                raise ValueError(f"unknown metric {name!r}{did_you_mean(name, METRIC_NAMES)}; "
                                 f"known: {', '.join(METRIC_NAMES)}")
        if not names:
            raise ValueError("list at least one metric")
        # a metric listed twice would be tested twice: stats.json would hold it twice, and replicate and
        # power would count its replications twice (power's interval too narrow)
        repeated = sorted({name for name in names if names.count(name) > 1}, key=names.index)
        if repeated:
            raise ValueError(f"{', '.join(map(repr, repeated))} listed more than once; list each metric once")
        return names


class StatsSettings(_Section):
    """Settings of the trial-level and participant-level tests.

    ``star_comparison`` is also the comparison of the Kruskal-Wallis gate (``p < alpha`` in the
    paper, ``p <= alpha`` in the study software).
    """

    kruskal_alpha: float = Field(default=0.05, gt=0, lt=1)
    posthoc: Literal["conover"] = "conover"
    p_adjust: Literal[P_ADJUST_METHODS] = "holm"  # type: ignore[valid-type]
    star_thresholds: tuple[float, ...] = (0.05, 0.01, 0.001)
    star_comparison: Literal["<", "<="] = "<"
    participant_aggregate: Literal["median", "mean"] = "median"

    @field_validator("star_thresholds")
    @classmethod
    def _decreasing(cls, thresholds: tuple[float, ...]) -> tuple[float, ...]:
        if not thresholds or any(not 0 < t < 1 for t in thresholds):
            raise ValueError("give one or more thresholds between 0 and 1, e.g. [0.05, 0.01, 0.001]")
        if any(b >= a for a, b in itertools.pairwise(thresholds)):
            raise ValueError("thresholds must be strictly decreasing, e.g. [0.05, 0.01, 0.001]")
        return thresholds


class BootstrapSettings(_Section):
    """The cluster bootstrap of the median difference (participants are resampled)."""

    resamples: int = Field(default=2000, ge=MIN_RESAMPLES, le=MAX_RESAMPLES)
    level: float = Field(default=0.95, gt=0, lt=1)
    seed: int = Field(default=0, ge=0)


class QuestionnaireSettings(_Section):
    """How questionnaire items are named in the figures.

    ``labels`` maps an item (``Q3``, or its ``likert_q3`` column; matched case-insensitively
    without the ``likert_``/``tlx_`` prefix) to its axis label: the study's wording of the
    statement, which belongs to the study, not to the drawing code.
    """

    labels: dict[str, str] = Field(default_factory=dict)


class AnalysisPlan(_Section):
    """A complete analysis plan (see the module docstring for the file layout)."""

    name: str = "custom"
    description: str = ""
    conditions: tuple[str, ...] = ()
    metrics: MetricDefinitions = Field(default_factory=MetricDefinitions)
    # finite: a comparison with nan is false for every value, so a nan maximum filtered nothing, unsaid
    filters: dict[str, Annotated[float, Field(allow_inf_nan=False)]] = Field(default_factory=dict)
    stats: StatsSettings = Field(default_factory=StatsSettings)
    bootstrap: BootstrapSettings = Field(default_factory=BootstrapSettings)
    questionnaires: QuestionnaireSettings = Field(default_factory=QuestionnaireSettings)
    # the TOML file :func:`load_plan` read it from (absolute); None for a preset or a plan made in code
    _file: Path | None = PrivateAttr(default=None)

    @field_validator("filters")
    @classmethod
    def _filters_that_can_leave_out_outliers(cls, filters: dict[str, float]) -> dict[str, float]:
        # a maximum that can only empty a metric (or keep it whole) is a mistake, not a filter: it
        # was applied and the analysis went on with no test of the metric
        for name, maximum in filters.items():
            if name in TRUE_FALSE_METRICS:
                raise ValueError(f"{name} = {maximum:g}: {name} is true or false, so a maximum keeps every "
                                 "value or leaves out every true one; remove the filter")
            if name in NON_NEGATIVE_METRICS and maximum < 0:
                raise ValueError(f"{name} = {maximum:g}: {name} is never negative, so a negative maximum "
                                 "leaves out every value; give a maximum of 0 or more")
        return filters

    def __eq__(self, other: object) -> bool:
        # a plan is its settings: two files holding the same plan are the same plan
        if not isinstance(other, AnalysisPlan):
            return NotImplemented
        return self.__dict__ == other.__dict__

    @property
    def file(self) -> Path | None:
        """The TOML file the plan was read from (absolute); ``None`` for a preset or a plan made in code."""
        return self._file

    @property
    def label(self) -> str:
        """How every message and a run's manifest name the plan: the absolute path of the file it
        was read from (its ``name`` may be a copied preset's), else its ``name`` (a preset's)."""
        return self.name if self._file is None else str(self._file)

    def comparison_options(self, seed: int | None = None) -> ComparisonOptions:
        """The plan's ``[stats]`` and ``[bootstrap]`` as :class:`~nudgecli.report.stats.ComparisonOptions`.

        Parameters
        ----------
        seed
            Bootstrap seed; default the plan's.
        """
        return ComparisonOptions(
            kruskal_alpha=self.stats.kruskal_alpha,
            p_adjust=self.stats.p_adjust,
            star_thresholds=tuple(self.stats.star_thresholds),
            star_comparison=self.stats.star_comparison,
            participant_aggregate=self.stats.participant_aggregate,
            bootstrap_resamples=self.bootstrap.resamples,
            bootstrap_level=self.bootstrap.level,
            seed=self.bootstrap.seed if seed is None else seed,
        )


def plan_argument(plan: AnalysisPlan) -> str | None:
    """How ``--plan`` names ``plan``: a preset's name, or the path of the file it was read from
    (:attr:`AnalysisPlan.label`); ``None`` for a plan built in code (``AnalysisPlan(...)``, or a
    preset's or a file's plan changed in code), whose settings no preset and no file holds, so
    that no ``--plan`` can give it again: it is given again from Python.
    """
    try:
        named = load_plan(plan.label) if plan.label in plan_names() or plan._file is not None else None
    except ConfigError:  # its file gone or broken since it was read: it names this plan no longer
        return None
    return plan.label if named == plan else None


def check_plan_conditions(plan: AnalysisPlan, plan_label: str, present: Sequence[str], source: str) -> None:
    """Refuse a plan whose ``conditions`` name one the data lacks where the data holds one the
    plan does not name, so that the plan's order would be ignored silently.

    A missing condition is refused when an unnamed one of the data resembles it (the same but
    for case or spaces, or a close spelling: :func:`~nudgecli.errors.did_you_mean`), or when the
    plan names some of the data's conditions (it is this data's plan, but its list is wrong). A
    plan naming conditions the data lacks is used where it names all the data's conditions (a
    plan over more conditions than one run holds: the CIAA plan over its one-condition run) or
    none of them and none alike (another study's plan, e.g. ``paper`` for a table of other
    conditions: its order applies to nothing there).

    Parameters
    ----------
    plan
        The analysis plan.
    plan_label
        How to name the plan (its file, or a preset's name).
    present
        The data's conditions.
    source
        How to name the data (a run folder or a table).

    Raises
    ------
    ConfigError
        A missing condition as above: the plan, the condition, the data's conditions and a
        suggestion.
    """
    present = sorted({str(c) for c in present})
    listed = [str(c) for c in plan.conditions]
    unnamed = [c for c in present if c not in listed]
    if not unnamed:
        return
    alike = {" ".join(c.split()).casefold(): c for c in unnamed}
    shares = any(c in present for c in listed)
    for name in listed:
        if name in present:
            continue
        twin = alike.get(" ".join(name.split()).casefold())
        hint = f" (did you mean {twin!r}?)" if twin is not None else did_you_mean(name, unnamed)
        if hint or shares:
            raise ConfigError(f"{plan_label}: conditions names {name!r}, which {source} does not hold{hint}; "
                              f"its conditions: {', '.join(present)}; list them in the plan as the data "
                              "spells them")


def plan_from_dict(data: dict[str, Any], source: str = "<plan>") -> AnalysisPlan:
    """Validate a plan given as a dict (as read from TOML).

    Parameters
    ----------
    data
        The plan's keys and tables.
    source
        Where the plan came from, named in error messages.

    Returns
    -------
    AnalysisPlan

    Raises
    ------
    ConfigError
        An unknown key (with a suggestion), a wrong type or a value out of range.
    """
    try:
        return AnalysisPlan.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source, AnalysisPlan)) from None


def plan_names() -> list[str]:
    """The names of the shipped analysis plans (e.g. ``["paper", "study-code"]``)."""
    return list(list_presets("analysis"))


def load_plan(plan: str | Path | AnalysisPlan) -> AnalysisPlan:
    """Load and validate an analysis plan.

    The preset lookup is :func:`nudgecli.config_files.resolve_preset` (the one shared with experiment
    files), the TOML reading :func:`nudgecli.config_files.read_toml`.

    Parameters
    ----------
    plan
        A preset name (``paper``, ``study-code``), a path to a TOML file, or a plan (returned as is).

    Returns
    -------
    AnalysisPlan
        Read from a file, it remembers the file (:attr:`AnalysisPlan.label`, which messages name).

    Raises
    ------
    ConfigError
        Unknown preset, missing file, TOML syntax error, unknown key, wrong type or range.
    """
    if isinstance(plan, AnalysisPlan):
        return plan
    path = resolve_preset(str(plan), "analysis")
    data = read_toml(path)
    data.setdefault("name", path.stem)
    loaded = plan_from_dict(data, source=str(path))
    if list_presets("analysis").get(str(plan)) != path:  # a file, not a preset: messages name the file
        loaded._file = path.resolve()
    return loaded


def left_out_metric_message(plan: AnalysisPlan, metric: str) -> str:
    """Why ``plan`` gives no ``metric``, a known metric its ``[metrics] include`` leaves out, and the
    fix: the shipped plans that include it (``--plan baselines``), else adding it to the plan's list."""
    including = [name for name in plan_names()
                 if name != plan.label and metric in load_plan(name).metrics.include]
    fix = (f"analyse with a plan that includes it: {' or '.join(f'--plan {name}' for name in including)}"
           if including else f"add {metric!r} to the [metrics] include of a copy of the plan")
    return f"metric {metric!r} is not in plan {plan.label}'s [metrics] include; {fix}"
