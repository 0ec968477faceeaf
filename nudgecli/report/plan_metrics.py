"""Which metrics an analysis takes under its plan, and how ``summary.md`` names the plan.

- :func:`select_metrics`: the ``--metric`` names among the metrics available (a known metric the
  plan's ``[metrics] include`` leaves out is refused with the plans that include it);
- :func:`check_filters`: a plan's ``[filters]`` name metrics;
- :func:`summary_plan_name`: ``summary.md``'s ``- plan:``, a preset's name or the plan's file as
  seen from the analysis folder (as its ``source`` is), never the file's ``name`` key, which a
  copied preset keeps;
- :func:`table_include_note`: a table's columns are all analysed, those the plan's ``include``
  leaves out too, said in a ``Note:`` where a plan was given;
- :func:`run_definitions_line`: ``summary.md``'s ``- definitions:`` line of a run folder analysed
  under a plan file (a table's says what could be applied:
  :mod:`nudgecli.report.table_definitions`). A preset's definitions are its name's; none is
  written for it, so ``results/paper/summary.md`` is as it was.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from nudgecli.errors import ConfigError, DataError, did_you_mean
from nudgecli.report.metric_names import METRIC_NAMES
from nudgecli.report.plans import AnalysisPlan, left_out_metric_message
from nudgecli.report.table_definitions import PLAN_DEFINED
from nudgecli.report.table_read import analysed_inputs


def select_metrics(requested: Sequence[str] | None, available: Sequence[str],
                   plan: AnalysisPlan) -> list[str]:
    """The metrics to analyse: ``requested`` (``--metric``, each once) or every one ``available``.

    Raises
    ------
    DataError
        A requested metric is not available: a known one the plan leaves out (with the plans that
        include it), else an unknown one (with a suggestion).
    """
    if not requested:
        return list(available)
    selected: list[str] = []
    for name in requested:
        if name in METRIC_NAMES and name not in available and name not in plan.metrics.include:
            raise DataError(left_out_metric_message(plan, name))  # known, but this plan leaves it out
        if name not in available:
            raise DataError(f"unknown metric {name!r}{did_you_mean(name, available)}; available: "
                            f"{', '.join(available)}")
        if name not in selected:
            selected.append(name)
    return selected


def check_filters(plan: AnalysisPlan, available: Sequence[str]) -> None:
    """Refuse a plan whose ``[filters]`` name a metric that is neither known nor available."""
    known = set(METRIC_NAMES) | set(available)
    for name in plan.filters:
        if name not in known:
            raise ConfigError(f"{plan.label}: [filters] names unknown metric {name!r}"
                              f"{did_you_mean(name, sorted(known))}")


def table_include_note(plan: AnalysisPlan, analysed: Sequence[str]) -> str | None:
    """Why a metrics table's analysis takes known metrics ``plan``'s ``[metrics] include`` leaves
    out: a table's numeric columns are all metrics, which ``--metric`` chooses among (the include
    list chooses what is computed from a run folder; the paper plan, a table's default, leaves out
    the baselines' metrics a run's ``metrics.csv`` holds). ``None`` where it leaves out none of
    ``analysed``."""
    left_out = [m for m in analysed if m in METRIC_NAMES and m not in plan.metrics.include]
    if not left_out:
        return None
    return (f"plan {plan.label}'s [metrics] include leaves out {', '.join(left_out)}, which this table's "
            "analysis takes as they are (every numeric column of a table is a metric); choose a "
            "table's metrics with --metric NAME")


def summary_plan_name(plan: AnalysisPlan, out_dir: Path) -> str:
    """How ``summary.md`` written to ``out_dir`` names ``plan``: a preset's name (or a plan built in
    code, by its ``name``), or the file it was read from as seen from ``out_dir`` (no machine's path)."""
    return analysed_inputs(out_dir, plan.label, None)[0] or plan.label


def run_definitions_line(plan: AnalysisPlan, analysed: Sequence[str]) -> str | None:
    """``summary.md``'s ``- definitions:`` line of a run folder analysed under a plan file: the
    plan's ``[metrics]`` definitions of the analysed metrics, with which they were computed;
    ``None`` for a preset or a plan built in code (named by its name) or where no analysed metric
    has a definition to choose."""
    if plan.file is None:
        return None
    chosen = [m for m in PLAN_DEFINED if m in analysed]
    if not chosen:
        return None
    names = ", ".join(f"{m} = {getattr(plan.metrics, PLAN_DEFINED[m])!r}" for m in chosen)
    return f"computed from the run's trials and steps under the plan's {names}"


__all__ = ["check_filters", "run_definitions_line", "select_metrics", "summary_plan_name",
           "table_include_note"]
