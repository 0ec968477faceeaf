"""`nudge analyze` end to end: run folders, metrics tables, plans, outputs and bad inputs."""

from __future__ import annotations

import json
import math
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_helpers import nudge, one_error_line
from click.testing import CliRunner
from run_builders import synthetic_run

from nudgecli.cli import main
from nudgecli.errors import ConfigError
from nudgecli.report.analysis import analyze
from nudgecli.report.plans import load_plan, plan_from_dict, plan_names
from nudgecli.report.stats import ComparisonOptions
from nudgecli.run_folder_names import CONFIG, LOCK
from nudgecli.run_folder_state import only_a_start, start_advice

DATA = Path(__file__).parent / "data"
METRICS_CSV = DATA / "metrics_two_conditions.csv"
QUESTIONNAIRES_CSV = DATA / "questionnaires_two_conditions.csv"
STATS_KEYS = ["metric", "n", "mean", "median", "q1", "q3", "mean_rank", "kruskal", "conover", "p_adjust",
              "stars", "star_rule", "participant_level", "effect_size", "ci"]


def make_run(folder: Path, n_participants: int = 5, trials_per_condition: int = 4, seed: int = 1) -> Path:
    """A small two-condition run folder: control trials are 2 s longer and have more mode switches,
    so the differences are clear."""
    return synthetic_run(folder, {"disambiguation": 0, "control": 20}, n_participants=n_participants,
                         trials_per_condition=trials_per_condition, seed=seed, max_steps=40,
                         switch_probability=lambda extra: 0.05 if extra == 0 else 0.2)


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_run(tmp_path_factory.mktemp("analysis") / "run")


def _invoke(*args: str):
    return CliRunner().invoke(main, ["analyze", *args])


def test_analyze_run_folder_writes_all_files(run_folder: Path, tmp_path: Path) -> None:
    result = analyze(run_folder, out=tmp_path)
    assert {p.name for p in result.files} == {"metrics.csv", "stats.json", "stats.csv", "summary.md"}
    metrics = pd.read_csv(tmp_path / "metrics.csv")
    assert len(metrics) == 5 * 8
    paper_metrics = list(load_plan("paper").metrics.include)  # the paper's seven, not the input measures
    assert list(metrics.columns) == ["participant", "condition", "block", "trial", *paper_metrics]
    stats = json.loads((tmp_path / "stats.json").read_text())
    assert stats["conditions"] == ["disambiguation", "control"]
    assert [m["metric"] for m in stats["metrics"]] == paper_metrics
    for entry in stats["metrics"]:
        assert list(entry) == STATS_KEYS
        assert set(entry["median"]) == {"disambiguation", "control"}
    completion = next(m for m in stats["metrics"] if m["metric"] == "completion_time")
    assert completion["kruskal"]["p"] < 0.001 and completion["stars"][0]["stars"] == "***"
    assert completion["effect_size"]["value"] == -1.0  # every participant slower in control
    success = next(m for m in stats["metrics"] if m["metric"] == "success")
    assert success["kruskal"]["p"] is None  # all trials succeeded: NaN written as null
    table = pd.read_csv(tmp_path / "stats.csv")
    assert len(table) == len(paper_metrics) and {"conover_p", "stars", "ci_low"} <= set(table.columns)
    summary = (tmp_path / "summary.md").read_text()
    assert "## completion_time" in summary and "| disambiguation - control |" in summary
    # the source as seen from the output folder: no machine's path in a shipped summary
    expected = os.path.relpath(run_folder.resolve(), tmp_path.resolve())
    assert f"- source: `{expected}`\n" in summary and not expected.startswith("/")
    assert not list(tmp_path.glob(".*.tmp"))


def test_study_code_plan_uses_its_definitions_and_filters(run_folder: Path, tmp_path: Path) -> None:
    paper = analyze(run_folder, out=tmp_path / "paper")
    study = analyze(run_folder, plan="study-code", out=tmp_path / "study")
    assert not paper.metrics["assistance_engagement"].equals(study.metrics["assistance_engagement"])
    assert (study.metrics["completion_time"].dropna() <= 100).all()
    assert study.stats["metrics"][0]["p_adjust"] == "holm"


