"""The Python API (issue 40): what each function returns, that it equals what the commands write
and print, that bad input raises the command's message and writes nothing, and that importing
nudgecli stays cheap."""

from __future__ import annotations

import gc
import json
import math
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import nudgecli
from nudgecli import api
from nudgecli.cli import main
from nudgecli.config_files import parse_override
from nudgecli.errors import ConfigError, NudgeError

ROOT = Path(__file__).resolve().parents[1]
Smoke = tuple[api.Run, api.Analysis]


def cli(arguments: list[str], code: int = 0) -> Any:
    """``nudge ARGUMENTS`` in this process, expected to exit with ``code``."""
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == code, result.output
    return result


@pytest.fixture(scope="module")
def smoke(tmp_path_factory: pytest.TempPathFactory) -> tuple[api.Run, api.Analysis]:
    """A kept smoke run of 2 participants and its analysis (into the run folder, as the CLI does)."""
    folder = tmp_path_factory.mktemp("api") / "run"
    run = api.simulate("smoke", participants=2, seed=7, out=folder)
    return run, api.analyze(run)


# --- import cost ---------------------------------------------------------------------------------

def test_importing_nudgecli_loads_no_heavy_module() -> None:
    # a fresh interpreter: the names are reachable, and neither the import nor looking one up
    # (nudgecli.NudgeError) loads numpy, pandas, matplotlib or scipy
    script = ("import sys, nudgecli; heavy = ('numpy', 'pandas', 'matplotlib', 'scipy', 'pydantic'); "
              "before = [m for m in heavy if m in sys.modules]; nudgecli.NudgeError; "
              "after = [m for m in heavy if m in sys.modules]; "
              "print(before, after, 'simulate' in dir(nudgecli))")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}).stdout
    assert out.strip() == "[] [] True"


def test_the_top_level_names_are_the_apis() -> None:
    for name in nudgecli._LAZY:
        assert getattr(nudgecli, name) is getattr(api, name)
    assert nudgecli.NudgeError is NudgeError and nudgecli.api is api
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        nudgecli.simulat  # noqa: B018 - the lookup is the test


# --- simulate and Run ----------------------------------------------------------------------------

def test_a_run_without_out_is_temporary_and_removed_on_close_exit_and_collection(private_tmp: Path) -> None:
    run = api.simulate("smoke", participants=2)
    assert run.temporary and run.path.parent == private_tmp and (run.path / "manifest.json").is_file()
    run.close()
    assert not run.path.exists() and run.closed
    run.close()  # a second close is harmless
    with pytest.raises(NudgeError, match="closed"):
        run.steps  # noqa: B018
    with api.simulate("smoke", participants=2) as held:
        assert held.path.exists()
    assert not held.path.exists()
    path = api.simulate("smoke", participants=2).path  # no reference kept: collected at once
    gc.collect()
    assert not path.exists()
    assert list(private_tmp.iterdir()) == []


def test_a_kept_run_stays_and_its_tables_are_the_run_folders(smoke: Smoke) -> None:
    run, _ = smoke
    run.close()  # closing a kept run removes nothing
    assert not run.temporary and run.path.is_dir()
    reopened = api.Run.open(run.path)
    pd.testing.assert_frame_equal(reopened.trials, run.trials)
    trials = pd.concat([pd.read_parquet(p) for p in sorted((run.path / "trials").glob("part-*.parquet"))],
                       ignore_index=True)
    pd.testing.assert_frame_equal(run.trials, trials)
    steps = reopened.steps
    assert len(steps) == sum(pd.read_parquet(p).shape[0] for p in (run.path / "steps").glob("part-*.parquet"))
    assert len(reopened.participants) == 2 and reopened.participant_count == 2
    keys = set(zip(trials["participant"], trials["trial"], strict=True))
    assert set(steps.groupby(["participant", "trial"]).groups) == keys


def test_simulate_prints_what_the_api_reports(tmp_path: Path) -> None:
    run = api.simulate("smoke", participants=2, seed=3, out=tmp_path / "api")
    printed = cli(["simulate", "smoke", "--participants", "2", "--seed", "3", "--out", str(tmp_path / "cli")])
    assert printed.stdout == f"{run.report()}\n{tmp_path / 'cli'}\n"
    # the success table, counted by hand from the trials
    table = run.success()
    for condition, rows in run.trials.groupby("condition", observed=True):
        assert table.loc[condition, "trials"] == len(rows)
        assert table.loc[condition, "success_rate"] == pytest.approx(rows["success"].sum() / len(rows))


def test_progress_reports_trials_done_of_all() -> None:
    calls: list[tuple[int, int]] = []
    with api.simulate("smoke", participants=2, progress=lambda done, all_: calls.append((done, all_))) as run:
        total = len(run.trials)
    assert calls[0] == (0, total) and calls[-1] == (total, total)
    assert [done for done, _ in calls] == sorted(done for done, _ in calls)


