"""How a p-value is printed beside its stars: the printed value never says the opposite of the
stars (p = 0.009976 with ``**`` once printed ``0.010``), under the paper's ``p < t`` and the study
code's ``p <= t``; and ``summary.md`` writes ``p < 0.001``, not ``p = <0.001``.

The printed value is read back independently (:class:`decimal.Decimal` of the text against the
threshold as written) and its stars compared with :func:`~nudgecli.report.stats.significance_stars`
of the exact p.
"""

from __future__ import annotations

import math
from decimal import Decimal
from pathlib import Path
from typing import Literal

import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.report.plans import AnalysisPlan, StatsSettings
from nudgecli.report.stats import ComparisonOptions, significance_stars
from nudgecli.report.stats_document import compare_conditions, json_ready, stats_table
from nudgecli.report.summary import format_p, format_summary, format_table, plan_p_thresholds

PLAN_THRESHOLDS = (0.05, 0.01, 0.001)  # every shipped plan's stars; 0.05 is also their Kruskal-Wallis alpha
COMPARISONS: tuple[Literal["<", "<="], ...] = ("<", "<=")

# QA's reproduction: two conditions whose Conover p is 0.009976 (two stars)
BORDER_PARTICIPANTS = [0, 1, 2, 3, 0, 1, 2, 3, 0]
BORDER = {"disambiguation": [0.93, -1.29, -1.33, 0.93, 0.6, -0.68, -0.06, -1.29, -0.69],
          "control": [0.13, 1.35, 2.72, 1.25, 0.49, 0.31, 3.14, -0.16, 1.35]}


def stars_of_printed(text: str, thresholds: tuple[float, ...], comparison: Literal["<", "<="]) -> str:
    """The stars a reader gives the printed value: each threshold (as written in the plan, its
    shortest repr) compared with the printed decimal; ``<0.001`` is below every threshold >= 0.001."""
    count = 0
    for t in thresholds:
        limit = Decimal(repr(t))
        if text == "<0.001":
            assert limit >= Decimal("0.001"), "no reading of <0.001 against a smaller threshold"
            count += 1
            continue
        value = Decimal(text)
        count += value < limit or (comparison == "<=" and value == limit)
    return "*" * count


def decimals_of(text: str) -> int:
    return len(text.split(".")[1])


# --- exact p's around each threshold -------------------------------------------------------------

AROUND = [
    # (p, printed): hand-solved; 3 decimals unless those land on or across a threshold
    (0.009976216232177043, "0.00998"),    # QA's Conover p: 3 and 4 decimals give 0.010(0)
    (0.0499, "0.0499"),                   # 0.050 would be on the threshold it is below
    (0.04951, "0.0495"),
    (0.049976, "0.04998"),                # 0.0500 at 4 decimals is still the threshold
    (0.05, "0.050"), (0.01, "0.010"), (0.001, "0.001"),  # on the threshold: stars under <= only
    (0.0500004, "0.0500004"),             # above: 0.050 would read as meeting p <= .05
    (0.0104, "0.0104"),                   # 0.010 would read as meeting p <= .01
    (0.0099, "0.0099"),
    (0.0010004, "0.0010004"),
    (0.0009996, "<0.001"),                # below 0.001 whatever 3 decimals say
    (0.0123, "0.012"), (0.5, "0.500"), (1.0, "1.000"), (0.0, "<0.001"),  # far from any: as before
    (math.nextafter(0.05, 1), "0.05000000000000001"),   # the float next to 0.05: all its digits
    (math.nextafter(0.05, 0), "0.049999999999999996"),
    (math.nextafter(0.01, 0), "0.009999999999999998"),
]


@pytest.mark.parametrize(("p", "printed"), AROUND)
def test_p_around_each_threshold_prints_hand_solved_digits(p: float, printed: str) -> None:
    assert format_p(p) == printed


@pytest.mark.parametrize("comparison", COMPARISONS)
@pytest.mark.parametrize(("p", "printed"), AROUND)
def test_printed_p_and_its_stars_agree_under_both_comparisons(
        p: float, printed: str, comparison: Literal["<", "<="]) -> None:
    text = format_p(p)
    assert stars_of_printed(text, PLAN_THRESHOLDS, comparison) == significance_stars(
        p, PLAN_THRESHOLDS, comparison)


def test_missing_p_prints_a_dash() -> None:
    assert format_p(None) == format_p(float("nan")) == format_p(float("inf")) == "-"


@given(p=st.floats(min_value=0.0, max_value=1.0),
       thresholds=st.lists(st.floats(min_value=0.001, max_value=0.999), min_size=1, max_size=4, unique=True),
       comparison=st.sampled_from(COMPARISONS))
def test_any_p_prints_on_its_side_of_every_threshold(
        p: float, thresholds: list[float], comparison: Literal["<", "<="]) -> None:
    ordered = tuple(sorted(thresholds, reverse=True))
    text = format_p(p, ordered)
    assert stars_of_printed(text, ordered, comparison) == significance_stars(p, ordered, comparison)
    if text == "<0.001":
        assert p < 0.001
        return
    # the printed value is p correctly rounded to its decimals, and no decimal more than needed
    places = decimals_of(text)
    assert places >= 3
    assert abs(Decimal(text) - Decimal(p)) <= Decimal(5) * Decimal(10) ** -(places + 1)
    if places > 3:
        shorter = f"{p:.{places - 1}f}"
        assert any(stars_of_printed(shorter, (t,), c) != significance_stars(p, (t,), c)
                   for t in ordered for c in COMPARISONS)


