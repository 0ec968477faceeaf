"""Whether a ``stats.json``'s p-values are those of the metrics ``nudge plot`` draws.

``metrics_checksum`` shows that the statistics were computed from the metrics present; the
p-values the figures' brackets and stars come from are then computed again from those metrics
(Kruskal-Wallis and the Conover pairs: milliseconds per metric), so a hand-edited p-value is
refused instead of drawn.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from nudgecli.errors import DataError
from nudgecli.report.stats import conover_rows, kruskal_wallis

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


def verify_p_values(stats: Mapping[str, Any], tables: Sequence[pd.DataFrame | None], where: str) -> None:
    """Refuse a ``stats.json`` (at ``where``) whose Kruskal-Wallis or Conover p-value of a metric is
    not the one its values in ``tables`` (the verified metrics, the verified questionnaire scores)
    give: the document was edited.

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
                all(_same(row.get("p"), pairs.get(frozenset((str(row["a"]), str(row["b"]))), math.nan))
                    for row in rows)
        except (KeyError, TypeError, ValueError, AttributeError):
            same = False
        if not same:
            raise DataError(f"{where}: the p-values of {metric} are not those of its metrics (the file was "
                            "edited); run `nudge analyze` on the source again before plotting")
