"""What the batch figures (``nudge replicate``, ``power``, ``sweep``) mark: a value only where it is
defined, "undefined" / "not tested" / "n/a" written where it is not, the pair of conditions each
difference is of, and readable text. Small synthetic tables drawn directly, artists read back."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from nudgecli.report.figures.replication import sweep_figure, sweep_panel

NAN = math.nan


def _sweep_rows(values: dict[float, list[float]], name: str = "study.time_limit_s",
                **fixed: object) -> pd.DataFrame:
    """Replication rows of one metric and pair: per swept value, each replication's difference."""
    rows = [{"point": i, "replication": r, name: value, "metric": "completion_time", "a": "disambiguation",
             "b": "control", "difference": difference, **fixed}
            for i, (value, differences) in enumerate(values.items())
            for r, difference in enumerate(differences)]
    return pd.DataFrame(rows)


def _mean_line(ax: Axes) -> tuple[np.ndarray, np.ndarray]:
    line = ax.lines[0]
    return np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float)


def _texts(ax: Axes) -> list[str]:
    return [t.get_text() for t in ax.texts]


# --- 1: the sweep's mean only where every replication's difference is defined --------------------


def test_the_sweep_plots_no_mean_where_a_replication_is_undefined_and_names_those_values() -> None:
    rows = _sweep_rows({17.0: [NAN, -0.5, 0.0, NAN], 19.0: [-1.0, NAN, -0.35, -0.675],
                        21.0: [-1.0, -0.5, 0.0, 0.5], 23.0: [1.0, 1.0, 1.0, 1.0]})
    ax = sweep_panel(rows, "study.time_limit_s")
    x, mean = _mean_line(ax)
    assert list(x) == [17.0, 19.0, 21.0, 23.0]
    assert np.isnan(mean[:2]).all()  # as points.csv: NaN, not the mean of the defined replications
    assert mean[2:].tolist() == [-0.25, 1.0]
    assert "undefined at 17, 19" in _texts(ax)
    open_marks = [line for line in ax.lines if line.get_markerfacecolor() == "none"]
    assert [list(line.get_xdata()) for line in open_marks] == [[17.0, 19.0]]


def test_the_sweep_band_is_per_value_of_its_parameter_with_the_others_pooled() -> None:
    # a grid of two parameters: at x = 1 the other parameter's two points, two replications each
    rows = pd.concat([_sweep_rows({1.0: [0.0, 1.0], 2.0: [5.0, 5.0]}, "p.x", **{"p.z": 0}),
                      _sweep_rows({1.0: [2.0, 3.0], 2.0: [5.0, 5.0]}, "p.x", **{"p.z": 1})])
    ax = sweep_panel(rows, "p.x")
    assert _mean_line(ax)[1].tolist() == [1.5, 5.0]
    (band,) = ax.collections
    vertices = band.get_paths()[0].vertices
    at_one = sorted(set(vertices[vertices[:, 0] == 1.0, 1].round(6)))
    assert at_one == list(np.percentile([0.0, 1.0, 2.0, 3.0], [2.5, 97.5]).round(6))


def test_the_sweep_figure_draws_a_mean_where_every_value_is_defined() -> None:
    rows = _sweep_rows({1.0: [0.5, 1.5], 2.0: [2.0, 4.0]}, "p.x")
    (ax,) = sweep_figure(rows, ["p.x"]).get_axes()
    assert _mean_line(ax)[1].tolist() == [1.0, 3.0]
    assert not any(t.startswith("undefined") for t in _texts(ax))


# --- 3: the power of one participant count -----------------------------------------------------


def _power(counts: list[int], power: float = 0.5, **pair: object) -> pd.DataFrame:
    rows = [{"participants": n, "metric": "completion_time", "a": "disambiguation", "b": "control",
             "level": level, "direction": "a < b", "replications": 4, "tested": 4, "power": power,
             "low": power - 0.3, "high": power + 0.3, **pair}
            for n in counts for level in ("trial", "participant")]
    return pd.DataFrame(rows)


