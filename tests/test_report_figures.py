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
from nudgecli.model import world
from nudgecli.report import figures
from nudgecli.report.figures import (
    FIGURE3_METRICS,
    FIGURE4_METRICS,
    METRIC_SPECS,
    choose_figure5_trial,
    figure_3,
    figure_4,
    figure_5,
    layout_poses,
    metric_boxplot,
    nudge_followup_changes,
    plot_run,
    questionnaire_figure,
    resolve_conditions,
    save_figure,
    trajectory_figure,
)
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


def make_steps(participant: int = 0, trial: int = 0, n_goals: int = 3, jump: float = 0.4) -> pd.DataFrame:
    """One trial at 10 Hz: human turn, autonomy turn with a nudge, human turn where goal 0 jumps."""
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
            belief = [p0] + [others + spread * (g - 1) for g in range(1, n_goals)]
            belief = list(np.asarray(belief) / np.sum(belief))
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
        out = metric_boxplot(ax, metrics2, "completion_time", None, seed=seed)
        return {c: np.asarray(pc.get_offsets()) for c, pc in out.points.items()}

    first, second, other = dots(0), dots(0), dots(5)
    for c in first:
        np.testing.assert_array_equal(first[c], second[c])
        assert not np.array_equal(first[c][:, 0], other[c][:, 0])
        # Jitter is horizontal only: the y values are the data.
        expected = np.sort(metrics2.loc[metrics2["condition"] == c, "completion_time"].to_numpy())
        np.testing.assert_allclose(np.sort(first[c][:, 1]), expected)


def test_boxplot_drops_nan_and_scales_percent(metrics2: pd.DataFrame) -> None:
    fig = Figure()
    ax = fig.subplots()
    out = metric_boxplot(ax, metrics2, "assistance_strength", None)
    expected_n = metrics2.groupby("condition")["assistance_strength"].count().to_dict()
    assert out.n == expected_n
    ax2 = Figure().subplots()
    out2 = metric_boxplot(ax2, metrics2, "assistance_engagement", None)
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


# --- Figure 5 and trial choice -------------------------------------------------------------------------


def test_figure5_lines_shading_and_nudges() -> None:
    steps = make_steps()
    fig = figure_5(steps, 3, title="P0 T0")
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


def test_figure5_and_choice_from_parquet_roundtrip(tmp_path: Path) -> None:
    steps = pd.concat([make_steps(0, 0, jump=0.2), make_steps(0, 1, jump=0.5)], ignore_index=True)
    steps.to_parquet(tmp_path / "steps.parquet")
    back = pd.read_parquet(tmp_path / "steps.parquet")
    trials = pd.DataFrame({"participant": [0, 0], "trial": [0, 1], "condition": ["disambiguation"] * 2})
    assert choose_figure5_trial(back, trials) == (0, 1)
    fig = figure_5(back[back.trial == 1], GOALS)
    assert len([ln for ln in fig.get_axes()[0].lines if len(ln.get_xdata()) > 2]) == 3


def test_figure5_belief_length_mismatch() -> None:
    with pytest.raises(DataError, match="goals"):
        figure_5(make_steps(n_goals=3), 4)


def test_nudge_followup_changes() -> None:
    changes = nudge_followup_changes(make_steps(jump=0.4))
    assert len(changes) == 1
    assert changes[0] == pytest.approx(0.4, abs=0.02)


def test_choose_figure5_trial() -> None:
    steps = pd.concat([make_steps(0, 0, jump=0.2), make_steps(0, 1, jump=0.5), make_steps(1, 2, jump=0.3),
                       make_steps(1, 3, jump=0.6)], ignore_index=True)
    trials = pd.DataFrame({"participant": [0, 0, 1, 1], "trial": [0, 1, 2, 3],
                           "condition": ["disambiguation", "disambiguation", "disambiguation", "control"],
                           "success": [True, True, True, True]})
    assert choose_figure5_trial(steps, trials) == (0, 1)  # (1, 3) jumps more but is a Control trial
    trials.loc[1, "success"] = False
    assert choose_figure5_trial(steps, trials) == (1, 2)
    mapping = {k: df for k, df in steps.groupby(["participant", "trial"])}
    assert choose_figure5_trial(mapping, trials) == (1, 2)
    # Without nudges: the largest human-turn rise of a Disambiguation trial.
    no_nudge = steps.assign(event="")
    assert choose_figure5_trial(no_nudge, trials.assign(success=True)) == (0, 1)


