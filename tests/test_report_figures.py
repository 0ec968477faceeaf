"""Figures from synthetic tables: files, labels, brackets only where significant, determinism."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from nudgecli.errors import ConfigError, DataError
from nudgecli.report import figures
from nudgecli.report.figures import (
    FIGURE3_METRICS,
    FIGURE4_METRICS,
    METRIC_SPECS,
    TrialLayout,
    belief_trace,
    figure_3,
    figure_4,
    figure_5,
    metric_boxplot,
    metrics_figure,
    questionnaire_figure,
    resolve_conditions,
    save_figure,
    trajectory,
    trajectory_figure,
)
from nudgecli.report.plotting import FigureInputs, PlotPlan, write_figures
from nudgecli.report.stats import ComparisonOptions, significance_stars
from nudgecli.report.style import MIN_FONT_PT

STAR_STRINGS = {"*", "**", "***"}
DC = ("disambiguation", "control")


# --- synthetic data --------------------------------------------------------------------------------


def make_metrics(conditions: tuple[str, ...] = ("disambiguation", "control"), participants: int = 4,
                 trials_per_condition: int = 6, seed: int = 1) -> pd.DataFrame:
    """A small metrics table: the first condition has more engagement/strength and less effort."""
    rng = np.random.default_rng(seed)
    rows = []
    trial = 0
    for p in range(participants):
        for ci, cond in enumerate(conditions):
            for k in range(trials_per_condition):
                shift = 0.12 * ci
                strength = float(np.clip(rng.normal(0.6 - shift, 0.08), 0, 1))
                rows.append({
                    "participant": p, "condition": cond, "block": ci, "trial": trial,
                    "assistance_engagement": float(np.clip(rng.normal(0.4, 0.1), 0, 1)),
                    "assistance_strength": strength if k % 5 else np.nan,
                    "human_turns": int(rng.integers(2, 6) + 2 * ci),
                    "mode_switches": int(rng.integers(1, 6) + 3 * ci),
                    "human_effort": float(np.clip(rng.normal(0.7 + shift, 0.05), 0, 1)),
                    "completion_time": float(rng.normal(40 + 10 * ci, 6)),
                    "success": bool(rng.random() < 0.9),
                })
                trial += 1
    return pd.DataFrame(rows)


def make_stats(conditions: tuple[str, ...], significant: dict[str, dict[tuple[str, str], float]],
               kruskal_p: dict[str, float] | None = None, with_stars: bool = True) -> dict:
    """A stats.json dict: Conover p per pair (1.0 unless given); stars from p when KW p < .05."""
    metrics = []
    names = list(FIGURE3_METRICS + FIGURE4_METRICS)
    for m in names:
        pairs = significant.get(m, {})
        kp = (kruskal_p or {}).get(m, 0.001 if pairs else 0.6)
        conover, stars = [], {}
        for i, a in enumerate(conditions):
            for b in conditions[i + 1:]:
                p = pairs.get((a, b), pairs.get((b, a), 0.7))
                conover.append({"a": a, "b": b, "p": p, "p_unadjusted": p / 2})
                s = ""
                if kp < 0.05:
                    s = "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else ""
                stars[f"{a}|{b}"] = s
        entry = {"metric": m, "n": {c: 10 for c in conditions}, "kruskal": {"statistic": 5.0, "p": kp},
                 "conover": conover, "p_adjust": "holm"}
        if with_stars:
            entry["stars"] = stars
        metrics.append(entry)
    return {"conditions": list(conditions), "metrics": metrics}


def make_steps(participant: int = 0, trial: int = 0, n_goals: int = 3, jump: float = 0.4,
               rising: int = 0) -> pd.DataFrame:
    """One trial at 10 Hz: human turn, autonomy turn with a nudge, human turn where goal ``rising`` jumps."""
    plan = [("human", 30), ("autonomy", 15), ("human", 30), ("autonomy", 10), ("human", 25)]
    rows = []
    step = 0
    x, y, th = 40.0, 32.0, 0.0
    p0 = 1.0 / n_goals
    mode_cycle = ["x", "y", "theta"]
    mode = "x"
    for turn_index, (turn, length) in enumerate(plan):
        for k in range(length):
            event = []
            if k == 0 and turn_index > 0:
                event.append("handover")
            if turn == "autonomy" and k == 0 and turn_index == 1:
                event.append("nudge")
                mode = "theta"
                event.append("mode_switch_autonomy")
            if turn == "human" and k == 10:
                mode = mode_cycle[(mode_cycle.index(mode) + 1) % 3]
                event.append("mode_switch_human")
            if turn == "human" and turn_index == 2:
                p0 = min(0.95, p0 + jump / length)
            elif turn == "human":
                p0 = min(0.95, p0 + 0.002)
            others = (1.0 - p0) / (n_goals - 1)
            spread = 0.01 if turn_index < 2 else 0.0
            ranked = [p0] + [others + spread * (g - 1) for g in range(1, n_goals)]
            ranked = list(np.asarray(ranked) / np.sum(ranked))
            rest = iter(ranked[1:])
            belief = [ranked[0] if g == rising else next(rest) for g in range(n_goals)]
            x -= 0.3 if turn == "human" else 0.15
            y -= 0.25
            th += 0.02
            rows.append({
                "participant": participant, "trial": trial, "step": step, "t": step * 0.1, "turn": turn,
                "x": x, "y": y, "theta": th, "mode": mode, "cell_x": 0, "cell_y": 0, "heading": 0,
                "phi_m": "", "alpha": 0.5 if turn == "human" else 0.0, "inferred_goal": 0,
                "belief": belief, "entropy": float(-np.sum(np.asarray(belief) * np.log(belief))),
                "event": "|".join(event),
            })
            step += 1
    return pd.DataFrame(rows)


GOALS = np.array([[10.0, 8.0, 0.0], [18.0, 6.0, np.pi / 2], [8.0, 15.0, np.pi]])
START = np.array([40.0, 32.0, 0.0])
LAYOUT = TrialLayout(GOALS, START, 0)


@pytest.fixture(scope="module")
def metrics2() -> pd.DataFrame:
    return make_metrics(("disambiguation", "control"))


@pytest.fixture(scope="module")
def metrics3() -> pd.DataFrame:
    return make_metrics(("disambiguation", "control", "full_state"))


def _star_texts(ax) -> list[str]:
    return [t.get_text() for t in ax.texts if t.get_text() in STAR_STRINGS]


def _all_font_sizes(fig: Figure) -> list[float]:
    return [t.get_fontsize() for t in fig.findobj(mpl.text.Text) if t.get_text().strip()]


# --- box plots ---------------------------------------------------------------------------------------


def test_figure3_panels_labels_and_brackets(metrics2: pd.DataFrame) -> None:
    stats = make_stats(("disambiguation", "control"), {"assistance_strength": {DC: 0.004}})
    fig = figure_3(metrics2, stats)
    axes = fig.get_axes()
    assert len(axes) == 3
    for ax, metric in zip(axes, FIGURE3_METRICS, strict=True):
        assert " ".join(ax.get_ylabel().split()) == METRIC_SPECS[metric].label
        assert [t.get_text().split("\n")[0] for t in ax.get_xticklabels()] == ["Disambiguation", "Control"]
    assert [ax.get_title(loc="left") for ax in axes] == ["(a)", "(b)", "(c)"]
    assert _star_texts(axes[0]) == []
    assert _star_texts(axes[1]) == ["**"]
    assert _star_texts(axes[2]) == []
    assert min(_all_font_sizes(fig)) >= MIN_FONT_PT
    assert tuple(fig.get_size_inches()) == pytest.approx((7.2, 2.6))


def test_figure4_labels_and_no_brackets_without_stats(metrics2: pd.DataFrame) -> None:
    fig = figure_4(metrics2, None)
    axes = fig.get_axes()
    for ax, metric in zip(axes, FIGURE4_METRICS, strict=True):
        assert " ".join(ax.get_ylabel().split()) == METRIC_SPECS[metric].label
        assert _star_texts(ax) == []


def test_brackets_need_significant_kruskal(metrics2: pd.DataFrame) -> None:
    # Conover p is small but Kruskal-Wallis is not significant and no stars are given: no bracket.
    stats = make_stats(("disambiguation", "control"), {"mode_switches": {DC: 0.001}},
                       kruskal_p={"mode_switches": 0.2}, with_stars=False)
    fig = figure_4(metrics2, stats)
    assert _star_texts(fig.get_axes()[0]) == []
    stats = make_stats(("disambiguation", "control"), {"mode_switches": {DC: 0.0004}}, with_stars=False)
    fig = figure_4(metrics2, stats)
    assert _star_texts(fig.get_axes()[0]) == ["***"]


def test_three_conditions_brackets_stack(metrics3: pd.DataFrame) -> None:
    conds = ("disambiguation", "control", "full_state")
    sig = {("disambiguation", "control"): 0.03, ("control", "full_state"): 0.002,
           ("disambiguation", "full_state"): 0.0001}
    stats = make_stats(conds, {"completion_time": sig})
    fig = figure_4(metrics3, stats)
    ax = fig.get_axes()[2]
    assert sorted(_star_texts(ax)) == sorted(["*", "**", "***"])
    names = [t.get_text().split("\n")[0] for t in ax.get_xticklabels()]
    assert names == ["Disambiguation", "Control", "Full State"]
    # The wide (0-2) bracket is above both narrow ones; every bracket is within the y-limits.
    lines = [ln for ln in ax.lines if len(ln.get_xdata()) == 4]
    tops = {(min(ln.get_xdata()), max(ln.get_xdata())): max(ln.get_ydata()) for ln in lines}
    assert tops[(0.0, 2.0)] > tops[(0.0, 1.0)] and tops[(0.0, 2.0)] > tops[(1.0, 2.0)]
    assert tops[(0.0, 1.0)] != tops[(1.0, 2.0)]  # they share x = 1, so they are stacked
    assert max(tops.values()) < ax.get_ylim()[1]


def test_condition_order_is_stable(metrics2: pd.DataFrame) -> None:
    shuffled = metrics2.sample(frac=1.0, random_state=3)
    control_first = metrics2.sort_values("condition")  # "control" < "disambiguation"
    for df in (shuffled, control_first):
        assert resolve_conditions(df) == ["disambiguation", "control"]
    stats = make_stats(("control", "disambiguation"), {})
    assert resolve_conditions(shuffled, stats) == ["control", "disambiguation"]
    assert resolve_conditions(shuffled, stats, ["disambiguation", "control"]) == ["disambiguation", "control"]
    fig = figure_3(shuffled, stats)
    assert [t.get_text().split("\n")[0] for t in fig.get_axes()[0].get_xticklabels()] == ["Control",
                                                                                           "Disambiguation"]


def test_jitter_is_deterministic(metrics2: pd.DataFrame) -> None:
    def dots(seed: int) -> dict[str, np.ndarray]:
        fig = Figure()
        ax = fig.subplots()
        out = metric_boxplot(metrics2, "completion_time", None, ax=ax, seed=seed)
        return {c: np.asarray(pc.get_offsets()) for c, pc in out.points.items()}

    first, second, other = dots(0), dots(0), dots(5)
    for c in first:
        np.testing.assert_array_equal(first[c], second[c])
        assert not np.array_equal(first[c][:, 0], other[c][:, 0])
        # Jitter is horizontal only: the y values are the data.
        expected = np.sort(metrics2.loc[metrics2["condition"] == c, "completion_time"].to_numpy())
        np.testing.assert_allclose(np.sort(first[c][:, 1]), expected)


def test_dots_of_a_crowded_panel_are_one_image_in_vector_files(metrics2: pd.DataFrame,
                                                                monkeypatch: pytest.MonkeyPatch,
                                                                tmp_path: Path) -> None:
    import nudgecli.report.figures.boxplots as boxplots

    n = int(metrics2["completion_time"].notna().sum())
    for limit, rasterized in ((n, False), (n - 1, True)):  # the panel's dots against the limit
        monkeypatch.setattr(boxplots, "RASTER_DOTS_ABOVE", limit)
        fig = Figure()
        out = metric_boxplot(metrics2, "completion_time", None, ax=fig.subplots())
        assert {pc.get_rasterized() for pc in out.points.values()} == {rasterized}
        svg = save_figure(fig, tmp_path / str(limit), "panel", ("svg",))[0].read_text(encoding="utf-8")
        assert ("<image" in svg) == rasterized


def test_boxplot_drops_nan_and_scales_percent(metrics2: pd.DataFrame) -> None:
    fig = Figure()
    ax = fig.subplots()
    out = metric_boxplot(metrics2, "assistance_strength", None, ax=ax)
    expected_n = metrics2.groupby("condition")["assistance_strength"].count().to_dict()
    assert out.n == expected_n
    ax2 = Figure().subplots()
    out2 = metric_boxplot(metrics2, "assistance_engagement", None, ax=ax2)
    y = np.asarray(out2.points["control"].get_offsets())[:, 1]
    assert y.max() > 1.0  # shown in percent


def test_missing_metric_column_is_a_data_error(metrics2: pd.DataFrame) -> None:
    with pytest.raises(DataError, match="human_turns"):
        figure_3(metrics2.drop(columns=["human_turns"]))


def test_no_global_rcparams_leak(metrics2: pd.DataFrame, tmp_path: Path) -> None:
    before = dict(mpl.rcParams)
    fig = figure_3(metrics2, None)
    save_figure(fig, tmp_path, "f", ("png",))
    after = dict(mpl.rcParams)
    assert {k: v for k, v in after.items() if before.get(k) != v} == {}


# --- Figure 5 ---------------------------------------------------------------------------------------


def test_figure5_lines_shading_and_nudges() -> None:
    steps = make_steps()
    fig = figure_5(steps, 0, 3, title="P0 T0")
    ax = fig.get_axes()[0]
    assert ax.get_xlabel() == "Time (s)"
    assert ax.get_ylabel() == "Goal probability"
    goal_lines = [ln for ln in ax.lines if len(ln.get_xdata()) == len(steps)]
    assert len(goal_lines) == 3
    assert mpl.colors.to_hex(goal_lines[0].get_color()) == "#d55e00"  # the true goal is red
    nudge_lines = [ln for ln in ax.lines
                   if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == ln.get_xdata()[1]]
    assert [float(ln.get_xdata()[0]) for ln in nudge_lines] == pytest.approx([3.0])
    assert len(ax.patches) == 3  # three human turns shaded
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[:3] == ["Goal 0 (true)", "Goal 1", "Goal 2"]
    assert "Nudge (to s*)" in labels and "Human turn" in labels
    assert min(_all_font_sizes(fig)) >= MIN_FONT_PT


def test_figure5_colours_the_trials_own_true_goal() -> None:
    # Goal 2 is the true goal (and the one whose belief rises): it is red, solid, thick, labelled.
    steps = make_steps(n_goals=4, rising=2)
    out = belief_trace(steps, 2)
    colours = [mpl.colors.to_hex(ln.get_color()) for ln in out.lines]
    assert colours[2] == "#d55e00" and colours.count("#d55e00") == 1
    assert len(set(colours)) == 4
    assert out.lines[2].get_linestyle() == "-" and out.lines[2].get_linewidth() > out.lines[0].get_linewidth()
    assert [ln.get_label() for ln in out.lines] == ["Goal 0", "Goal 1", "Goal 2 (true)", "Goal 3"]
    # The drawn line of goal 2 is that goal's belief, not goal 0's.
    np.testing.assert_allclose(out.lines[2].get_ydata(), [b[2] for b in steps["belief"]])
    with pytest.raises(DataError, match="true goal 4"):
        belief_trace(steps, 4)


def test_figure5_from_parquet_roundtrip(tmp_path: Path) -> None:
    steps = make_steps(0, 1, jump=0.5)
    steps.to_parquet(tmp_path / "steps.parquet")
    back = pd.read_parquet(tmp_path / "steps.parquet")
    fig = figure_5(back, 0, 3)
    assert len([ln for ln in fig.get_axes()[0].lines if len(ln.get_xdata()) > 2]) == 3


def test_figure5_belief_length_mismatch() -> None:
    with pytest.raises(DataError, match="goals"):
        figure_5(make_steps(n_goals=3), 0, 4)


# --- trajectory and questionnaires --------------------------------------------------------------------


def test_trajectory_figure() -> None:
    steps = make_steps()
    fig = trajectory_figure(steps, LAYOUT, title="P0 T0")
    ax = fig.get_axes()[0]
    assert ax.get_xlim() == (3.0, 45.0) and ax.get_ylim() == (2.0, 36.0)
    assert ax.get_xlabel().startswith("x") and ax.get_ylabel().startswith("y")
    texts = [t.get_text() for t in ax.texts]
    assert texts == ["g0 (true)", "g1", "g2"]
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"Human drove", "Autonomy drove", "Start", "g0 (true goal)", "g1", "g2", "Nudge"} <= set(labels)
    assert min(_all_font_sizes(fig)) >= MIN_FONT_PT


def test_trajectory_marks_the_trials_own_true_goal() -> None:
    out = trajectory(make_steps(), TrialLayout(GOALS, START, 1))
    assert [t.get_text() for t in out.goal_labels] == ["g0", "g1 (true)", "g2"]
    assert [mpl.colors.to_hex(d.get_color()) for d in out.goals][1] == "#d55e00"
    assert mpl.colors.to_hex(out.goals[0].get_color()) != "#d55e00"


def test_trajectory_colours_who_drove_and_fills_who_switched() -> None:
    # Fixed expectations (DESIGN 6 / the legend): human black solid, autonomy gray dashed; a mode
    # change is a filled marker when the human switched, an open one when the autonomy did.
    steps = make_steps()
    out = trajectory(steps, LAYOUT)
    turns = [turn for turn, _ in steps.groupby((steps["turn"] != steps["turn"].shift()).cumsum())["turn"]
             .first().items()]
    assert [who for who, _ in out.path] == [steps["turn"].iloc[0], "autonomy", "human", "autonomy", "human"]
    assert len(out.path) == len(turns)
    for who, line in out.path:
        colour, dashed = mpl.colors.to_hex(line.get_color()), line.get_linestyle() != "-"
        assert (colour, dashed) == (("#000000", False) if who == "human" else ("#8c8c8c", True))
    # make_steps: the autonomy switches at the start of its first turn (step 30), the human at
    # step 10 of each human turn (turns start at steps 0, 45 and 85: steps 10, 55, 95).
    expected = {30: "autonomy", 10: "human", 55: "human", 95: "human"}
    drawn = {}
    for who, marker in out.switches:
        k = int(np.flatnonzero((steps["x"].to_numpy() == marker.get_xdata()[0])
                               & (steps["y"].to_numpy() == marker.get_ydata()[0]))[0])
        drawn[k] = (who, mpl.colors.to_hex(marker.get_markerfacecolor()))
    assert drawn == {k: (who, "#000000" if who == "human" else "#ffffff") for k, who in expected.items()}
    fills = {h.get_label().strip(): mpl.colors.to_hex(h.get_markerfacecolor()) for h in out.handles
             if h.get_label().strip().startswith(("filled", "open"))}
    assert fills == {"filled: by human": "#000000", "open: by autonomy": "#ffffff"}


def test_every_drawing_function_composes_on_given_axes(metrics2: pd.DataFrame) -> None:
    fig = Figure(figsize=(10, 8), layout="constrained")
    a, b, c, d = fig.subplots(2, 2).ravel()
    assert metric_boxplot(metrics2, "human_effort", ax=a).ax is a
    assert belief_trace(make_steps(), 0, ax=b, legend=False).ax is b
    assert trajectory(make_steps(), LAYOUT, ax=c, legend=False).ax is c
    tlx = pd.DataFrame({"participant": [0, 0, 1, 1], "condition": ["disambiguation", "control"] * 2,
                        "raw_tlx": [30.0, 35.0, 28.0, 40.0]})
    figures.questionnaire_bars(tlx, "tlx", ax=d)
    assert fig.get_axes() == [a, b, c, d]
    assert all(ax.has_data() for ax in (a, b, c, d))
    assert fig.legends == []


def test_questionnaire_figure_long_and_wide() -> None:
    rng = np.random.default_rng(0)
    conds = ("disambiguation", "control")
    tlx = pd.DataFrame([{"participant": p, "condition": c, "raw_tlx": rng.uniform(20, 50),
                         "mental": rng.uniform(10, 80)} for p in range(5) for c in conds])
    likert = pd.DataFrame([{"participant": p, "condition": c, "item": q, "response": int(rng.integers(1, 8))}
                           for p in range(5) for c in ("disambiguation", "control") for q in ("Q3", "Q4")])
    fig = questionnaire_figure(tlx, likert, conditions=["disambiguation", "control"])
    ax_tlx, ax_lik = fig.get_axes()
    assert ax_tlx.get_ylabel().startswith("NASA-TLX")
    assert "agree" in ax_lik.get_ylabel()
    # Bars are the means; error bars one SD.
    bar_heights = [p.get_height() for p in ax_tlx.patches]
    means = tlx.groupby("condition")["raw_tlx"].mean()
    assert means["disambiguation"] == pytest.approx(bar_heights[0])
    assert means["control"] == pytest.approx(bar_heights[2])
    err = ax_tlx.containers[1]  # the errorbar of the first condition
    seg = err.lines[2][0].get_segments()[0]
    sd = tlx.loc[tlx.condition == "disambiguation", "raw_tlx"].std()
    assert seg[1][1] - seg[0][1] == pytest.approx(2 * sd)
    with pytest.raises(DataError):
        questionnaire_figure(None, None)


def test_questionnaire_scores_table_is_split_and_labelled(tmp_path: Path) -> None:
    # The format of nudgecli.report.questionnaires.questionnaire_scores.
    rng = np.random.default_rng(4)
    scores = pd.DataFrame([{"participant": p, "condition": c, "block": b, "tlx_raw": rng.uniform(20, 50),
                            "tlx_weighted": rng.uniform(20, 50), "likert_q3": int(rng.integers(1, 8)),
                            "likert_q4": int(rng.integers(1, 8))}
                           for p in range(6) for b, c in enumerate(DC)])
    tlx, likert = figures.split_questionnaire_scores(scores)
    assert tlx is not None and likert is not None
    assert list(tlx.columns) == ["participant", "condition", "block", "tlx_raw", "tlx_weighted"]
    stats = make_stats(DC, {})
    stats["metrics"] = [{**stats["metrics"][0], "metric": "likert_q3",
                         "stars": {"disambiguation|control": "*"}}]
    fig = questionnaire_figure(tlx, likert, conditions=list(DC), stats=stats,
                               item_labels={"Q3": "Q3: first", "q4": "Q4: second"})
    ax_tlx, ax_lik = fig.get_axes()
    assert [t.get_text() for t in ax_tlx.get_xticklabels()] == ["Raw TLX", "Weighted TLX"]
    assert [t.get_text().split("\n")[0] for t in ax_lik.get_xticklabels()] == ["Q3", "Q4"]
    assert _star_texts(ax_lik) == ["*"] and _star_texts(ax_tlx) == []
    inputs = FigureInputs(metrics=make_metrics(), stats=make_stats(DC, {}), questionnaires=scores)
    paths = write_figures(inputs, PlotPlan(tmp_path, ("png",)))
    assert [p.name for p in paths] == ["fig3.png", "fig4.png", "questionnaires.png"]


def test_questionnaires_of_four_conditions_get_letters_not_a_bracket_per_pair() -> None:
    """Four conditions have six pairs: as the box plots do, the bars get a compact letter display
    (the letters of nudgecli.report.letters, one per condition above its bar) and no brackets."""
    from nudgecli.report.letters import entry_letters

    four = ("disambiguation", "control", "blending", "teleoperation")
    likert = pd.DataFrame([{"participant": p, "condition": c, "likert_q3": 2 + 4 * (c == "control"),
                            "likert_q4": 4} for p in range(4) for c in four])
    stats = make_stats(four, {})
    first = stats["metrics"][0]["metric"]
    pairs = {("disambiguation", "control"): 0.001, ("control", "blending"): 0.002,
             ("control", "teleoperation"): 0.003}
    stats["metrics"] = [{**make_stats(four, {first: pairs})["metrics"][0], "metric": "likert_q3"}]
    fig = questionnaire_figure(None, likert, conditions=list(four), stats=stats)
    (ax,) = fig.get_axes()
    expected = entry_letters(stats["metrics"][0], list(four))
    assert len(set(expected.values())) == 2  # control apart from the other three
    assert _star_texts(ax) == []
    assert sorted(t.get_text() for t in ax.texts if t.get_text() in set(expected.values())) == \
        sorted(expected.values())


def test_likert_wording_comes_from_the_plan() -> None:
    from nudgecli.report.plans import load_plan

    likert = pd.DataFrame([{"participant": p, "condition": c, "likert_q3": 4, "likert_q10": 5}
                           for p in range(3) for c in DC])
    labels = load_plan("study-code").questionnaires.labels
    fig = questionnaire_figure(None, likert, item_labels=labels)
    ticks = [t.get_text().split("\n", 1) for t in fig.get_axes()[0].get_xticklabels()]
    assert [(code, " ".join(text.split())) for code, text in ticks] == [
        ("Q3", "figured out my goal more easily"), ("Q10", "helped reduce unwanted mode switches")]
    bare = questionnaire_figure(None, likert)
    assert [t.get_text() for t in bare.get_axes()[0].get_xticklabels()] == ["q3", "q10"]


# --- writing ----------------------------------------------------------------------------------------


def test_save_figure_atomic_and_formats(metrics2: pd.DataFrame, tmp_path: Path) -> None:
    fig = figure_4(metrics2, None)
    paths = save_figure(fig, tmp_path / "out", "fig4", ("png", "pdf", "svg"))
    assert [p.name for p in paths] == ["fig4.png", "fig4.pdf", "fig4.svg"]
    assert all(p.stat().st_size > 1000 for p in paths)
    assert sorted(os.listdir(tmp_path / "out")) == ["fig4.pdf", "fig4.png", "fig4.svg"]  # no temp files left
    assert paths[0].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ConfigError, match="jpeg"):
        save_figure(fig, tmp_path, "x", ("jpeg",))
    # Reproducible bytes: no timestamps or version strings in the files.
    again = save_figure(figure_4(metrics2, None), tmp_path / "again", "fig4", ("pdf", "svg"))
    assert again[0].read_bytes() == paths[1].read_bytes()
    assert again[1].read_bytes() == paths[2].read_bytes()


def test_trial_layout_checks_shapes_and_true_goal() -> None:
    with pytest.raises(DataError, match="shape"):
        TrialLayout(np.zeros((3, 2)), None, 0)
    with pytest.raises(DataError, match="true goal 3"):
        TrialLayout(GOALS, START, 3)


def test_save_figure_uses_the_usual_permissions(metrics2: pd.DataFrame, tmp_path: Path) -> None:
    # Files get 0666 minus the process's umask (as `touch` would), not a temporary file's 0600.
    umask = os.umask(0o022)
    os.umask(umask)
    paths = save_figure(figure_4(metrics2, None), tmp_path, "fig4", ("png", "svg"))
    assert [p.stat().st_mode & 0o777 for p in paths] == [0o666 & ~umask] * 2
    assert 0o666 & ~umask != 0o600  # the test can tell the two apart under this umask


def test_save_figure_cleans_up_on_failure(metrics2: pd.DataFrame, tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    fig = figure_4(metrics2, None)

    def boom(*args: object, **kwargs: object) -> None:
        raise RuntimeError("disk full")

    monkeypatch.setattr(fig, "savefig", boom)
    with pytest.raises(RuntimeError):
        save_figure(fig, tmp_path, "fig4", ("png",))
    assert os.listdir(tmp_path) == []


def test_write_figures_writes_everything(metrics2: pd.DataFrame, tmp_path: Path) -> None:
    stats = make_stats(("disambiguation", "control"), {"human_effort": {("disambiguation", "control"): 0.01}})
    trial_keys = list(metrics2.loc[metrics2.condition == "disambiguation", ["participant", "trial"]]
                      .itertuples(index=False, name=None))[:2]
    steps = pd.concat([make_steps(k[0], k[1], jump=0.1 + 0.3 * i) for i, k in enumerate(trial_keys)],
                      ignore_index=True)
    trials = metrics2.assign(true_goal=0)
    layouts = {k: LAYOUT for k in trial_keys}
    tlx = pd.DataFrame({"participant": [0, 0, 1, 1], "condition": ["disambiguation", "control"] * 2,
                        "tlx_raw": [30.0, 35.0, 28.0, 40.0]})
    inputs = FigureInputs(metrics=metrics2, stats=stats, trials=trials, steps=steps, layouts=layouts,
                          questionnaires=tlx)
    paths = write_figures(inputs, PlotPlan(tmp_path, ("png",)))
    assert [p.name for p in paths] == ["fig3.png", "fig4.png", "fig5.png", "trajectory.png",
                                       "questionnaires.png"]
    assert all(p.exists() for p in paths)
    # Metrics-only source: only the box plots.
    paths = write_figures(FigureInputs(metrics=metrics2, stats=stats), PlotPlan(tmp_path / "m", ("pdf",)))
    assert [p.name for p in paths] == ["fig3.pdf", "fig4.pdf"]
    with pytest.raises(DataError, match="trial 999"):
        write_figures(inputs, PlotPlan(tmp_path / "x", ("png",), trial=(0, 999)))


def test_metrics_figure_has_one_panel_per_metric(metrics2: pd.DataFrame) -> None:
    names = ["success", "completion_time", "human_turns", "mode_switches"]
    fig = metrics_figure(metrics2, None, names)
    visible = [ax for ax in fig.get_axes() if ax.get_visible()]
    assert [" ".join(ax.get_ylabel().split()) for ax in visible] == [METRIC_SPECS[m].label for m in names]
    assert [ax.get_title(loc="left") for ax in visible] == ["(a)", "(b)", "(c)", "(d)"]
    assert tuple(fig.get_size_inches()) == pytest.approx((7.2, 5.2))


# --- brackets follow the p-values and the plan's star rule ------------------------------------------


def test_bracket_positions_and_stars_follow_the_p_values(metrics3: pd.DataFrame) -> None:
    conds = ("disambiguation", "control", "full_state")
    pairs = {("disambiguation", "control"): 0.2, ("control", "full_state"): 0.004,
             ("disambiguation", "full_state"): 0.0004}
    stats = make_stats(conds, {"completion_time": pairs}, with_stars=False)
    out = metric_boxplot(metrics3, "completion_time", stats["metrics"][-1])
    drawn = {}
    for line, text in zip(out.brackets[::2], out.brackets[1::2], strict=True):
        span = (min(line.get_xdata()), max(line.get_xdata()))
        assert text.get_position()[0] == pytest.approx(sum(span) / 2)
        drawn[span] = text.get_text()
    pos = out.positions
    expected = {tuple(sorted((pos[a], pos[b]))): significance_stars(p) for (a, b), p in pairs.items()
                if significance_stars(p)}
    assert drawn == expected == {(1.0, 2.0): "**", (0.0, 2.0): "***"}


@pytest.mark.parametrize(("comparison", "stars"), [("<", "*"), ("<=", "**")])
def test_bracket_stars_follow_the_plans_comparison(metrics2: pd.DataFrame, comparison: str,
                                                    stars: str) -> None:
    # A Conover p exactly at the .01 threshold: one star under "<", two under "<=". An omnibus p
    # exactly at alpha = .05: the gate (same comparison) closes under "<" and opens under "<=".
    stats = make_stats(DC, {"human_effort": {DC: 0.01}}, kruskal_p={"human_effort": 0.04}, with_stars=False)
    rule = ComparisonOptions(star_comparison=comparison)  # type: ignore[arg-type]
    out = metric_boxplot(metrics2, "human_effort", stats["metrics"][4], star_rule=rule)
    assert [t.get_text() for t in out.brackets[1::2]] == [stars]
    gate = make_stats(DC, {"human_effort": {DC: 0.001}}, kruskal_p={"human_effort": 0.05}, with_stars=False)
    gated = metric_boxplot(metrics2, "human_effort", gate["metrics"][4], star_rule=rule).brackets
    assert [t.get_text() for t in gated[1::2]] == ([] if comparison == "<" else ["***"])


def test_box_colours_follow_the_condition_order(metrics2: pd.DataFrame) -> None:
    for order in (["disambiguation", "control"], ["control", "disambiguation"]):
        out = metric_boxplot(metrics2, "human_effort", conditions=order)
        faces = [mpl.colors.to_hex(out.boxes[c].get_facecolor(), keep_alpha=False) for c in order]
        assert faces == ["#0072b2", "#e69f00"]  # Okabe-Ito blue, then orange


def test_replication_panels_compose_and_colour_by_significance() -> None:
    from matplotlib.colors import to_hex

    from nudgecli.report.figures.replication import FOREST_COLOURS, forest_figure, forest_panel, power_panel

    rows = pd.DataFrame({"metric": "m", "replication": [0, 1, 2], "difference": [1.0, -2.0, 3.0],
                         "ci_low": [0.5, -3.0, 2.0], "ci_high": [1.5, -1.0, 4.0],
                         "participant_significant": [True, False, True]})
    pooled = pd.Series({"metric": "m", "a": "x", "b": "y", "difference": 0.7, "difference_low": -1.0,
                        "difference_high": 2.5})
    fig = Figure()
    ax = fig.subplots()
    assert forest_panel(rows, pooled, ax=ax) is ax  # draws on the axes it is given
    by_colour = {to_hex(line.get_color()): sorted(line.get_ydata())
                 for line in ax.lines if line.get_marker() == "o"}
    # the significant replications (0 and 2) in the significant colour, replication 1 in the other
    assert by_colour == {FOREST_COLOURS[True]: [0, 2], FOREST_COLOURS[False]: [1]}
    assert [line.get_xdata()[0] for line in ax.lines if line.get_linewidth() == 1.2] == [0.7]  # pooled mean
    assert forest_figure(rows, pd.DataFrame([pooled])).axes[0].get_title() == "m"
    power = pd.DataFrame({"metric": "m", "direction": "+", "level": ["participant", "trial"] * 2,
                          "participants": [4, 4, 8, 8], "power": [0.2, 0.1, 0.9, 0.6],
                          "low": [0.1, 0.0, 0.8, 0.5], "high": [0.3, 0.2, 1.0, 0.7]})
    drawn = power_panel(power, 0.8)
    solid = [line for line in drawn.lines if line.get_linestyle() == "-" and line.get_marker() == "o"]
    assert [list(line.get_ydata()) for line in solid] == [[0.2, 0.9]]  # participant level solid


def test_path_panels_compose_and_mark_each_switch_with_the_new_mode() -> None:
    from matplotlib.colors import to_hex

    from nudgecli.report.path_figures import _MODE_COLOURS, _MODE_MARKERS, path_panel, progress_panel

    n = 9
    steps = pd.DataFrame({"step": np.arange(n), "t": np.arange(n) / 10, "x": np.linspace(3, 11, n),
                          "y": np.full(n, 5.0), "theta": np.zeros(n),
                          "mode": ["x"] * 3 + ["y"] * 3 + ["theta"] * 3,
                          "event": ["", "", "mode_switch_human", "", "", "mode_switch_human", "", "", ""]})
    waypoints = np.array([[3.0, 5.0], [11.0, 5.0]])
    fig = Figure()
    ax, bx = fig.subplots(1, 2)
    assert path_panel(steps, waypoints, 1, np.array([11.0, 5.0, 0.0]), ax=ax) is ax
    switches = [(line.get_xdata()[0], line.get_marker(), to_hex(line.get_markerfacecolor()))
                for line in ax.lines if line.get_zorder() == 7]
    # the switch at step 2 leads into y, the one at step 5 into theta (x of those steps: 5, 8)
    assert switches == [(5.0, _MODE_MARKERS["y"], _MODE_COLOURS["y"].lower()),
                        (8.0, _MODE_MARKERS["theta"], _MODE_COLOURS["theta"].lower())]
    assert progress_panel(steps, waypoints, time_limit_s=3.0, ax=bx) is bx
    assert [line.get_xdata()[0] for line in bx.lines if line.get_linestyle() == "-."] == [3.0]  # time limit
    assert list(bx.lines[0].get_ydata()) == pytest.approx(np.linspace(0, 8, n))  # distance along the path


def test_compare_and_population_panels_compose() -> None:
    from matplotlib.colors import to_hex

    from nudgecli.model.interface import LABELS
    from nudgecli.report.compare import participant_medians
    from nudgecli.report.compare_figure import SOURCE_STYLE, compare_panel
    from nudgecli.report.population_figure import population_panel
    from nudgecli.sim.real_population import PILOT_DIAGONALS

    sim = pd.DataFrame({"participant": [1, 1, 2, 2], "condition": "A", "m": [1.0, 2.0, 3.0, 4.0]})
    real = pd.DataFrame({"participant": [7, 7, 8], "condition": "A", "m": [5.0, 6.0, 7.0]})
    fig = Figure()
    ax, bx = fig.subplots(1, 2)
    assert compare_panel({"simulated": sim, "real": real}, participant_medians(sim, real, ["m"]), "m", "A",
                         ax=ax) is ax
    steps = {line.get_linestyle(): (to_hex(line.get_color()), list(line.get_xdata())) for line in ax.lines
             if len(line.get_xdata()) > 2}
    # each source's ECDF in its own colour and line style, over its own trials
    assert steps == {"-": (to_hex(SOURCE_STYLE["simulated"]["color"]), [1.0, 1.0, 2.0, 3.0, 4.0]),
                     "--": (to_hex(SOURCE_STYLE["real"]["color"]), [5.0, 5.0, 6.0, 7.0])}
    dots = [c.get_offsets() for c in ax.collections]
    assert [list(d[:, 0]) for d in dots] == [[1.5, 3.5], [5.5, 7.0]]  # participants' medians
    simulated = pd.DataFrame([{"participant": 0, "stream": "fixed_rate", "label": label, "diagonal": 0.5}
                              for label in LABELS])
    assert population_panel(simulated, "fixed_rate", ax=bx) is bx
    diamonds = [c for c in bx.collections if len(c.get_offsets()) == len(PILOT_DIAGONALS)]
    first = LABELS[0]
    assert sorted(diamonds[0].get_offsets()[:, 1]) == sorted(v[first] for v in PILOT_DIAGONALS.values())