# --- the printed table and summary.md -----------------------------------------------------------


def border_data() -> pd.DataFrame:
    return pd.DataFrame([{"participant": person, "condition": condition, "trial": trial, "m": value}
                         for condition, values in BORDER.items()
                         for trial, (person, value)
                         in enumerate(zip(BORDER_PARTICIPANTS, values, strict=True))])


def border_table(plan: AnalysisPlan) -> pd.DataFrame:
    options = plan.comparison_options()
    stats = json_ready(compare_conditions(border_data(), ["m"], list(BORDER), options))
    return stats_table(stats)


def test_qa_border_case_prints_the_conover_p_below_its_two_stars(tmp_path: Path) -> None:
    border = tmp_path / "border.csv"
    border_data().to_csv(border, index=False)
    result = CliRunner().invoke(main, ["analyze", str(border), "--out", str(tmp_path / "A")])
    assert result.exit_code == 0, result.output
    (row,) = [line.split() for line in result.output.splitlines() if line.startswith("m ")]
    # m, two medians with their quartiles (3 words each), then KW p, Conover p, stars
    assert row[7:10] == ["0.015", "0.00998", "**"]
    summary = (tmp_path / "A" / "summary.md").read_text()
    assert "| disambiguation - control | 0.00998 | 0.00998 | ** |" in summary
    assert "0.010" not in summary


def test_summary_writes_p_less_than_not_p_equals_less_than() -> None:
    strong = pd.DataFrame([{"participant": person, "condition": condition, "trial": trial,
                            "m": shift + 0.1 * ((person * 7 + trial * 3) % 5)}
                           for person in range(8) for condition, shift in (("a", 0.0), ("b", 5.0))
                           for trial in range(5)])
    options = ComparisonOptions(bootstrap_resamples=100)
    stats = json_ready(compare_conditions(strong, ["m"], ["a", "b"], options))
    assert stats["metrics"][0]["kruskal"]["p"] < 0.001
    text = format_summary(stats_table(stats), ["a", "b"], AnalysisPlan(), Path("t.csv"), n_trials=80,
                          n_participants=8)
    assert "Kruskal-Wallis H = " in text and ", p < 0.001. Participant level" in text
    assert "= <" not in text and "p = <" not in text
    # a table cell under a "p" header keeps the short form
    assert "| a - b | <0.001 | <0.001 | *** |" in text


def test_summary_keeps_the_kruskal_p_on_its_side_of_the_plans_alpha() -> None:
    # the border case's Kruskal-Wallis p is 0.01501: a plan gating at 0.015 finds it not significant
    gated = AnalysisPlan(stats=StatsSettings(kruskal_alpha=0.015))
    table = border_table(gated)
    assert table["kruskal_p"].iloc[0] == pytest.approx(0.0150125, abs=1e-7)
    assert table["stars"].iloc[0] == ""
    text = format_summary(table, list(BORDER), gated, Path("t.csv"), n_trials=18, n_participants=4)
    assert "Kruskal-Wallis H = 5.91, p = 0.01501. " in text
    default = format_summary(border_table(AnalysisPlan()), list(BORDER), AnalysisPlan(), Path("t.csv"),
                             n_trials=18, n_participants=4)
    assert "Kruskal-Wallis H = 5.91, p = 0.015. " in default


def test_summary_keeps_the_conover_p_on_its_side_of_the_plans_star_thresholds() -> None:
    # the Conover p 0.009976 printed against stars at 0.1 and 0.00998 (one star: not below 0.00998)
    plan = AnalysisPlan(stats=StatsSettings(star_thresholds=(0.1, 0.00998)))
    table = border_table(plan)
    assert table["stars"].iloc[0] == "**"  # 0.0099762 < 0.00998
    text = format_summary(table, list(BORDER), plan, Path("t.csv"), n_trials=18, n_participants=4)
    assert "| disambiguation - control | 0.009976 | 0.009976 | ** |" in text


def test_printed_table_takes_the_plans_thresholds() -> None:
    table = border_table(AnalysisPlan())
    gated = AnalysisPlan(stats=StatsSettings(kruskal_alpha=0.015))
    assert plan_p_thresholds(gated) == (0.05, 0.01, 0.001, 0.015)
    (row,) = format_table(table, list(BORDER), thresholds=(0.015,)).splitlines()[2:]
    # only 0.015 given: the Kruskal-Wallis p keeps its side of it, the Conover p needs no more digits
    assert row.split()[7:9] == ["0.01501", "0.010"]
    (row,) = format_table(table, list(BORDER)).splitlines()[2:]
    assert row.split()[7:9] == ["0.015", "0.00998"]


def test_the_apis_printed_table_takes_its_plans_thresholds(tmp_path: Path) -> None:
    # nudge analyze's printed table (Analysis.table) with a plan gating at 0.015: the Kruskal-Wallis p
    # 0.01501 is printed on its side of it, as summary.md prints it
    from nudgecli import api

    border = tmp_path / "border.csv"
    border_data().to_csv(border, index=False)
    gated = AnalysisPlan(stats=StatsSettings(kruskal_alpha=0.015))
    analysis = api.analyze(border, plan=gated, out=tmp_path / "A", bootstrap=100)
    (row,) = [line.split() for line in analysis.table().splitlines() if line.startswith("m ")]
    assert row[7] == "0.01501"
    assert "p = 0.01501" in analysis.summary()