# --- trajectory and questionnaires --------------------------------------------------------------------


def test_trajectory_figure() -> None:
    steps = make_steps()
    fig = trajectory_figure(steps, GOALS, START, title="P0 T0")
    ax = fig.get_axes()[0]
    assert ax.get_xlim() == (3.0, 45.0) and ax.get_ylim() == (2.0, 36.0)
    assert ax.get_xlabel().startswith("x") and ax.get_ylabel().startswith("y")
    texts = [t.get_text() for t in ax.texts]
    assert texts == ["g0 (true)", "g1", "g2"]
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"Human drove", "Autonomy drove", "Start", "g0 (true goal)", "g1", "g2", "Nudge"} <= set(labels)
    assert min(_all_font_sizes(fig)) >= MIN_FONT_PT


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
    fig = questionnaire_figure(tlx, likert, conditions=list(DC), stats=stats)
    ax_tlx, ax_lik = fig.get_axes()
    assert [t.get_text() for t in ax_tlx.get_xticklabels()] == ["Raw TLX", "Weighted TLX"]
    assert [t.get_text().split("\n")[0] for t in ax_lik.get_xticklabels()] == ["Q3", "Q4"]
    assert _star_texts(ax_lik) == ["*"] and _star_texts(ax_tlx) == []
    paths = plot_run(make_metrics(), None, None, None, tmp_path, ("png",), questionnaires=scores)
    assert [p.name for p in paths] == ["fig3.png", "fig4.png", "questionnaires.png"]


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


def test_layout_poses_accepts_world_layout() -> None:
    layout = world.sample_layout(np.random.default_rng(2), "tr", 4, 0)
    goals, start = layout_poses(layout)
    assert goals.shape == (4, 3) and start is not None and start.shape == (3,)
    np.testing.assert_allclose(goals, layout.goal_poses)
    goals, start = layout_poses((GOALS, START))
    np.testing.assert_allclose(goals, GOALS)
    with pytest.raises(DataError, match="shape"):
        layout_poses({"goal_poses": np.zeros((3, 2))})


def test_save_figure_cleans_up_on_failure(metrics2: pd.DataFrame, tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    fig = figure_4(metrics2, None)

    def boom(*args: object, **kwargs: object) -> None:
        raise RuntimeError("disk full")

    monkeypatch.setattr(fig, "savefig", boom)
    with pytest.raises(RuntimeError):
        save_figure(fig, tmp_path, "fig4", ("png",))
    assert os.listdir(tmp_path) == []


def test_plot_run_writes_everything(metrics2: pd.DataFrame, tmp_path: Path) -> None:
    stats = make_stats(("disambiguation", "control"), {"human_effort": {("disambiguation", "control"): 0.01}})
    trial_keys = list(metrics2.loc[metrics2.condition == "disambiguation", ["participant", "trial"]]
                      .itertuples(index=False, name=None))[:2]
    steps = {k: make_steps(k[0], k[1], jump=0.1 + 0.3 * i) for i, k in enumerate(trial_keys)}
    layouts = {k: {"goal_poses": GOALS, "start_pose": START} for k in trial_keys}
    tlx = pd.DataFrame({"participant": [0, 0, 1, 1], "condition": ["disambiguation", "control"] * 2,
                        "raw_tlx": [30.0, 35.0, 28.0, 40.0]})
    paths = plot_run(metrics2, stats, steps, layouts, tmp_path, ("png",), tlx=tlx)
    assert [p.name for p in paths] == ["fig3.png", "fig4.png", "fig5.png", "trajectory.png",
                                       "questionnaires.png"]
    assert all(p.exists() for p in paths)
    # Metrics-only source: only the box plots.
    paths = plot_run(metrics2, stats, None, None, tmp_path / "m", ("pdf",))
    assert [p.name for p in paths] == ["fig3.pdf", "fig4.pdf"]
    with pytest.raises(DataError, match="trial 999"):
        plot_run(metrics2, stats, steps, layouts, tmp_path / "x", ("png",), trial=(0, 999))