def test_overrides_as_a_mapping_are_the_set_texts() -> None:
    mapping = api.experiment_config("smoke", {"disambiguation.window": 5, "study.corners": ["tr"],
                                              "study.time_limit_s": 45.5, "experiment.name": "two words"})
    texts = api.experiment_config("smoke", ["disambiguation.window=5", "study.corners=['tr']",
                                            "study.time_limit_s=45.5", "experiment.name=two words"])
    assert mapping == texts
    assert mapping.disambiguation.window == 5 and mapping.study.corners == ("tr",)
    assert mapping.experiment.name == "two words"


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=False),
                 st.text(max_size=20), st.lists(st.integers(-50, 50), max_size=4)))
def test_a_toml_literal_reads_back_as_its_value(value: object) -> None:
    _, parsed = parse_override(f"a.b={api.run.toml_literal(value)}")
    assert parsed == value and type(parsed) is type(value)


def test_a_quoted_string_keeps_its_spaces_and_quotes() -> None:
    for text in (" padded ", 'say "hi"', "back\\slash", "line\nbreak", "\x7f", "\U00010000"):
        assert parse_override(f"a.b={api.run.toml_literal(text)}")[1] == text


def test_people_are_simulated_as_their_twins(smoke: Smoke, tmp_path: Path) -> None:
    run, _ = smoke
    people = tmp_path / "people.csv"
    cli(["fit-people", str(run.path), "--out", str(people)])
    table = pd.read_csv(people)
    parameters = [c for c in table.columns if c not in ("person", "source", "participant", "from_population")]
    twins = api.simulate("smoke", participants=3, seed=2, people=people, out=tmp_path / "api")
    drawn = twins.participants.set_index("index")
    without = api.simulate("smoke", participants=3, seed=2).participants.set_index("index")
    for participant in range(3):  # participant i is person i mod P, their parameters as the file's
        person = table.iloc[participant % len(table)]
        for name in parameters:  # an empty cell (the grid world's stop parameters): the population's draw
            expected = without.loc[participant, name] if pd.isna(person[name]) else person[name]
            assert drawn.loc[participant, name] == pytest.approx(expected), (participant, name)
    manifest = json.loads((twins.path / "manifest.json").read_text())
    assert manifest["people"]["file"] == "people.csv" and manifest["people"]["people"] == len(table) == 2
    assert not all(without.loc[0, name] == pytest.approx(table.iloc[0][name]) for name in parameters)


# --- analyze ---------------------------------------------------------------------------------------