def test_seed_makes_the_interval_reproducible(run_folder: Path, tmp_path: Path) -> None:
    first = analyze(run_folder, out=tmp_path / "a", metrics=["human_effort"], seed=3)
    again = analyze(run_folder, out=tmp_path / "b", metrics=["human_effort"], seed=3)
    other = analyze(run_folder, out=tmp_path / "c", metrics=["human_effort"], seed=4)
    assert first.stats == again.stats
    assert first.stats["metrics"][0]["ci"] != other.stats["metrics"][0]["ci"]


def test_cli_table_json_and_csv(run_folder: Path, tmp_path: Path) -> None:
    result = _invoke(str(run_folder), "--out", str(tmp_path), "--metric", "mode_switches")
    assert result.exit_code == 0, result.output
    assert "mode_switches" in result.stdout and "KW p" in result.stdout
    assert result.stderr.strip().splitlines()[-1] == str(tmp_path)
    result = _invoke(str(run_folder), "--out", str(tmp_path), "--format", "json", "--metric", "human_turns",
                     "--force")  # --out holds the first analysis now
    assert result.exit_code == 0
    document = json.loads(result.stdout)  # stdout holds only JSON
    assert [m["metric"] for m in document["metrics"]] == ["human_turns"]
    result = _invoke(str(run_folder), "--out", str(tmp_path), "--format", "csv", "--force")
    assert result.exit_code == 0
    assert result.stdout.splitlines()[0].startswith("metric,a,b,")


def test_metrics_table_source_and_questionnaires(tmp_path: Path) -> None:
    result = analyze(METRICS_CSV, out=tmp_path, questionnaires=QUESTIONNAIRES_CSV)
    names = [m["metric"] for m in result.stats["metrics"]]
    assert names == ["mode_switches", "completion_time", "success", "tlx_raw", "tlx_weighted", "likert_q3",
                     "likert_q4"]
    assert (tmp_path / "questionnaire_scores.csv").is_file()  # a name of its own: not the answers
    tlx = pd.read_csv(tmp_path / "questionnaire_scores.csv")
    raw = pd.read_csv(QUESTIONNAIRES_CSV)
    subscales = [c for c in raw.columns if c.startswith("tlx_") and "pair" not in c]
    assert np.allclose(tlx["tlx_raw"], raw[subscales].mean(axis=1))


def test_metrics_table_in_its_own_folder_is_not_overwritten(tmp_path: Path) -> None:
    table = tmp_path / "metrics.csv"
    table.write_text(METRICS_CSV.read_text())
    before = table.read_bytes()
    result = analyze(table)
    assert result.out == tmp_path / "metrics-analysis" and table.read_bytes() == before
    assert (result.out / "stats.json").is_file()


def test_three_conditions_from_a_parquet_table(tmp_path: Path) -> None:
    rng = np.random.default_rng(2)
    rows = [{"participant": p, "condition": c, "score": shift + rng.normal()}
            for p in range(6) for c, shift in (("a", 0), ("b", 1), ("c", 3)) for _ in range(5)]
    pd.DataFrame(rows).to_parquet(tmp_path / "three.parquet")
    result = analyze(tmp_path / "three.parquet", out=tmp_path / "out")
    entry = result.stats["metrics"][0]
    assert result.stats["conditions"] == ["a", "b", "c"]
    assert entry["participant_level"]["test"] == "friedman" and entry["effect_size"]["name"] == "kendall_w"
    assert [(s["a"], s["b"]) for s in entry["stars"]] == [("a", "b"), ("a", "c"), ("b", "c")]
    assert len(result.table) == 3


