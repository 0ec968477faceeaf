"""Condition names shown apart, and pairs shown with their own statistics.

A researcher's conditions ``-10``, ``0`` and ``10`` were drawn as " 10", "0" and "10" (the minus
became a space), and ``offset-10`` and ``offset_10`` both as "Offset 10"; the built-in conditions
keep the names the shipped figures show. With three or more conditions the printed table of
``nudge analyze`` gave every pair the omnibus Friedman p and Kendall's W as its "participant p";
it gives the pair's own Wilcoxon p and rank-biserial r, as ``summary.md`` does. ``nudge compare``
offered ``--match SIMULATED=...`` for a real condition though no simulated condition was left to
pair with it."""

from __future__ import annotations

import pandas as pd
import pytest
from test_report_compare_match import SIMULATED, table
from test_report_not_applicable import FEW, FOUR, four_groups

from nudgecli.model.conditions import POLICIES, POLICY_ALIASES
from nudgecli.report.compare import align_conditions
from nudgecli.report.figures.boxplots import metric_boxplot
from nudgecli.report.stats_document import compare_conditions, json_ready, stats_table
from nudgecli.report.style import condition_display_name, condition_display_names
from nudgecli.report.summary import format_p, format_table, format_value

#: What the shipped figures show for every built-in and preset condition.
SHIPPED_NAMES = {"disambiguation": "Disambiguation", "control": "Control", "teleoperation": "Teleoperation",
                 "blending": "Blending", "mode-switch": "Mode Switch", "hindsight": "Hindsight",
                 "turn-taking": "Turn Taking", "no_assistance": "No Assistance"}


def test_built_in_conditions_keep_the_names_the_shipped_figures_show() -> None:
    assert set(SHIPPED_NAMES) == {*POLICIES, *POLICY_ALIASES}
    assert condition_display_names(list(SHIPPED_NAMES)) == SHIPPED_NAMES
    assert all(condition_display_name(c) == shown for c, shown in SHIPPED_NAMES.items())


@pytest.mark.parametrize(("conditions", "shown"), [
    (["-10", "0", "10"], ["-10", "0", "10"]),  # was " 10", "0", "10"
    (["offset-10", "offset_10"], ["offset-10", "offset_10"]),  # was Offset 10 twice
    (["gain_-5", "gain_5", "+3"], ["Gain -5", "Gain 5", "+3"]),  # a sign after a break is kept
    (["-fast", "fast"], ["-fast", "Fast"]),  # a leading sign no prettifying may drop
    (["offset-10", "Blend-30"], ["Offset 10", "Blend 30"]),  # prettified while they stay apart
])
def test_a_researchers_conditions_are_shown_apart(conditions: list[str], shown: list[str]) -> None:
    names = condition_display_names(conditions)
    assert [names[c] for c in conditions] == shown
    # one condition named among the others, as a trial's title names it
    assert condition_display_name(conditions[0], conditions) == shown[0]


def test_the_box_plot_labels_signed_conditions_apart() -> None:
    trials = pd.DataFrame({"participant": [f"p{i % 3}" for i in range(9)],
                           "condition": ["-10", "0", "10"] * 3, "value": [float(i) for i in range(9)]})
    out = metric_boxplot(trials, "value", conditions=["-10", "0", "10"], show_n=False)
    assert [t.get_text() for t in out.ax.get_xticklabels()] == ["-10", "0", "10"]


def test_the_printed_table_gives_each_of_three_conditions_pairs_its_own_wilcoxon_test() -> None:
    three = FOUR[:3]
    data = four_groups()
    stats = json_ready(compare_conditions(data[data["condition"].isin(three)], ["value"], three, FEW))
    tidy = stats_table(stats)
    lines = format_table(tidy, three).splitlines()
    assert "Wilcoxon p (holm)" in lines[0] and "participant p" not in lines[0]
    friedman = format_p(stats["metrics"][0]["participant_level"]["p"])
    for row, line in zip(tidy.to_dict("records"), lines[2:], strict=True):
        # metric, "a vs b", two "median [q1, q3]", KW p, Conover p, stars, then the pair's own test
        own = line.split()[13:15]
        assert own == [format_p(row["pairwise_p"]), f"r={format_value(row['pairwise_effect_size'])}"]
    assert {line.split()[13] for line in lines[2:]} != {friedman}  # what every row showed before


def test_compare_offers_a_match_only_while_a_simulated_condition_is_unpaired() -> None:
    real = table({"control": 3, "disambiguation": 3, "Blend-30": 3}, prefix="r")
    notes: list[str] = []
    _, _, shared = align_conditions(SIMULATED, real, {"disambiguation": "Blend-30"}, names=("s", "r.csv"),
                                    notes=notes)
    assert shared == ["control", "Blend-30"]
    assert notes == ["condition 'disambiguation' of the real table (r.csv) is not compared: --match "
                     "disambiguation=Blend-30 compares the simulated 'disambiguation' as the real 'Blend-30'"]
    notes.clear()  # every simulated condition paired by name: nothing to pair Blend-30 with
    align_conditions(SIMULATED, real, names=("s", "r.csv"), notes=notes)
    assert notes == ["condition 'Blend-30' is only in the real table (r.csv): not compared"]
