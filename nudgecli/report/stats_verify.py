"""Whether a ``stats.json``'s p-values and stars are those of the metrics ``nudge plot`` draws.

``metrics_checksum`` shows that the statistics were computed from the metrics present; the
p-values the figures' brackets and stars come from are then computed again from those metrics
(Kruskal-Wallis and the Conover pairs: milliseconds per metric), so a hand-edited p-value is
refused instead of drawn. The stars are then those of the p-values under the rule the document
records beside them (``star_rule``; a document of an older nudge records none, and its stars are
not checked).

The analysis of a ``nudge study`` folder records the trials the study had (``live_completed_trials``):
``plot`` refuses it once the study has recorded others (:func:`check_live_analysis_current`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from nudgecli.errors import DataError, RunFolderError, shell_words
from nudgecli.report.questionnaires import SCORES_CHECKSUM_KEY
from nudgecli.report.stats import conover_rows, kruskal_wallis, pair_stars
from nudgecli.run_folder_live import ANALYSED_TRIALS
from nudgecli.store import RunFolder

#: How far a recorded p-value may be from the one computed again (JSON's round trip keeps floats
#: exactly; this only allows another machine's last bits).
_TOLERANCE = 1e-9


def _same(recorded: Any, computed: float) -> bool:
    """Whether a recorded p-value (a number, or ``null`` for NaN) is ``computed``."""
    if recorded is None or (isinstance(recorded, float) and math.isnan(recorded)):
        return math.isnan(computed)
    if isinstance(recorded, bool) or not isinstance(recorded, int | float):
        return False
    return not math.isnan(computed) and math.isclose(float(recorded), computed, rel_tol=_TOLERANCE,
                                                     abs_tol=_TOLERANCE)


def _stars_follow_rule(entry: Mapping[str, Any]) -> bool:
    """Whether the entry's stars are those its (verified) p-values give under its ``star_rule``."""
    rule = entry.get("star_rule")
    if rule is None:
        return True  # a document of an older nudge: no rule recorded, its stars are not checked
    if not isinstance(rule, Mapping) or rule.get("comparison") not in ("<", "<="):
        return False
    kruskal_p = _p_value((entry.get("kruskal") or {}).get("p"))
    p_values = {_pair(r): _p_value(r.get("p")) for r in entry.get("conover") or []}
    return all((row.get("stars") or "") == pair_stars(p_values.get(_pair(row), math.nan), kruskal_p, rule)
               for row in entry.get("stars") or [])


def _pair(row: Mapping[str, Any]) -> frozenset[str]:
    return frozenset((str(row["a"]), str(row["b"])))


def _p_value(recorded: Any) -> float:
    """A recorded p-value (``null`` for NaN) as a float."""
    return math.nan if recorded is None else float(recorded)


def verify_p_values(stats: Mapping[str, Any], tables: Sequence[pd.DataFrame | None], where: str) -> None:
    """Refuse a ``stats.json`` (at ``where``) whose Kruskal-Wallis or Conover p-value of a metric is
    not the one its values in ``tables`` (the verified metrics, the verified questionnaire scores)
    give, or whose stars are not those of its p-values under its ``star_rule``: the document was
    edited.

    Raises
    ------
    DataError
        Names the metric and says to run ``nudge analyze`` again.
    """
    for entry in stats.get("metrics") or []:
        rows = entry.get("conover") if isinstance(entry, Mapping) else None
        if not rows or not isinstance(rows, list):
            continue
        metric = str(entry.get("metric"))
        data = next((t for t in tables if t is not None and metric in t.columns), None)
        if data is None:
            continue  # (a metric not present: verify_metrics refused it)
        try:
            # the conditions tested: those with values of it (not one it is not applicable to)
            conditions = [c for c in dict.fromkeys(str(c) for row in rows for c in (row["a"], row["b"]))
                          if (entry.get("n") or {}).get(c)]
            tested = len(conditions) > 1
            computed = conover_rows(data, metric, conditions, p_adjust=str(entry.get("p_adjust"))) \
                if tested else []
            pairs = {frozenset((r["a"], r["b"])): r["p"] for r in computed}
            omnibus = kruskal_wallis(data, metric, conditions)["p"] if tested else math.nan
            same = _same((entry.get("kruskal") or {}).get("p"), omnibus) and \
                all(_same(row.get("p"), pairs.get(_pair(row), math.nan))
                    for row in rows) and _stars_follow_rule(entry)
        except (KeyError, TypeError, ValueError, AttributeError):
            same = False
        if not same:
            raise DataError(f"{where}: the p-values or stars of {metric} are not those of its metrics (the "
                            "file was edited); run `nudge analyze` on the source again before plotting")


def check_live_analysis_current(stats: Mapping[str, Any], run: RunFolder, where: str) -> None:
    """Refuse the analysis (``stats``, at ``where``) of a ``nudge study`` folder ``run`` whose
    manifest now lists other trials than the analysis saw (its ``live_completed_trials``): its
    metrics would be drawn beside the trials recorded since. An analysis that records none (of an
    older nudge), and any other run, are drawn as before.

    Raises
    ------
    RunFolderError
        Naming the ``nudge analyze`` command that analyses the study again.
    """
    if ANALYSED_TRIALS not in stats or not run.is_run():
        return
    now = RunFolder.analysed_progress(run.manifest_to_read()).get(ANALYSED_TRIALS)
    recorded = stats[ANALYSED_TRIALS]
    if now is None or recorded == now:
        return
    try:  # each participant's trials then among those now (a record edited by hand: not grown)
        grown = all(set(trials) <= set(now.get(key, [])) for key, trials in recorded.items())
    except (AttributeError, TypeError):
        grown = False
    what = "has recorded more trials since it was analysed" if grown else \
        "lists other trials than when it was analysed"
    with_scores = " with the --questionnaires it was analysed with" if SCORES_CHECKSUM_KEY in stats else ""
    raise RunFolderError(f"{where}: the study {what}; run "
                         f"`{shell_words(['nudge', 'analyze', str(run.path)])}` again{with_scores}")