def test_presets_load_and_unknown_plan_keys_are_refused(tmp_path: Path) -> None:
    assert {"paper", "study-code"} <= set(plan_names())
    assert load_plan("paper").stats.star_comparison == "<"
    study = load_plan("study-code")
    assert study.stats.star_comparison == "<="
    assert study.filters == {"mode_switches": 10, "human_turns": 10, "completion_time": 100}
    plan = tmp_path / "plan.toml"
    plan.write_text('[stats]\nkruskal_alpah = 0.05\n')
    expected = r"plan.toml: unknown key 'stats.kruskal_alpah' \(did you mean 'kruskal_alpha'\?\)"
    with pytest.raises(ConfigError, match=expected):
        load_plan(plan)
    plan.write_text('[metrics]\ninclude = ["mode_switchs"]\n')
    with pytest.raises(ConfigError, match="did you mean 'mode_switches'"):
        load_plan(plan)


def _bad_input_cases(tmp_path: Path) -> dict[str, tuple[list[str], str]]:
    good = pd.read_csv(METRICS_CSV)
    cases: dict[str, tuple[list[str], str]] = {}

    def table(name: str, frame: pd.DataFrame) -> str:
        path = tmp_path / name
        frame.to_csv(path, index=False)
        return str(path)

    cases["no condition"] = ([table("a.csv", good.drop(columns="condition"))], "no 'condition' column")
    cases["no participant"] = ([table("b.csv", good.drop(columns="participant"))], "no 'participant' column")
    cases["non-numeric"] = ([table("c.csv", good.assign(completion_time="fast"))],
                            "metric column 'completion_time' is not numeric")
    (tmp_path / "empty.csv").write_text("")
    cases["empty file"] = ([str(tmp_path / "empty.csv")], "is empty")
    (tmp_path / "header.csv").write_text("participant,condition,x\n")
    cases["header only"] = ([str(tmp_path / "header.csv")], "has no rows")
    (tmp_path / "notes.txt").write_text("hello")
    cases["text file"] = ([str(tmp_path / "notes.txt")], "neither a run folder nor a metrics table")
    (tmp_path / "plain").mkdir()
    cases["plain folder"] = ([str(tmp_path / "plain")], "neither a run folder nor a metrics table")
    cases["missing path"] = ([str(tmp_path / "nowhere")], "does not exist")
    cases["unknown metric"] = ([str(METRICS_CSV), "--metric", "completion_tme"],
                               "did you mean 'completion_time'")
    (tmp_path / "fresh" / "trials").mkdir(parents=True)
    (tmp_path / "fresh" / "manifest.json").write_text("{}")
    cases["no trials yet"] = ([str(tmp_path / "fresh")], "run `nudge simulate")
    cases["unknown plan"] = ([str(METRICS_CSV), "--plan", "papr"], "did you mean 'paper'")
    cases["bad questionnaire"] = ([str(METRICS_CSV), "--questionnaires", str(METRICS_CSV)], "holds no scores")
    return cases


def test_bad_inputs_give_one_error_line_and_exit_code_1(tmp_path: Path) -> None:
    for name, (args, message) in _bad_input_cases(tmp_path).items():
        result = _invoke(*args, "--out", str(tmp_path / "out"))
        assert result.exit_code == 1, (name, result.output, result.exception)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("Error: "), (name, result.stderr)
        assert message in lines[0], (name, lines[0])
        assert result.stdout == "", name


@pytest.mark.parametrize("left", [(), (LOCK,), (LOCK, "trials/", "steps/", "participants/")])
def test_a_start_killed_writing_its_config_gets_start_advice(tmp_path: Path, left: tuple[str, ...]) -> None:
    # what `nudge simulate --out F` killed while writing config.toml leaves; without its empty part
    # folders it has no run-folder marker at all
    start = tmp_path / "run"
    start.mkdir()
    temporary = start / f".{CONFIG}.x1y2z3w4.tmp"
    temporary.write_text("[experiment]\n")
    for name in left:
        (start / name).mkdir() if name.endswith("/") else (start / name).write_text("")
    analyzed, plotted = nudge("analyze", start), nudge("plot", start)
    assert analyzed.exit_code == 1 and plotted.exit_code == 1
    # was: "neither a run folder nor a metrics table", while plot gave the start advice
    advice = f"Error: {start_advice(start)}"
    assert one_error_line(analyzed.output) == one_error_line(plotted.output) == advice
    # nothing written beside it (a stale lock is released, as by plot): still a start for its resume
    assert only_a_start(start) and temporary.is_file()


