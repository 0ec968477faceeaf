"""Significance brackets: stars from p-values, stacking, and only significant comparisons drawn."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.text import Text

from nudgecli.errors import DataError
from nudgecli.report import brackets as brackets_module
from nudgecli.report.brackets import Bracket, assign_levels, brackets_from_stats, draw_brackets
from nudgecli.report.stats import ComparisonOptions, significance_stars


def _axes(n_groups: int = 3):
    fig = Figure(figsize=(3.0, 2.6))
    ax = fig.subplots()
    rng = np.random.default_rng(0)
    for i in range(n_groups):
        ax.scatter(np.full(20, float(i)), rng.uniform(0, 10, 20))
    ax.autoscale_view()
    return fig, ax


@pytest.mark.parametrize(("p", "stars"), [(0.0009, "***"), (0.001, "**"), (0.0099, "**"), (0.01, "*"),
                                          (0.049, "*"), (0.05, ""), (0.7, ""), (float("nan"), "")])
def test_computed_stars_are_the_stats_modules_strict_by_default(p: float, stars: str) -> None:
    entry = {"kruskal": {"p": 0.001}, "conover": [{"a": "a", "b": "b", "p": p}]}
    assert [b.stars for b in brackets_from_stats(entry)] == [stars] == [significance_stars(p)]


def test_stars_have_one_owner() -> None:
    # brackets computes no stars of its own: it uses nudgecli.report.stats.
    assert brackets_module.significance_stars is significance_stars
    assert not hasattr(brackets_module, "STAR_THRESHOLDS") and not hasattr(brackets_module, "stars_for_p")


def test_computed_stars_follow_the_plan_thresholds_and_comparison() -> None:
    entry = {"kruskal": {"p": 0.02}, "conover": [{"a": "a", "b": "b", "p": 0.02}]}
    loose = ComparisonOptions(star_thresholds=(0.1, 0.02), star_comparison="<=")
    assert [b.stars for b in brackets_from_stats(entry, loose)] == ["**"]
    strict = ComparisonOptions(star_thresholds=(0.1, 0.02), star_comparison="<")
    assert [b.stars for b in brackets_from_stats(entry, strict)] == ["*"]


def test_brackets_from_stats_prefers_given_stars_and_gates_on_kruskal() -> None:
    entry = {"kruskal": {"statistic": 9.0, "p": 0.01},
             "conover": [{"a": "a", "b": "b", "p": 0.004, "p_unadjusted": 0.002},
                         {"a": "a", "b": "c", "p": 0.2, "p_unadjusted": 0.1},
                         {"a": "b", "b": "c", "p": 0.0004, "p_unadjusted": 0.0002}],
             "stars": {"b|a": "*"}}  # given (reversed key) wins over the p-value; others computed
    got = brackets_from_stats(entry)
    assert [(b.a, b.b, b.stars) for b in got] == [("a", "b", "*"), ("a", "c", ""), ("b", "c", "***")]
    entry["kruskal"]["p"] = 0.3
    del entry["stars"]
    assert [b.stars for b in brackets_from_stats(entry)] == ["", "", ""]
    assert brackets_from_stats(None) == []
    assert brackets_from_stats({"kruskal": {"p": 0.01}, "conover": []}) == []


def test_assign_levels() -> None:
    # Disjoint spans share a level; touching spans do not; the wide span goes above.
    assert assign_levels([(0, 1), (2, 3)]) == [0, 0]
    assert assign_levels([(0, 1), (1, 2)]) == [0, 1]
    assert assign_levels([(0, 2), (0, 1), (1, 2)]) == [2, 0, 1]


def test_only_significant_brackets_are_drawn() -> None:
    _fig, ax = _axes()
    data_top = ax.dataLim.y1
    comps = [Bracket("a", "b", 0.004, "**"), Bracket("b", "c", 0.4, ""), Bracket("a", "c", 0.03, "*")]
    artists = draw_brackets(ax, {"a": 0.0, "b": 1.0, "c": 2.0}, comps)
    texts = [a.get_text() for a in artists if isinstance(a, Text)]
    assert sorted(texts) == ["*", "**"]
    assert sorted(t.get_text() for t in ax.texts) == ["*", "**"]
    lines = [a for a in artists if isinstance(a, Line2D)]
    assert len(lines) == 2
    for text, line in zip([a for a in artists if isinstance(a, Text)], lines, strict=True):
        xs = line.get_xdata()
        assert text.get_position()[0] == pytest.approx((min(xs) + max(xs)) / 2)  # stars centred
    # All brackets are above the data and inside the new limits.
    assert min(min(ln.get_ydata()) for ln in lines) > data_top
    assert max(max(ln.get_ydata()) for ln in lines) < ax.get_ylim()[1]


def test_nothing_drawn_keeps_limits() -> None:
    _fig, ax = _axes()
    before = ax.get_ylim()
    assert draw_brackets(ax, {"a": 0.0, "b": 1.0}, [Bracket("a", "b", 0.3, "")]) == []
    assert ax.get_ylim() == before
    assert len(ax.texts) == 0


def test_show_ns_and_unknown_condition() -> None:
    _fig, ax = _axes(2)
    artists = draw_brackets(ax, {"a": 0.0, "b": 1.0}, [Bracket("a", "b", 0.3, "")], show_ns=True)
    assert [a.get_text() for a in artists if isinstance(a, Text)] == ["n.s."]
    with pytest.raises(DataError, match="'z'"):
        draw_brackets(ax, {"a": 0.0, "b": 1.0}, [Bracket("a", "z", 0.001, "***")])


def test_all_pairs_of_four_groups_stack_without_overlap() -> None:
    _fig, ax = _axes(4)
    data_top = ax.dataLim.y1
    pos = {c: float(i) for i, c in enumerate("abcd")}
    comps = [Bracket(a, b, 0.001, "**") for a, b in itertools.combinations("abcd", 2)]
    artists = draw_brackets(ax, pos, comps)
    lines = [a for a in artists if isinstance(a, Line2D)]
    texts = [a for a in artists if isinstance(a, Text)]
    assert len(lines) == 6 and len(texts) == 6
    bars = [(min(ln.get_xdata()), max(ln.get_xdata()), max(ln.get_ydata()), min(ln.get_ydata()))
            for ln in lines]
    for (l1, r1, y1, b1), (l2, r2, y2, b2) in itertools.combinations(bars, 2):
        if l1 <= r2 and l2 <= r1:  # horizontally overlapping or touching: different heights
            assert y1 != pytest.approx(y2)
            upper_bottom, lower_top = (b1, y2) if y1 > y2 else (b2, y1)
            assert upper_bottom > lower_top  # the upper bracket's legs stay above the lower bar
    assert min(b for *_, b in bars) > data_top
    assert max(y for _, _, y, _ in bars) < ax.get_ylim()[1]