def test_the_api_writes_the_commands_tables_byte_for_byte(smoke: Smoke,
                                                         tmp_path: Path) -> None:
    run, _ = smoke
    analysis = api.analyze(run.path, out=tmp_path / "api")
    printed = cli(["analyze", str(run.path), "--out", str(tmp_path / "cli")])
    for name in ("stats.csv", "metrics.csv", "summary.md", "stats.json"):
        assert (tmp_path / "api" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert printed.stdout == analysis.table() + "\n"
    assert analysis.summary() == (tmp_path / "cli" / "summary.md").read_text(encoding="utf-8")
    csv = cli(["analyze", str(run.path), "--out", str(tmp_path / "cli-csv"), "--format", "csv"])
    assert csv.stdout == analysis.csv() == (tmp_path / "api" / "stats.csv").read_text(encoding="utf-8")


def test_the_tests_frame_holds_each_metrics_kruskal_wallis(smoke: Smoke) -> None:
    _, analysis = smoke
    tests = analysis.tests.set_index("metric")
    assert list(tests.index) == [entry["metric"] for entry in analysis.stats["metrics"]]
    for metric in ("completion_time", "mode_switches", "human_effort"):
        groups = [rows[metric].dropna().to_numpy(float)
                  for _, rows in analysis.metrics.groupby("condition", observed=True)]
        statistic, p = stats.kruskal(*groups)
        assert tests.loc[metric, "kruskal_statistic"] == pytest.approx(statistic, rel=1e-12)
        assert tests.loc[metric, "kruskal_p"] == pytest.approx(p, rel=1e-12)
        # the participant-level test is the pairs' (two conditions: one pair a metric)
        pair = analysis.pairs[analysis.pairs["metric"] == metric].iloc[0]
        assert tests.loc[metric, "participant_p"] == pytest.approx(pair["participant_p"], nan_ok=True)
        assert tests.loc[metric, "n_participants"] == pair["n_participants"] == 2


def test_a_metrics_dataframe_is_analysed_as_its_table_is(smoke: Smoke,
                                                         tmp_path: Path, private_tmp: Path) -> None:
    _, analysis = smoke
    table = pd.read_csv(analysis.path / "metrics.csv")
    from_path = api.analyze(analysis.path / "metrics.csv", out=tmp_path / "from-path")
    with api.analyze(table) as from_frame:
        assert from_frame.temporary and from_frame.path.parent == private_tmp
        pd.testing.assert_frame_equal(from_frame.pairs, from_path.pairs)
        assert from_frame.summary().split("\n", 4)[4] == from_path.summary().split("\n", 4)[4]  # source aside
        figure = api.plot(from_frame, "fig4")
        assert len([ax for ax in figure.axes if ax.get_visible()]) == 3
    assert list(private_tmp.iterdir()) == []


def test_analyze_of_a_temporary_run_keeps_the_run_alive(private_tmp: Path) -> None:
    analysis = api.analyze(api.simulate("smoke", participants=2))  # the Run has no other reference
    gc.collect()
    assert (analysis.path / "stats.json").is_file()
    del analysis
    gc.collect()
    assert list(private_tmp.iterdir()) == []


# --- bad input: the command's message, nothing written ------------------------------------------

def _error_line(arguments: list[str]) -> str:
    lines = [line for line in cli(arguments, code=1).output.splitlines() if line.startswith("Error: ")]
    assert len(lines) == 1
    return lines[0].removeprefix("Error: ")


BAD_INPUTS: dict[str, tuple[Callable[[Path, Path], object], Callable[[Path, Path], list[str]]]] = {
    "unknown experiment": (lambda run, out: api.simulate("nosuch", out=out),
                           lambda run, out: ["simulate", "nosuch", "--out", str(out)]),
    "no participants": (lambda run, out: api.simulate("smoke", participants=0, out=out),
                        lambda run, out: ["simulate", "smoke", "--participants", "0", "--out", str(out)]),
    "no participants, temporary": (lambda run, out: api.simulate("smoke", participants=0),
                                   lambda run, out: ["simulate", "smoke", "--participants", "0"]),
    "bad override": (lambda run, out: api.simulate("smoke", overrides={"disambiguation.window": "wide"},
                                                   out=out),
                     lambda run, out: ["simulate", "smoke", "--set", 'disambiguation.window="wide"', "--out",
                                       str(out)]),
    "missing source": (lambda run, out: api.analyze(out / "none.csv", out=out),
                       lambda run, out: ["analyze", str(out / "none.csv"), "--out", str(out)]),
    "unknown metric": (lambda run, out: api.analyze(run, metrics=["speed"], out=out),
                       lambda run, out: ["analyze", str(run), "--metric", "speed", "--out", str(out)]),
    "too many resamples": (lambda run, out: api.analyze(run, bootstrap=10**9, out=out),
                           lambda run, out: ["analyze", str(run), "--bootstrap", str(10**9), "--out",
                                             str(out)]),
    "unknown trial": (lambda run, out: api.save_figures(run, trial="99:0", out=out),
                      lambda run, out: ["plot", str(run), "--trial", "99:0", "--out", str(out)]),
    "bad format": (lambda run, out: api.save_figures(run, formats="png,gif", out=out),
                   lambda run, out: ["plot", str(run), "--formats", "png,gif", "--out", str(out)]),
    "habits of nothing": (lambda run, out: api.habits(out / "none"),
                          lambda run, out: ["habits", str(out / "none")]),
    "real is a folder": (lambda run, out: api.compare(run, run, out=out),
                         lambda run, out: ["compare", str(run), str(run), "--out", str(out)]),
    "bad match": (lambda run, out: api.compare(run, run / "metrics.csv", match=["control"], out=out),
                  lambda run, out: ["compare", str(run), str(run / "metrics.csv"), "--match", "control",
                                    "--out", str(out)]),
    "no replications": (lambda run, out: api.replicate("smoke", 0, out=out),
                        lambda run, out: ["replicate", "smoke", "-R", "0", "--out", str(out)]),
    "power of one": (lambda run, out: api.power("smoke", [1], 2, out=out),
                     lambda run, out: ["power", "smoke", "--participants", "1", "-R", "2", "--out",
                                       str(out)]),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_raises_the_commands_message_and_writes_nothing(case: str, smoke: Smoke, tmp_path: Path,
                                                                 private_tmp: Path) -> None:
    run, _ = smoke
    call, arguments = BAD_INPUTS[case]
    before = sorted(p.relative_to(run.path) for p in run.path.rglob("*"))
    with pytest.raises(NudgeError) as raised:
        call(run.path, tmp_path / "api-out")
    assert str(raised.value) == _error_line(arguments(run.path, tmp_path / "api-out"))
    assert not (tmp_path / "api-out").exists()
    assert list(private_tmp.iterdir()) == []
    assert sorted(p.relative_to(run.path) for p in run.path.rglob("*")) == before


def test_a_dataframe_that_is_no_table_is_refused_and_leaves_nothing(tmp_path: Path,
                                                                    private_tmp: Path) -> None:
    frame = pd.DataFrame({"participant": [0, 1], "condition": ["a", "b"], "time": [{"x": 1}, [2]]})
    with pytest.raises(NudgeError, match="metrics DataFrame"):
        api.analyze(frame)
    with pytest.raises(NudgeError):
        api.analyze(frame.assign(time=[1.0, 2.0]).drop(columns="condition"), out=tmp_path / "out")
    assert not (tmp_path / "out").exists() and list(private_tmp.iterdir()) == []


# --- plot ----------------------------------------------------------------------------------------

def test_plot_draws_the_commands_figures_and_one_panel_into_given_axes(smoke: Smoke) -> None:
    from matplotlib.figure import Figure

    _, analysis = smoke
    fig4 = api.plot(analysis)
    assert [ax.get_ylabel() for ax in fig4.axes][:3] and len(fig4.axes) == 3
    own = Figure()
    left, right = own.subplots(1, 2)
    assert api.plot(analysis, "completion_time", ax=right) is own
    assert not left.has_data() and right.has_data()
    # the panel's boxes are the conditions' completion times: each median line at the data's median
    medians = analysis.metrics.groupby("condition", observed=True)["completion_time"].median()
    drawn = sorted(float(line.get_ydata()[0]) for line in right.lines
                   if line.get_zorder() == 4)  # the boxes' medianprops
    assert drawn == pytest.approx(sorted(medians), rel=1e-12)
    assert isinstance(api.plot(analysis, "fig5"), Figure)
    beliefs = Figure().subplots()
    assert api.plot(analysis, "fig5", ax=beliefs, trial=(1, 3)) is beliefs.figure
    assert beliefs.get_title(loc="left").startswith("Participant 1, trial 3")
    # Fig. 5's lines are the trial's beliefs over its steps: one point a step
    steps = api.Run.open(analysis.path).steps.query("participant == 1 and trial == 3")
    assert max(len(line.get_xdata()) for line in beliefs.lines) == len(steps)
    with pytest.raises(ConfigError, match="several panels, which one axes cannot hold"):
        api.plot(analysis, "fig4", ax=left)
    with pytest.raises(ConfigError, match="did you mean 'fig4'"):
        api.plot(analysis, "fig 4")


def test_save_figures_writes_what_nudge_plot_writes(smoke: Smoke, tmp_path: Path) -> None:
    run, _ = smoke
    written = api.save_figures(run, out=tmp_path / "api", formats="png")
    printed = cli(["plot", str(run.path), "--out", str(tmp_path / "cli"), "--formats", "png"])
    assert [p.name for p in written] == [Path(line).name for line in printed.stdout.splitlines()]


# --- habits, compare, batches ------------------------------------------------------------------------

def test_habits_and_compare_are_what_the_commands_print(smoke: Smoke, tmp_path: Path) -> None:
    run, analysis = smoke
    found = api.habits(run)
    assert cli(["habits", str(run.path), "--format", "csv"]).stdout == found.csv()
    assert cli(["habits", str(run.path)]).stdout == found.text() + "\n"
    pooled = found.pooled.set_index("habit")
    assert (pooled["n"] == found.events.groupby("habit").size().reindex(pooled.index)).all()
    real = analysis.path / "metrics.csv"
    side = api.compare(run, real, resamples=100, out=tmp_path / "api", formats="svg")
    printed = cli(["compare", str(run.path), str(real), "--resamples", "100", "--format", "csv",
                   "--out", str(tmp_path / "cli"), "--formats", "svg"])
    assert printed.stdout == side.table.to_csv(index=False)
    assert (tmp_path / "api" / "compare.csv").read_bytes() == (tmp_path / "cli" / "compare.csv").read_bytes()
    # a source beside itself: the same medians and no distance
    assert np.allclose(side.table["median_simulated"], side.table["median_real"], equal_nan=True)
    assert np.nanmax(side.table["wasserstein"].to_numpy(float)) == 0.0


def test_replicate_is_what_nudge_replicate_prints(tmp_path: Path, private_tmp: Path) -> None:
    with api.replicate("smoke", 2, participants=2, seed=5) as batch:
        assert batch.temporary and batch.computed > 0
        printed = cli(["replicate", "smoke", "-R", "2", "--participants", "2", "--seed", "5", "--format",
                       "csv", "--out", str(tmp_path / "cli")])
        assert printed.stdout == batch.summary.to_csv(index=False)
        assert set(batch.tables) == {"replications", "conditions", "summary"}
        assert batch.rows["replication"].nunique() == 2
    assert list(private_tmp.iterdir()) == []
    assert math.isfinite(len(batch.summary))