def test_nan_values_are_null_in_stats_json(tmp_path: Path) -> None:
    frame = pd.read_csv(METRICS_CSV)
    frame["empty_metric"] = math.nan
    frame.to_csv(tmp_path / "with_nan.csv", index=False)
    analyze(tmp_path / "with_nan.csv", out=tmp_path / "out", metrics=["empty_metric"])
    text = (tmp_path / "out" / "stats.json").read_text()
    assert "NaN" not in text
    entry = json.loads(text)["metrics"][0]
    assert entry["median"] == {"disambiguation": None, "control": None}
    # a condition without values is left out of the metric as "no values" (its n too)
    assert entry["n"] == {"disambiguation": None, "control": None}
    assert entry["not_applicable_reasons"] == {"disambiguation": "no values", "control": "no values"}


def test_a_run_kept_without_step_logs_points_to_its_metrics_table(tmp_path):
    run = tmp_path / "kept"
    run.mkdir()
    (run / "manifest.json").write_text("{}")
    (run / "metrics.csv").write_text("participant,condition,completion_time\n0,a,1\n0,b,2\n")
    result = CliRunner().invoke(main, ["analyze", str(run)])
    assert result.exit_code == 1
    assert result.output.startswith("Error: ") and f"nudge analyze {run / 'metrics.csv'}" in result.output


@pytest.mark.parametrize("marker", ["trials", "steps", "manifest.json", "config.toml", None])
def test_is_run_folder_is_one_marker_of_a_run(tmp_path: Path, marker: str | None) -> None:
    from nudgecli.store import RunFolder, is_run_folder

    folder = tmp_path / "run"
    folder.mkdir()
    if marker in ("trials", "steps"):
        (folder / marker).mkdir()
    elif marker is not None:
        (folder / marker).write_text("{}")
    assert is_run_folder(folder) is (marker is not None)
    assert RunFolder(folder).is_run() is (marker == "manifest.json")  # the narrower test: a manifest
    assert not is_run_folder(folder / "missing") and not is_run_folder(tmp_path / "file.csv")


def test_every_option_of_a_plan_reaches_the_statistics() -> None:
    plan = plan_from_dict({"stats": {"kruskal_alpha": 0.01, "p_adjust": "bonferroni",
                                     "star_thresholds": [0.1, 0.02], "star_comparison": "<=",
                                     "participant_aggregate": "mean"},
                           "bootstrap": {"resamples": 150, "level": 0.9, "seed": 4}})
    expected = ComparisonOptions(kruskal_alpha=0.01, p_adjust="bonferroni", star_thresholds=(0.1, 0.02),
                                 star_comparison="<=", participant_aggregate="mean", bootstrap_resamples=150,
                                 bootstrap_level=0.9, seed=4)
    assert plan.comparison_options() == expected
    assert plan.comparison_options(seed=9) == replace(expected, seed=9)


def test_star_thresholds_must_strictly_decrease() -> None:
    with pytest.raises(ConfigError, match="strictly decreasing"):
        plan_from_dict({"stats": {"star_thresholds": [0.05, 0.05]}})
    with pytest.raises(ConfigError, match="strictly decreasing"):
        plan_from_dict({"stats": {"star_thresholds": [0.01, 0.05]}})


def test_a_plan_file_without_a_name_is_named_after_the_file(tmp_path: Path) -> None:
    (tmp_path / "my-plan.toml").write_text('description = "mine"\n')
    (tmp_path / "named.toml").write_text('name = "other"\n')
    assert load_plan(tmp_path / "my-plan.toml").name == "my-plan"
    assert load_plan(tmp_path / "named.toml").name == "other"


def test_a_bootstrap_of_zero_resamples_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="--bootstrap 0: at least 100 bootstrap resamples"):
        analyze(METRICS_CSV, out=tmp_path / "out", bootstrap=0)
    assert not (tmp_path / "out").exists()