def test_the_power_of_one_count_is_drawn_with_error_bars_at_its_integer_tick() -> None:
    from nudgecli.report.figures.replication import power_panel

    ax = power_panel(_power([3]))
    assert [t.get_text() for t in ax.get_xticklabels()] == ["3"]  # not 2.80, 2.90, ... 3.20
    low, high = ax.get_xlim()
    assert low <= 2.5 and high >= 3.5 and high - low <= 3
    bars = [c for c in ax.collections if c.get_segments()]
    assert len(bars) == 2  # each level's Clopper-Pearson interval, a vertical bar
    for bar in bars:
        (segment,) = bar.get_segments()
        assert sorted(segment[:, 1].round(6)) == [0.2, 0.8]


def test_the_power_of_several_counts_has_a_tick_at_each_count() -> None:
    from nudgecli.report.figures.replication import power_panel

    ax = power_panel(_power([6, 9, 12]))
    assert [t.get_text() for t in ax.get_xticklabels()] == ["6", "9", "12"]


# --- 5: the pair of conditions each difference is of --------------------------------------------


def test_the_sweep_names_the_pair_and_ticks_each_swept_value() -> None:
    rows = _sweep_rows({17.0: [1.0, 2.0], 19.0: [1.0, 2.0], 21.0: [0.0, 0.5], 23.0: [0.0, 0.0]})
    (ax,) = sweep_figure(rows, ["study.time_limit_s"]).get_axes()
    assert ax.get_ylabel() == "completion_time\n(disambiguation - control)"  # not "(a - b)"
    assert [t.get_text() for t in ax.get_xticklabels()] == ["17", "19", "21", "23"]


def test_the_power_titles_name_the_pair_in_the_direction_tested() -> None:
    from nudgecli.report.figures.replication import power_figure

    (ax,) = power_figure(_power([6, 9])).get_axes()
    assert ax.get_title() == "completion_time\ndisambiguation < control"  # not "(a < b)"
    either = _power([6, 9]).assign(direction="either")
    (ax,) = power_figure(either).get_axes()
    assert ax.get_title() == "completion_time\ndisambiguation - control, either direction"


# --- 4: undefined values written, never drawn as blank ----------------------------------------


def test_sensitivity_panels_without_indices_say_why_and_show_no_value_axis() -> None:
    from nudgecli.report.figures.replication import sensitivity_panel

    indices = pd.DataFrame({"metric": "success", "a": "x", "b": "y",
                            "parameter": ["p.x", "p.x", "p.z", "p.z"], "index": ["S1", "ST"] * 2,
                            "value": NAN, "conf": NAN, "replications": 3})
    ax = sensitivity_panel(indices)
    assert _texts(ax) == ["undefined (constant output)"]
    assert list(ax.get_yticks()) == []
    ax = sensitivity_panel(indices.assign(replications=0))
    assert _texts(ax)[0].startswith("undefined (no replication defined")


def _replications(pairs: dict[tuple[str, str], list[float]]) -> pd.DataFrame:
    return pd.DataFrame([{"metric": "assistance_engagement", "a": a, "b": b, "replication": r,
                          "difference": d, "ci_low": d - 1, "ci_high": d + 1,
                          "participant_significant": False}
                         for (a, b), differences in pairs.items() for r, d in enumerate(differences)])


