"""`nudge plot` and `nudge run` on a real (smoke) run: every figure, its labels, its brackets, bad inputs.

One smoke study is simulated and analysed in-process per module (``run_study`` + ``analyze``,
about a second); tests that change a run work on a copy of it.
"""

from __future__ import annotations

import copy
import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner, Result
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.report import figures
from nudgecli.report.analysis import analyze
from nudgecli.report.figure_records import recorded_figures
from nudgecli.report.figures import (
    FIGURE3_METRICS,
    FIGURE4_METRICS,
    figure_3,
    figure_4,
    figure_5,
    questionnaire_figure,
    split_questionnaire_scores,
    trajectory_figure,
)
from nudgecli.report.plotting import analysis_folder_of_table, layouts_by_trial
from nudgecli.report.style import condition_display_name, figure_style
from nudgecli.report.trial_selection import choose_figure5_trial
from nudgecli.run_folder_names import FIGURES_RECORD
from nudgecli.runs.study import run_study
from nudgecli.store import RunFolder

QUESTIONNAIRES_CSV = Path(__file__).parent / "data" / "questionnaires_smoke_run.csv"
CONDITIONS = ("disambiguation", "control")
#: fig3/fig4 hold six of the paper plan's metrics; `metrics` the remaining one (success).
ALL_STEMS = {"fig3", "fig4", "metrics", "fig5", "trajectory", "questionnaires"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FILE_MAGIC = {"png": PNG_MAGIC, "pdf": b"%PDF", "svg": b"<?xml"}


# --- the shared smoke run ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def simulated_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The smoke study (2 participants x 8 trials), simulated but not analysed. Do not modify."""
    run = run_study(load_experiment("smoke"), tmp_path_factory.mktemp("smoke") / "simulated")
    return run.path


@pytest.fixture(scope="module")
def analysed_run(simulated_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the smoke run analysed with the paper plan and the questionnaire table."""
    folder = tmp_path_factory.mktemp("smoke") / "analysed"
    shutil.copytree(simulated_run, folder)
    analyze(folder, plan="paper", questionnaires=QUESTIONNAIRES_CSV)
    return folder


@dataclass
class RunData:
    metrics: pd.DataFrame
    stats: dict[str, Any]
    trials: pd.DataFrame
    steps: pd.DataFrame
    layouts: dict[tuple[int, int], Any]
    questionnaires: pd.DataFrame

    def trial_steps(self, key: tuple[int, int]) -> pd.DataFrame:
        return self.steps[(self.steps["participant"] == key[0]) & (self.steps["trial"] == key[1])]


@pytest.fixture(scope="module")
def run_data(analysed_run: Path) -> RunData:
    run = RunFolder(analysed_run)
    trials = run.read_trials()
    return RunData(metrics=pd.read_csv(analysed_run / "metrics.csv"),
                   stats=json.loads((analysed_run / "stats.json").read_text(encoding="utf-8")),
                   trials=trials, steps=run.read_steps(),
                   layouts=layouts_by_trial(trials, run.read_layouts()),
                   questionnaires=pd.read_csv(analysed_run / "questionnaire_scores.csv"))


@pytest.fixture(scope="module")
def default_plot(analysed_run: Path) -> Result:
    """``nudge plot RUN`` with the default formats and folder."""
    return CliRunner().invoke(main, ["plot", str(analysed_run)])


def _copy_run(source: Path, target: Path) -> Path:
    shutil.copytree(source, target)
    return target


def _plot(*args: str) -> Result:
    return CliRunner().invoke(main, ["plot", *args])


def _single_error_line(result: Result) -> str:
    """The one ``Error:`` line of a failed command (asserts exit status 1 and nothing else printed)."""
    assert result.exit_code == 1, (result.output, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    assert result.stdout == ""
    return lines[0]


def _star_texts(ax: Axes) -> list[str]:
    return sorted(t.get_text() for t in ax.texts if t.get_text() and set(t.get_text()) == {"*"})


def _expected_stars(entry: dict[str, Any]) -> list[str]:
    return sorted(row["stars"] for row in entry["stars"] if row["stars"])


def _figure_paths(folder: Path) -> list[Path]:
    """The files in a folder but plot's record of the figures it wrote (``FIGURES_RECORD``)."""
    return sorted(path for path in folder.iterdir() if path.name != FIGURES_RECORD)


def _written_files(folder: Path) -> dict[str, set[str]]:
    """``stem -> {suffixes}`` of the files in a folder (no hidden temporaries expected)."""
    found: dict[str, set[str]] = {}
    for path in _figure_paths(folder):
        found.setdefault(path.stem, set()).add(path.suffix.lstrip("."))
    return found


def _assert_valid_files(paths: list[Path]) -> None:
    for path in paths:
        data = path.read_bytes()
        assert data.startswith(FILE_MAGIC[path.suffix.lstrip(".")]), path
        assert len(data) > 1000, path


# --- `nudge plot` writes every figure -----------------------------------------------------------


def test_plot_writes_every_figure_as_png_and_pdf_into_run_figures(default_plot: Result,
                                                                   analysed_run: Path) -> None:
    assert default_plot.exit_code == 0, (default_plot.output, default_plot.exception)
    folder = analysed_run / "figures"
    assert _written_files(folder) == {stem: {"png", "pdf"} for stem in ALL_STEMS}
    _assert_valid_files(_figure_paths(folder))


def test_plot_lists_exactly_the_written_paths_on_stdout(default_plot: Result, analysed_run: Path) -> None:
    listed = [Path(line) for line in default_plot.stdout.splitlines()]
    assert len(listed) == len(set(listed)) == 2 * len(ALL_STEMS)
    assert set(listed) == set(_figure_paths(analysed_run / "figures"))
    # and plot's record of them, for the next plot there to remove those it does not draw again
    assert recorded_figures(analysed_run / "figures") == (sorted(path.name for path in listed), None)


def test_plot_out_elsewhere_with_svg_leaves_the_run_folder_alone(analysed_run: Path, tmp_path: Path) -> None:
    run = _copy_run(analysed_run, tmp_path / "run")
    shutil.rmtree(run / "figures", ignore_errors=True)
    out = tmp_path / "elsewhere"
    result = _plot(str(run), "--out", str(out), "--formats", "png,svg")
    assert result.exit_code == 0, (result.output, result.exception)
    assert _written_files(out) == {stem: {"png", "svg"} for stem in ALL_STEMS}
    assert {Path(line) for line in result.stdout.splitlines()} == set(_figure_paths(out))
    _assert_valid_files(_figure_paths(out))
    assert not (run / "figures").exists()


def test_plot_trial_option_draws_that_trial_in_fig5_and_trajectory(analysed_run: Path, run_data: RunData,
                                                                    tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    default = choose_figure5_trial(run_data.steps, run_data.trials)
    chosen = next(key for key in sorted(run_data.layouts) if key != default)
    drawn: dict[str, tuple[set[tuple[int, int]], str | None]] = {}

    def recording(name: str, original: Callable[..., Figure]) -> Callable[..., Figure]:
        def wrapper(steps: pd.DataFrame, *args: Any, **kwargs: Any) -> Figure:
            keys = set(zip(steps["participant"], steps["trial"], strict=True))
            drawn[name] = ({(int(p), int(t)) for p, t in keys}, kwargs.get("title"))
            return original(steps, *args, **kwargs)
        return wrapper

    monkeypatch.setattr(figures, "figure_5", recording("fig5", figures.figure_5))
    monkeypatch.setattr(figures, "trajectory_figure", recording("trajectory", figures.trajectory_figure))
    result = _plot(str(analysed_run), "--out", str(tmp_path), "--formats", "png",
                   "--trial", f"{chosen[0]}:{chosen[1]}")
    assert result.exit_code == 0, (result.output, result.exception)
    condition = run_data.trials.set_index(["participant", "trial"]).loc[chosen, "condition"]
    title = f"Participant {chosen[0]}, trial {chosen[1]} ({condition_display_name(condition)})"
    assert drawn == {"fig5": ({chosen}, title), "trajectory": ({chosen}, title)}


def test_plot_inputs_of_a_run_hold_the_shown_trials_participant_only(
        analysed_run: Path, run_data: RunData, monkeypatch: pytest.MonkeyPatch) -> None:
    from nudgecli.report.plotting import read_inputs

    default = choose_figure5_trial(run_data.steps, run_data.trials)  # from the whole step log
    steps_read: list[Any] = []
    read_table = RunFolder.read_table

    def recording(self: RunFolder, kind: str, *args: Any, **kwargs: Any) -> pd.DataFrame:
        if kind == "steps":
            steps_read.append(kwargs.get("participants"))
        return read_table(self, kind, *args, **kwargs)

    monkeypatch.setattr(RunFolder, "read_table", recording)
    inputs = read_inputs(analysed_run)
    # the rule read each participant's part on its own, then the chosen one's whole
    assert steps_read and all(participants is not None and len(participants) == 1
                              for participants in steps_read)
    assert {participants[0] for participants in steps_read} == set(run_data.trials["participant"])
    assert inputs.trial == default and inputs.steps is not None
    assert set(inputs.steps["participant"]) == {default[0]}
    expected = run_data.steps[run_data.steps["participant"] == default[0]].reset_index(drop=True)
    pd.testing.assert_frame_equal(inputs.steps, expected)
    other = next(key for key in sorted(run_data.layouts) if key[0] != default[0])
    asked = read_inputs(analysed_run, other)
    assert asked.trial == other and set(asked.steps["participant"]) == {other[0]}


def test_plot_of_a_run_missing_a_step_part_names_it_and_the_restore_command(analysed_run: Path,
                                                                             tmp_path: Path) -> None:
    run = _copy_run(analysed_run, tmp_path / "run")
    (run / "steps" / "part-0001.parquet").unlink()
    result = _plot(str(run), "--trial", "1:0", "--out", str(tmp_path / "figures"))
    line = _single_error_line(result)
    assert "participant 1: steps/part-0001.parquet (missing)" in line and "--resume" in line
    assert not (tmp_path / "figures").exists()


def test_a_run_folder_reads_the_parts_of_the_participants_asked_and_checks_them(simulated_run: Path,
                                                                               tmp_path: Path) -> None:
    from nudgecli.errors import RunFolderError

    run = RunFolder(_copy_run(simulated_run, tmp_path / "run"))
    whole = run.read_steps()
    one = run.read_table("steps", participants=[1])
    pd.testing.assert_frame_equal(one, whole[whole["participant"] == 1].reset_index(drop=True))
    with (run.path / "steps" / "part-0000.parquet").open("ab") as part:
        part.write(b"edited")  # another participant's part is not read, so not checked
    pd.testing.assert_frame_equal(run.read_table("steps", participants=[1]), one)
    with pytest.raises(RunFolderError, match=r"part-0000\.parquet changed"):
        run.read_table("steps", participants=[0])


@pytest.mark.parametrize(("args", "message"), [
    (["--trial", "0-3"], "expected PARTICIPANT:TRIAL"),
    (["--trial", "one:two"], "expected PARTICIPANT:TRIAL"),
    (["--trial", "1:2:3"], "expected PARTICIPANT:TRIAL"),
    (["--trial", "7:0"], "no such trial"),
    (["--trial", "0:99"], "no such trial"),
    (["--formats", "png,gif"], "choose from png, pdf, svg"),
    (["--formats", ","], "choose from png, pdf, svg"),
], ids=["trial-dash", "trial-words", "trial-three-parts", "unknown-participant", "unknown-trial",
        "format-gif", "format-empty"])
def test_plot_bad_trial_or_formats_is_one_error_line_and_writes_nothing(
        analysed_run: Path, tmp_path: Path, args: list[str], message: str) -> None:
    out = tmp_path / "figures"
    line = _single_error_line(_plot(str(analysed_run), "--out", str(out), *args))
    assert message in line
    assert not out.exists()


# --- `nudge plot` on something that is not an analysed run --------------------------------------


def test_plot_refuses_what_is_not_a_run_and_says_to_simulate(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    (tmp_path / "a_file.txt").write_text("not a run\n")
    for name, what in (("empty", "not a run folder"), ("a_file.txt", "a file, not a folder"),
                       ("missing", "no such folder")):
        line = _single_error_line(_plot(str(tmp_path / name)))
        assert what in line and "`nudge simulate`" in line, (name, line)
    assert not (tmp_path / "empty" / "figures").exists()
    assert not (tmp_path / "missing").exists()


def test_plot_of_a_simulated_but_unanalysed_run_says_to_analyze(simulated_run: Path) -> None:
    line = _single_error_line(_plot(str(simulated_run)))
    assert f"`nudge analyze {simulated_run}`" in line
    assert not (simulated_run / "figures").exists()


def test_plot_with_plan_analyses_an_unanalysed_run_then_plots(simulated_run: Path, tmp_path: Path) -> None:
    run = _copy_run(simulated_run, tmp_path / "run")
    result = _plot(str(run), "--plan", "paper", "--formats", "png")
    assert result.exit_code == 0, (result.output, result.exception)
    stats = json.loads((run / "stats.json").read_text(encoding="utf-8"))
    assert {e["metric"] for e in stats["metrics"]} >= set(FIGURE3_METRICS) | set(FIGURE4_METRICS)
    assert (run / "metrics.csv").is_file()
    assert _written_files(run / "figures") == {stem: {"png"} for stem in ALL_STEMS - {"questionnaires"}}


@pytest.mark.parametrize(("manifest", "expected"), [
    ({"experiment": "baselines"}, "baselines"),  # the plan named like the experiment
    ({"experiment": "ciaa-teleop"}, "ciaa-teleop"),
    ({"experiment": "a-new-study"}, "paper"),  # no plan of that name
    ({"experiment": "baselines", "plan": "study-code"}, "study-code"),  # the plan the run recorded wins
])
def test_plot_takes_the_plan_of_the_runs_experiment(simulated_run: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch, manifest: dict[str, str],
                                                    expected: str) -> None:
    # one rule for the plan (config_files.resolve_plan), as analyze and run: the plan given, else the
    # run's recorded plan, else the plan named like its experiment, else paper
    from nudgecli.report import plotting
    from nudgecli.report.plans import load_plan

    run = _copy_run(simulated_run, tmp_path / "run")
    recorded = {k: v for k, v in json.loads((run / "manifest.json").read_text()).items() if k != "plan"}
    (run / "manifest.json").write_text(json.dumps({**recorded, **manifest}))
    seen: dict[str, Any] = {}
    monkeypatch.setattr(plotting, "plot_folder", lambda *args, **kwargs: seen.update(kwargs) or [])
    result = _plot(str(run))
    assert result.exit_code == 0, (result.output, result.exception)
    plan = load_plan(expected)
    assert (seen["star_rule"], seen["item_labels"]) == (plan.comparison_options(), plan.questionnaires.labels)
    if expected in ("baselines", "ciaa-teleop"):  # what tells these plans from the paper's
        assert seen["item_labels"] != load_plan("paper").questionnaires.labels
    if expected == "study-code":
        assert seen["star_rule"] != load_plan("paper").comparison_options()


# --- `nudge run` ---------------------------------------------------------------------------------


def test_run_smoke_leaves_stats_summary_metrics_and_figures_and_prints_the_folder_last(
        tmp_path: Path) -> None:
    out = tmp_path / "smoke-run"
    result = CliRunner().invoke(main, ["run", "smoke", "--out", str(out)])
    assert result.exit_code == 0, (result.output, result.exception)
    assert result.stdout.strip().splitlines()[-1] == str(out)
    for name in ("stats.json", "summary.md", "metrics.csv"):
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "stats.json").read_text(encoding="utf-8"))["conditions"] == list(CONDITIONS)
    assert _written_files(out / "figures") == {stem: {"png", "pdf"}
                                               for stem in ALL_STEMS - {"questionnaires"}}
    _assert_valid_files(_figure_paths(out / "figures"))


def test_run_plots_with_the_plan_it_analysed_with(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the smoke study named "study-code": run analyses with that plan, and plots with its star rule
    from nudgecli.config_files import list_presets
    from nudgecli.report import plotting
    from nudgecli.report.plans import load_plan

    experiment = tmp_path / "experiment.toml"
    experiment.write_text(list_presets("experiments")["smoke"].read_text().replace(
        'name = "smoke"', 'name = "study-code"'))
    seen: dict[str, Any] = {}
    monkeypatch.setattr(plotting, "plot_folder", lambda *args, **kwargs: seen.update(kwargs) or [])
    result = CliRunner().invoke(main, ["run", str(experiment), "--out", str(tmp_path / "run")])
    assert result.exit_code == 0, (result.output, result.exception)
    plan = load_plan("study-code")
    assert (seen["star_rule"], seen["item_labels"]) == (plan.comparison_options(), plan.questionnaires.labels)
    assert seen["star_rule"] != load_plan("paper").comparison_options()


# --- the figures of the run: axes, labels, brackets -----------------------------------------------


@pytest.mark.parametrize(("draw", "metric_names"), [(figure_3, FIGURE3_METRICS), (figure_4, FIGURE4_METRICS)],
                         ids=["fig3", "fig4"])
def test_box_plot_panels_have_letters_labels_and_condition_ticks(
        run_data: RunData, draw: Callable[..., Figure], metric_names: tuple[str, ...]) -> None:
    fig = draw(run_data.metrics, run_data.stats)
    assert len(fig.axes) == len(metric_names)
    names = [condition_display_name(c) for c in CONDITIONS]
    for i, (ax, metric) in enumerate(zip(fig.axes, metric_names, strict=True)):
        assert ax.get_title(loc="left") == f"({'abc'[i]})", metric
        assert ax.get_ylabel().strip(), metric
        ticks = [t.get_text() for t in ax.get_xticklabels()]
        assert [t.split("\n")[0] for t in ticks] == names, metric
        # n counts the trials with a value (the paper's completion time skips failed trials)
        counts = run_data.metrics.groupby("condition")[metric].count()
        expected = [f"n = {counts[c]}" for c in CONDITIONS]
        assert all(n in t for n, t in zip(expected, ticks, strict=True)), (metric, ticks)


@pytest.mark.parametrize("metric", ["human_turns", "mode_switches"])
def test_count_metrics_have_whole_number_ticks(run_data: RunData, metric: str) -> None:
    draw, names = (figure_3, FIGURE3_METRICS) if metric in FIGURE3_METRICS else (figure_4, FIGURE4_METRICS)
    fig = draw(run_data.metrics, run_data.stats)
    ax = fig.axes[names.index(metric)]
    with figure_style():  # as save_figure renders it: the tick count depends on the style's font size
        FigureCanvasAgg(fig).draw()
        low, high = ax.get_ylim()
        shown = [t for t in ax.get_yticks() if low <= t <= high]
    assert len(shown) >= 2 and all(float(t).is_integer() for t in shown), shown


def _restarred(stats: dict[str, Any], stars: str | None) -> dict[str, Any]:
    """A copy of ``stats`` with every comparison's stars set to ``stars`` (``None``: unchanged)."""
    out = copy.deepcopy(stats)
    if stars is not None:
        for entry in out["metrics"]:
            for row in entry["stars"]:
                row["stars"] = stars
    return out


@pytest.mark.parametrize("stars", [None, "**", ""], ids=["as-analysed", "all-starred", "none-starred"])
def test_box_plot_star_texts_match_the_stars_of_stats_json(run_data: RunData, stars: str | None) -> None:
    stats = _restarred(run_data.stats, stars)
    checked = 0
    for draw, metric_names in ((figure_3, FIGURE3_METRICS), (figure_4, FIGURE4_METRICS)):
        fig = draw(run_data.metrics, stats)
        for entry in stats["metrics"]:
            if entry["metric"] in metric_names:
                ax = fig.axes[metric_names.index(entry["metric"])]
                assert _star_texts(ax) == _expected_stars(entry), entry["metric"]
                checked += 1
    assert checked == len(FIGURE3_METRICS) + len(FIGURE4_METRICS)


def _effort_stats(kruskal_p: float, conover_p: float, stars: str | None) -> dict[str, Any]:
    """stats.json with one comparison of human effort (``stars`` None: no "stars" key at all)."""
    entry: dict[str, Any] = {
        "metric": "human_effort", "kruskal": {"statistic": 1.0, "p": kruskal_p},
        "conover": [{"a": "disambiguation", "b": "control", "p": conover_p, "p_unadjusted": conover_p}],
        "p_adjust": "holm"}
    if stars is not None:
        entry["stars"] = [{"a": "disambiguation", "b": "control", "stars": stars}]
    return {"conditions": list(CONDITIONS), "metrics": [entry]}


def _effort_axes(run_data: RunData, stats: dict[str, Any]) -> Axes:
    return figure_4(run_data.metrics, stats).axes[FIGURE4_METRICS.index("human_effort")]


@pytest.mark.parametrize("stars", ["", None], ids=["stars-empty", "stars-absent"])
def test_no_bracket_when_conover_is_tiny_but_kruskal_wallis_is_not_significant(run_data: RunData,
                                                                                 stars: str | None) -> None:
    ax = _effort_axes(run_data, _effort_stats(kruskal_p=0.2, conover_p=1e-9, stars=stars))
    assert _star_texts(ax) == []
    assert not [line for line in ax.lines if len(line.get_xdata()) == 4]


def test_bracket_follows_study_code_stars_at_p_exactly_005(run_data: RunData) -> None:
    # The study code stars p <= .05; the paper's rule (p < .05) would give none at p = .05.
    ax = _effort_axes(run_data, _effort_stats(kruskal_p=0.05, conover_p=0.05, stars="*"))
    assert _star_texts(ax) == ["*"]
    (bracket,) = [line for line in ax.lines if len(line.get_xdata()) == 4]
    assert list(bracket.get_xdata()) == [0.0, 0.0, 1.0, 1.0]
    effort = run_data.metrics["human_effort"].max()
    assert min(bracket.get_ydata()) > effort


def test_no_bracket_when_stats_json_gives_no_stars_even_if_p_is_tiny(run_data: RunData) -> None:
    ax = _effort_axes(run_data, _effort_stats(kruskal_p=1e-6, conover_p=1e-6, stars=""))
    assert _star_texts(ax) == []


def test_fig5_and_trajectory_of_the_default_trial_are_labelled(run_data: RunData) -> None:
    key = choose_figure5_trial(run_data.steps, run_data.trials)
    steps, layout = run_data.trial_steps(key), run_data.layouts[key]
    n_goals = layout.n_goals
    true_goal = int(run_data.trials.set_index(["participant", "trial"]).loc[key, "true_goal"])
    assert layout.true_goal == true_goal

    fig5 = figure_5(steps, true_goal, n_goals, title=f"Participant {key[0]}, trial {key[1]}")
    (ax,) = fig5.axes
    assert ax.get_xlabel() == "Time (s)" and ax.get_ylabel().strip()
    assert ax.get_title(loc="left") == f"Participant {key[0]}, trial {key[1]}"
    assert ax.get_ylim() == (0.0, 1.0)
    labels = [t.get_text() for t in fig5.legends[0].get_texts()]
    assert labels[:n_goals] == [f"Goal {g}" + (" (true)" if g == true_goal else "") for g in range(n_goals)]
    assert {"Human turn", "Autonomy turn"} <= set(labels)

    trajectory = trajectory_figure(steps, layout, title="t")
    (ax,) = trajectory.axes
    assert ax.get_xlabel().strip() and ax.get_ylabel().strip()
    assert trajectory.legends and trajectory.legends[0].get_texts()


def test_questionnaire_figure_of_the_run_has_labelled_panels_and_stats_json_stars(run_data: RunData) -> None:
    tlx, likert = split_questionnaire_scores(run_data.questionnaires)
    fig = questionnaire_figure(tlx, likert, stats=run_data.stats)
    assert len(fig.axes) == 2
    by_name = {e["metric"]: e for e in run_data.stats["metrics"]}
    for i, (ax, prefix) in enumerate(zip(fig.axes, ("tlx_", "likert_"), strict=True)):
        assert ax.get_title(loc="left") == f"({'ab'[i]})"
        assert ax.get_ylabel().strip()
        assert all(t.get_text().strip() for t in ax.get_xticklabels())
        expected = sorted(s for name, e in by_name.items() if name.startswith(prefix)
                          for s in _expected_stars(e))
        assert expected, f"the fixture's {prefix} scores should differ significantly"
        assert _star_texts(ax) == expected
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == [condition_display_name(c) for c in CONDITIONS]


def test_star_text_sits_above_every_trial_dot(run_data: RunData) -> None:
    stats = _restarred(run_data.stats, "*")
    fig = figure_4(run_data.metrics, stats)
    for ax in fig.axes:
        (star,) = [t for t in ax.texts if t.get_text() == "*"]
        dots_top = max(np.max(c.get_offsets()[:, 1]) for c in ax.collections if len(c.get_offsets()))
        assert star.get_position()[1] > dots_top
        assert star.get_position()[1] < ax.get_ylim()[1]


# --- `nudge plot` checks the statistics it draws ---------------------------------------------------


def test_plot_refuses_stats_computed_from_other_metrics(analysed_run: Path, tmp_path: Path) -> None:
    run = _copy_run(analysed_run, tmp_path / "run")
    shutil.rmtree(run / "figures", ignore_errors=True)
    metrics = pd.read_csv(run / "metrics.csv")
    metrics.loc[0, "human_effort"] = metrics["human_effort"].iloc[0] + 0.25  # one trial changed
    metrics.to_csv(run / "metrics.csv", index=False)
    line = _single_error_line(_plot(str(run), "--formats", "png"))
    assert f"{run / 'stats.json'} does not match {run / 'metrics.csv'}" in line
    assert "`nudge analyze`" in line
    assert not (run / "figures").exists()


def test_plot_refuses_a_condition_without_data(analysed_run: Path, tmp_path: Path) -> None:
    # A stale stats.json of a table whose control trials were since removed: not an empty box.
    run = _copy_run(analysed_run, tmp_path / "run")
    metrics = pd.read_csv(run / "metrics.csv")
    metrics[metrics["condition"] == "disambiguation"].to_csv(run / "metrics.csv", index=False)
    line = _single_error_line(_plot(str(run), "--formats", "png"))
    assert "condition" in line or "does not match" in line


@pytest.mark.parametrize(("text", "message"), [
    ('{"conditions": ["disambiguation", "control"], "metrics": [', "not valid JSON"),
    ("[1, 2]", "no `metrics` list"),
    ('{"conditions": [], "metrics": []}', "no checksum"),
], ids=["truncated", "not-an-object", "no-checksum"])
def test_plot_of_a_broken_stats_json_is_one_error_line(analysed_run: Path, tmp_path: Path, text: str,
                                                       message: str) -> None:
    run = _copy_run(analysed_run, tmp_path / "run")
    (run / "stats.json").write_text(text, encoding="utf-8")
    line = _single_error_line(_plot(str(run), "--out", str(tmp_path / "f")))
    assert message in line and str(run / "stats.json") in line
    assert not (tmp_path / "f").exists()


def test_a_hand_edited_p_value_is_refused_only_through_the_data_it_claims(analysed_run: Path,
                                                                            tmp_path: Path) -> None:
    # The checksum covers the metrics, not the p-values: re-analysing restores agreement.
    run = _copy_run(analysed_run, tmp_path / "run")
    metrics = pd.read_csv(run / "metrics.csv")
    metrics.loc[3, "completion_time"] = 1e6
    metrics.to_csv(run / "metrics.csv", index=False)
    assert _plot(str(run), "--formats", "png").exit_code == 1
    # the run's analysis again, its questionnaires too (plot draws only the scores its stats.json records)
    analyze(run / "metrics.csv", plan="paper", out=tmp_path / "again", questionnaires=QUESTIONNAIRES_CSV)
    for name in ("stats.json", "questionnaire_scores.csv"):
        shutil.copy(tmp_path / "again" / name, run / name)
    assert _plot(str(run), "--formats", "png").exit_code == 0


# --- `nudge plot` on a real metrics table -------------------------------------------------------------


def _real_table(tmp_path: Path, metrics: dict[str, Callable[[np.random.Generator, int], float]]) -> Path:
    """A metrics table of 6 participants x 2 conditions x 5 trials with the given metric columns."""
    rng = np.random.default_rng(7)
    rows = [{"participant": p, "condition": c, "trial": t,
             **{name: draw(rng, ci) for name, draw in metrics.items()}}
            for p in range(6) for ci, c in enumerate(("assisted", "manual")) for t in range(5)]
    path = tmp_path / "study.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def test_plot_of_a_table_with_other_metrics_draws_one_panel_each(tmp_path: Path) -> None:
    table = _real_table(tmp_path, {"workload": lambda r, c: float(r.normal(50 + 10 * c, 5)),
                                   "errors": lambda r, c: float(r.integers(0, 4 + c))})
    analyze(table, plan="paper")
    folder = analysis_folder_of_table(table)
    for source in (table, folder):  # the table itself, or the folder its analysis went to
        out = tmp_path / f"figures-{source.name}"
        result = _plot(str(source), "--out", str(out), "--formats", "png")
        assert result.exit_code == 0, (result.output, result.exception)
        assert _written_files(out) == {"metrics": {"png"}}
    fig = figures.metrics_figure(pd.read_csv(table), json.loads((folder / "stats.json").read_text()),
                                 ["workload", "errors"])
    labels = [" ".join(ax.get_ylabel().split()) for ax in fig.axes if ax.get_visible()]
    assert labels == ["Workload", "Errors"]


def test_plot_of_a_table_with_the_papers_metrics_uses_the_papers_layout(run_data: RunData,
                                                                         tmp_path: Path) -> None:
    table = tmp_path / "real.csv"
    run_data.metrics.drop(columns=["success"]).to_csv(table, index=False)
    analyze(table, plan="paper")
    result = _plot(str(table), "--formats", "png")
    assert result.exit_code == 0, (result.output, result.exception)
    assert _written_files(analysis_folder_of_table(table) / "figures") == {"fig3": {"png"}, "fig4": {"png"}}


def test_plot_of_an_unanalysed_table_says_to_analyze(tmp_path: Path) -> None:
    table = _real_table(tmp_path, {"workload": lambda r, c: float(r.normal(50, 5))})
    line = _single_error_line(_plot(str(table)))
    assert f"`nudge analyze {table}`" in line


@pytest.mark.parametrize(("manifest", "expected"), [
    ({"experiment": "ciaa-teleop"}, "ciaa-teleop"),
    ({"experiment": "a-new-study"}, "paper"),
    ({"experiment": "baselines", "plan": "study-code"}, "study-code"),
])
def test_compare_takes_the_simulated_runs_plan_by_the_same_rule(
        simulated_run: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, manifest: dict[str, str],
        expected: str) -> None:
    from nudgecli.report import compare
    from nudgecli.report.analysis import plan_of_source

    run = _copy_run(simulated_run, tmp_path / "run")
    recorded = {k: v for k, v in json.loads((run / "manifest.json").read_text()).items() if k != "plan"}
    (run / "manifest.json").write_text(json.dumps({**recorded, **manifest}))
    assert plan_of_source(run) == expected
    assert plan_of_source(tmp_path / "metrics.csv") == "paper"  # a table: no run to ask
    asked: list[object] = []

    def stop(plan: object) -> None:
        asked.append(plan)
        raise RuntimeError("stop before reading")

    monkeypatch.setattr(compare, "load_plan", stop)
    with pytest.raises(RuntimeError):
        compare.compare_sources(run, tmp_path / "real.csv")
    assert asked == [expected]


@pytest.mark.parametrize(("condition", "shown"), [
    ("disambiguation", "Disambiguation"), ("turn-taking", "Turn Taking"), ("mode-switch", "Mode Switch"),
    ("my_policy", "My Policy"), ("NASA-TLX", "NASA TLX"), ("iPad", "iPad"), ("DS2_fast", "DS2 Fast"),
    ("p300", "P300"),
])
def test_a_conditions_shown_name_keeps_the_capitals_it_was_given(condition: str, shown: str) -> None:
    # title case made NASA-TLX 'Nasa Tlx' and iPad 'Ipad'; a word in lower case is still capitalised
    assert condition_display_name(condition) == shown


def test_an_unknown_metrics_label_keeps_the_capitals_it_was_given() -> None:
    from nudgecli.report.figures.boxplots import METRIC_SPECS, metric_spec

    assert metric_spec("tlx_NASA_raw").label == "Tlx NASA raw"  # capitalize() made it 'Tlx nasa raw'
    assert metric_spec("first_input_latency").label == "First input latency"
    assert metric_spec("mode_switches") == METRIC_SPECS["mode_switches"]
