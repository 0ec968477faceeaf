"""A pair of conditions no replication tested (a condition left out of the metric's tests) reads
"not tested" in the replication summaries, never a rate or power of 0; a pair only some
replications tested keeps its rates and power over all replications, an untested one counted as
not significant, and says how many tested it (docs/batches.md)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nudgecli.report import replication
from nudgecli.report.replication import clopper_pearson, power_table, smallest_n, summarise

BASELINE = Path(__file__).parents[1] / "results" / "baselines" / "replicate"
RATES = ("trial_a_higher", "trial_a_lower", "participant_a_higher", "participant_a_lower")


def _row(participants: int, replication: int, b: str, p: float, significant: bool,
         median_b: float = 1.0) -> dict:
    """A :func:`replication_rows` row of metric ``m``, pair ``x - b``: every p ``p``, both levels
    significant (a < b) as ``significant`` says."""
    return {"point": 0, "replication": replication, "seed": replication, "participants": participants,
            "metric": "m", "a": "x", "b": b, "median_a": 2.0, "median_b": median_b, "difference": 1.0,
            "kruskal_p": p, "conover_p": p, "participant_p": p, "effect_size_name": "rank_biserial",
            "effect_size": -0.5, "trial_significant": significant, "trial_direction": -1,
            "participant_significant": significant, "participant_direction": -1}


def _table() -> pd.DataFrame:
    """Four replications at 6 and 9 participants: ``x - y`` tested in each (significant in 2 of 4,
    then 4 of 4); ``x - z`` in none (z left out of m: its median and every p NaN)."""
    rows = []
    for n, hits in ((6, 2), (9, 4)):
        for r in range(4):
            rows.append(_row(n, r, "y", 0.01 if r < hits else 0.5, r < hits))
            rows.append(_row(n, r, "z", math.nan, False, median_b=math.nan))
    return pd.DataFrame(rows)


def test_a_pair_no_replication_tested_has_no_rate_no_power_and_no_smallest_n() -> None:
    rows = _table()
    summary = summarise(rows).set_index(["participants", "b"])
    for n in (6, 9):
        assert all(np.isnan(summary.loc[(n, "z"), rate]) for rate in RATES)
        assert summary.loc[(n, "z"), "tested"] == 0 and summary.loc[(n, "z"), "replications"] == 4
    power = power_table(rows).set_index(["participants", "b", "level"])
    for key in [(n, "z", level) for n in (6, 9) for level in ("trial", "participant")]:
        assert np.isnan(power.loc[key, ["power", "low", "high"]].astype(float)).all(), key
        assert power.loc[key, "tested"] == 0
    smallest = smallest_n(power_table(rows), target=0.8).set_index(["b", "level"])
    for level in ("trial", "participant"):
        assert smallest.loc[("z", level), "participants"] is None
        assert smallest.loc[("z", level), "status"] == replication.NOT_TESTED
        assert smallest.loc[("y", level), "participants"] == 9
        assert smallest.loc[("y", level), "status"] == replication.REACHED
    assert "m,x,z,trial,,not tested\n" in smallest.reset_index()[["metric", "a", "b", "level", "participants",
                                                                 "status"]].to_csv(index=False)
    # a table without the medians: a pair whose p-values are all NaN was not tested
    assert not replication.pair_tested(rows.drop(columns=["median_a", "median_b"]).query("b == 'z'")).any()


def test_a_pair_tested_in_some_replications_counts_the_others_as_not_significant() -> None:
    # replication 3 could not test x - y (y without values there): power stays over all 4, 2 of 4,
    # and tested says 3
    rows = pd.DataFrame([_row(6, r, "y", p, p < 0.05, median_b=1.0 if r < 3 else math.nan)
                         for r, p in enumerate([0.01, 0.02, 0.5, math.nan])])
    (summary,) = summarise(rows).to_dict("records")
    assert (summary["replications"], summary["tested"]) == (4, 3)
    assert (summary["trial_a_lower"], summary["participant_a_lower"]) == (0.5, 0.5)
    assert (summary["trial_a_higher"], summary["participant_a_higher"]) == (0.0, 0.0)
    power = power_table(rows, {"m": -1})
    assert power["tested"].tolist() == [3, 3] and power["power"].tolist() == [0.5, 0.5]
    assert (power["low"].iloc[0], power["high"].iloc[0]) == pytest.approx(clopper_pearson(2, 4))
    assert smallest_n(power, target=0.8)["status"].tolist() == [replication.NOT_REACHED] * 2


def test_a_pair_whose_values_were_all_equal_was_tested_and_not_significant() -> None:
    # every p NaN beside both medians: the tests compared the conditions and found one value
    rows = pd.DataFrame([_row(6, r, "y", math.nan, False, median_b=2.0) for r in range(3)])
    (summary,) = summarise(rows).to_dict("records")
    assert all(summary[rate] == 0.0 for rate in RATES) and summary["tested"] == 3
    assert replication.pair_tested(rows).all()
    assert power_table(rows)["power"].tolist() == [0.0, 0.0]


def test_the_shipped_summary_changes_only_in_the_pairs_no_replication_tested() -> None:
    # the shipped replications summarised (three metrics: n/a pairs, a participant test undefined in
    # every replication, plain pairs): every tested pair's numbers are those shipped before the
    # pairs not tested were told apart; the untested pairs (n/a) have no rates
    metrics = ["assistance_engagement", "human_effort", "success"]
    rows = pd.read_csv(BASELINE / "replications.csv")
    rows = rows[rows["metric"].isin(metrics)].assign(point=0)
    summary = summarise(rows).drop(columns=["point"])
    shipped = pd.read_csv(BASELINE / "summary.csv")
    shipped = shipped[shipped["metric"].isin(metrics)].reset_index(drop=True)
    untested = summary["effect_size_name"] == "none"  # a pair holding a condition n/a to the metric
    assert untested.sum() == 6 + 15 and summary.loc[untested, list(RATES)].isna().all().all()
    assert (summary.loc[untested, "tested"] == 0).all() and (summary.loc[~untested, "tested"] == 10).all()
    before = {("assistance_engagement", "disambiguation", "control"): (0.8, 0.0, 0.8, 0.0),
              ("success", "disambiguation", "teleoperation"): (0.0, 1.0, 0.0, 0.0),
              ("success", "disambiguation", "hindsight"): (0.8, 0.0, 0.0, 0.0)}
    keyed = summary.set_index(["metric", "a", "b"])
    for pair, rates in before.items():
        assert tuple(keyed.loc[pair, list(RATES)]) == rates, pair
    pd.testing.assert_frame_equal(summary[~untested].reset_index(drop=True),
                                  shipped[~untested].reset_index(drop=True), check_dtype=False)


def test_the_batch_notes_say_which_pairs_were_not_tested() -> None:
    rows = pd.concat([_table(), pd.DataFrame([_row(6, 4, "y", math.nan, False, median_b=math.nan)])])
    notes = replication.untested_notes(summarise(rows))
    assert len(notes) == 2
    assert notes[0].startswith("2 of 4 pairs of conditions (per metric, count) were tested in no replication "
                               "(e.g. m: x - z)") and notes[0].endswith("NaN, not tested, never 0")
    assert "1 pair of conditions (per metric, count) was tested in only some replications (e.g. m: x - y, "\
           "4 of 5 at 6 participants" in notes[1]
    assert replication.untested_notes(summarise(_table()[lambda t: t["b"] == "y"])) == []