def test_forest_rows_and_panels_of_pairs_not_tested_say_so() -> None:
    from nudgecli.report.figures.replication import forest_panel, pairs_forest_panel

    rows = _replications({("x", "y"): [1.0, 2.0], ("x", "z"): [NAN, NAN], ("y", "z"): [0.5, 0.5]})
    pooled = pd.DataFrame({"metric": "assistance_engagement", "a": ["x", "x", "y"], "b": ["y", "z", "z"],
                           "tested": [2, 0, 2], "difference": [1.5, NAN, 0.5],
                           "difference_low": [1.0, NAN, 0.5], "difference_high": [2.0, NAN, 0.5]})
    ax = pairs_forest_panel(rows, pooled)
    (text,) = ax.texts
    assert text.get_text() == "not tested" and text.get_position()[1] == 1  # in the row of x - z
    two = rows[rows["b"] == "z"].loc[lambda t: t["a"] == "x"]
    ax = forest_panel(two, pooled.iloc[1])
    assert _texts(ax) == ["not tested"] and list(ax.get_xticks()) == []


def test_power_of_a_pair_not_tested_is_written_in_its_panel_and_its_cells() -> None:
    from nudgecli.report.figures.replication import power_grid_panel, power_panel

    untested = _power([6, 9], NAN).assign(low=NAN, high=NAN, tested=0)
    assert _texts(power_panel(untested)) == ["not tested"]
    three = pd.concat([_power([6, 9]).assign(b="y"), untested.assign(b="z")])
    assert _texts(power_grid_panel(three, "trial")).count("not tested") == 1  # once across its row


def test_a_sweep_panel_undefined_everywhere_shows_no_value_axis() -> None:
    ax = sweep_panel(_sweep_rows({1.0: [NAN, NAN], 2.0: [NAN, 1.0]}, "p.x"), "p.x")
    assert "undefined at 1, 2" in _texts(ax) and list(ax.get_yticks()) == []


def test_a_box_panel_of_conditions_all_not_applicable_shows_no_value_axis() -> None:
    from nudgecli.report.figures.boxplots import metric_boxplot

    metrics = pd.DataFrame({"condition": ["teleoperation", "control"] * 3, "completion_time": NAN})
    entry = {"metric": "completion_time", "not_applicable": ["teleoperation", "control"]}
    out = metric_boxplot(metrics, "completion_time", entry)
    assert [t.get_text() for t in out.not_applicable] == ["n/a", "n/a"]
    assert list(out.ax.get_yticks()) == []  # not -0.04 ... 0.04 s


# --- 7: the batch figures' text at the style's print sizes, laid out without overlaps -------------


def _batch_figures(*names: str) -> dict[str, Figure]:
    """The batch figures of small tables, by name (``names``: only those; default all)."""
    from nudgecli.report.figures.replication import forest_figure, power_figure, sensitivity_figure

    pairs = {("x", "y"): [1.0, 2.0, 0.5], ("x", "z"): [NAN, NAN, NAN], ("y", "z"): [0.5, 0.5, 1.0]}
    rows = _replications(pairs)
    pooled = rows.groupby(["metric", "a", "b"], sort=False)["difference"].agg(
        difference="mean", difference_low="min", difference_high="max").reset_index().assign(tested=[3, 0, 3])
    two = _power([6, 9, 12])
    three = pd.concat([two.assign(b=b) for b in ("y", "z", "w", "v")]
                      + [two.assign(metric="success", b=b) for b in ("y", "z", "w", "v")])
    indices = pd.DataFrame({"metric": "success", "a": "x", "b": "y", "replications": 3,
                            "parameter": ["p.x", "p.x", "p.z", "p.z"], "index": ["S1", "ST"] * 2,
                            "value": [0.2, 0.3, 0.5, 0.6], "conf": 0.1})
    builders: dict[str, Callable[[], Figure]] = {
        "forest": lambda: forest_figure(rows, pooled),
        "forest of two": lambda: forest_figure(rows[rows["b"] == "y"], pooled.iloc[:1]),
        "power": lambda: power_figure(two), "power grid": lambda: power_figure(three),
        "sweep": lambda: sweep_figure(_sweep_rows({17.0: [NAN, 1.0], 19.0: [0.5, 1.0]}),
                                      ["study.time_limit_s"]),
        "sensitivity": lambda: sensitivity_figure(indices)}
    return {name: build() for name, build in builders.items() if not names or name in names}


def test_every_batch_figure_writes_its_text_at_the_print_sizes() -> None:
    """The style's own sizes, not only text of at least 8 pt (matplotlib's default 10 pt is that):
    tick labels and legends at the style's sizes, every other text at one of its sizes."""
    from matplotlib.text import Text

    from nudgecli.report.style import BASE_FONT_PT, LABEL_FONT_PT, LEGEND_FONT_PT, MIN_FONT_PT, TICK_FONT_PT

    style_sizes = {BASE_FONT_PT, LABEL_FONT_PT, LEGEND_FONT_PT, TICK_FONT_PT}
    for name, fig in _batch_figures().items():
        sizes = {t.get_text(): t.get_fontsize() for t in fig.findobj(Text) if t.get_text().strip()}
        small = {text: size for text, size in sizes.items() if size < MIN_FONT_PT}
        assert not small, f"{name}: text under {MIN_FONT_PT} pt: {small}"
        other = {text: size for text, size in sizes.items() if size not in style_sizes}
        assert not other, f"{name}: text at none of the style's sizes {sorted(style_sizes)}: {other}"
        ticks = {t.get_fontsize() for ax in fig.get_axes()
                 for t in [*ax.get_xticklabels(), *ax.get_yticklabels()] if t.get_text()}
        assert ticks == {TICK_FONT_PT}, f"{name}: tick labels at {ticks}"
        legends = {t.get_fontsize() for legend in fig.legends for t in legend.get_texts()}
        assert legends <= {LEGEND_FONT_PT}, f"{name}: legend text at {legends}"


def test_the_batch_figures_lay_out_their_labels_and_legends_apart() -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from nudgecli.report.style import figure_style

    # the crowded rows, and a legend of each kind
    for name, fig in _batch_figures("forest", "power", "power grid").items():
        with figure_style():
            renderer = FigureCanvasAgg(fig).get_renderer()
            fig.draw(renderer)
        for ax in fig.get_axes():
            assert ax.get_legend() is None, f"{name}: a legend inside a panel covers its data"
            labels = [t.get_window_extent(renderer) for t in ax.get_yticklabels() if t.get_text()]
            for first, second in itertools.pairwise(sorted(labels, key=lambda box: box.y0)):
                assert first.y1 <= second.y0 + 0.5, f"{name}: y labels overlap"
            panel = ax.get_window_extent(renderer)
            for legend in fig.legends:
                assert not legend.get_window_extent(renderer).overlaps(panel), f"{name}: legend over a panel"


# --- 2: the box plots' labels say what the plan's definition measures ---------------------------


def _trial_metrics() -> pd.DataFrame:
    return pd.DataFrame({"participant": [1, 1, 2, 2] * 2, "condition": ["disambiguation", "control"] * 4,
                         "success": [1.0, 0.0, 1.0, 1.0] * 2, "assistance_engagement": 0.5,
                         "assistance_strength": 0.4, "mode_switches": [1, 2, 3, 4] * 2, "human_turns": 2,
                         "human_effort": 0.5, "completion_time": 20.0})


def test_the_box_plot_labels_follow_the_plans_metric_definitions() -> None:
    from nudgecli.report.figures.boxplots import METRIC_SPECS
    from nudgecli.report.plans import MetricDefinitions, load_plan
    from nudgecli.report.plotting import FigureInputs, PlotPlan, draw_figures

    metrics = _trial_metrics()
    names = ["success", "assistance_engagement", "assistance_strength", "mode_switches", "human_effort"]
    stats = {"conditions": ["disambiguation", "control"], "metrics": [{"metric": m} for m in names]}
    study_code = load_plan("study-code").metrics
    assert (study_code.success, study_code.engagement, study_code.strength, study_code.mode_switches) == (
        "last_inferred_goal", "per_turn", "per_turn", "human_turn")

    def labels(definitions: MetricDefinitions) -> dict[str, str]:
        drawn = draw_figures(FigureInputs(metrics, stats), PlotPlan(Path("."), definitions=definitions))
        return {m: " ".join(ax.get_ylabel().split()) for m, ax in zip(names, drawn["metrics"].get_axes(),
                                                                      strict=False)}

    assert labels(study_code) == {"success": "Success (1 = last inferred goal is the true goal)",
                      "assistance_engagement": "Assistance engagement (mean % per human turn)",
                      "assistance_strength": "Strength of assistance (mean α per human turn)",
                      "mode_switches": "Mode switches in human turns per trial",
                      "human_effort": METRIC_SPECS["human_effort"].label}  # one definition in every plan
    assert labels(load_plan("paper").metrics) == {m: METRIC_SPECS[m].label for m in names}


def test_the_box_plot_labels_of_a_metrics_tables_analysis_name_no_plan_definition() -> None:
    """A metrics table's analysis takes the table's own engagement, strength, mode switches and
    success (its note says so): the labels name none of the plan's definitions of them, in the
    figures nudge plot draws and in one metric's panel drawn by nudge.plot."""
    from nudgecli.report.figures.boxplots import METRIC_SPECS, applied_definitions, metric_boxplot
    from nudgecli.report.plans import load_plan
    from nudgecli.report.plotting import FigureInputs, PlotPlan, draw_figures
    from nudgecli.report.table_read import TABLE_READ_KEY

    names = ["success", "assistance_engagement", "assistance_strength", "mode_switches"]
    stats = {"conditions": ["disambiguation", "control"], "metrics": [{"metric": m} for m in names],
             TABLE_READ_KEY: {"table": "m.csv", "plan": "study-code"}}
    study_code = load_plan("study-code").metrics
    drawn = draw_figures(FigureInputs(_trial_metrics(), stats), PlotPlan(Path("."), definitions=study_code))
    labels = {m: " ".join(ax.get_ylabel().split()) for m, ax in zip(names, drawn["metrics"].get_axes(),
                                                                    strict=False)}
    assert labels == {m: METRIC_SPECS[m].label for m in names}
    assert applied_definitions(stats, study_code) is None
    run_stats = {k: v for k, v in stats.items() if k != TABLE_READ_KEY}  # a run's: the plan's definitions
    assert applied_definitions(run_stats, study_code) is study_code
    panel = metric_boxplot(_trial_metrics(), "mode_switches", None,
                           definitions=applied_definitions(run_stats, study_code)).ax
    assert " ".join(panel.get_ylabel().split()) == "Mode switches in human turns per trial"


# --- 6: the README says what the batch figures of three or more conditions draw -----------------


def test_the_readme_describes_the_panels_of_the_batch_figures_of_three_conditions() -> None:
    from nudgecli.report.figures.replication import forest_figure, power_figure

    readme = " ".join((Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8").split())
    assert "one panel per metric and pair" not in readme
    assert ("Their figures draw a panel per metric; with 3+ conditions the forest has a row per pair, "
            "power a panel per level of test, a row per metric and pair.") in readme
    three = _replications({("x", "y"): [1.0], ("x", "z"): [2.0], ("y", "z"): [3.0]})
    rows = pd.concat([three.assign(metric=m) for m in ("completion_time", "success")])
    pooled = rows.assign(difference_low=rows["difference"], difference_high=rows["difference"], tested=1)
    forest = forest_figure(rows, pooled).get_axes()
    assert [len(ax.get_yticks()) for ax in forest] == [3, 3]  # a panel per metric, a row per pair
    power = pd.concat([_power([6]).assign(b=b, metric=m)
                       for m in ("completion_time", "success") for b in "yz"])
    levels = power_figure(power).get_axes()
    assert [len(ax.get_yticks()) for ax in levels] == [4, 4]  # a panel per level, a row per metric and pair
