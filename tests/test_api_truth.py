"""The Python API tells a notebook the truth: an interrupted run's tables are refused as analyze
refuses them, a Run's config holds the seed simulated, overrides= takes NumPy's numbers and
mappings as ``--set`` does, a DataFrame where a path belongs is one ``Error:`` line, and a bad
``reference=`` or ``variant=`` is refused instead of passed over."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import nudgecli
from nudgecli.errors import ConfigError, RunFolderError


@pytest.fixture(scope="module")
def interrupted_run(tmp_path_factory: pytest.TempPathFactory):
    """Three smoke participants, interrupted after the first (8 of 24 trials)."""
    folder = tmp_path_factory.mktemp("interrupted") / "run"

    def interrupt(done: int, total: int) -> None:
        if done >= 8:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        nudgecli.simulate("smoke", participants=3, seed=3, out=folder, progress=interrupt)
    return folder


@pytest.mark.parametrize("table", ["trials", "steps", "participants"])
def test_the_tables_of_an_interrupted_run_are_refused_naming_the_resume(interrupted_run, table):
    run = nudgecli.Run.open(interrupted_run)  # opens: its path is there to resume
    assert run.path == interrupted_run
    with pytest.raises(RunFolderError, match=r"is incomplete: participant 1: .*restore with `nudge simulate "
                                             r".*--resume`"):
        getattr(run, table)


def test_the_report_of_an_interrupted_run_says_it_is_incomplete(interrupted_run):
    report = nudgecli.Run.open(interrupted_run).report()
    assert "incomplete" in report and "--resume" in report
    assert "8 trials" not in report


def test_a_runs_config_holds_the_seed_simulated():
    with nudgecli.simulate("smoke", participants=1, seed=3) as run:
        assert run.config.experiment.seed == 3
        assert run.config.study.participants == 1
        opened = nudgecli.Run.open(run.path).config
        assert (run.config.experiment, run.config.study) == (opened.experiment, opened.study)


@pytest.mark.parametrize(("overrides", "field", "expected"), [
    ({"study.participants": np.int64(3)}, lambda c: c.study.participants, 3),
    ({"study.time_limit_s": np.float64(50.0)}, lambda c: c.study.time_limit_s, 50.0),
    ({"policies.threshold.params": {"threshold": np.float64(0.7)}},
     lambda c: c.policies["threshold"].params, {"threshold": 0.7}),
])
def test_overrides_take_numpy_numbers_and_mappings(overrides, field, expected):
    preset = "custom-policy" if "policies.threshold.params" in overrides else "smoke"
    assert field(nudgecli.experiment_config(preset, overrides)) == expected


def test_toml_literals_of_numpy_values_and_tables():
    from nudgecli.api.run import toml_literal

    assert toml_literal(np.bool_(True)) == "true"
    assert toml_literal(np.array([1, 2])) == "[1, 2]"
    assert toml_literal({"a b": [np.int32(1)], "c": "x"}) == '{"a b" = [1], c = "x"}'


FRAME = pd.DataFrame({"participant": [0, 1], "condition": ["a", "b"], "x": [1.0, 2.0]})


@pytest.mark.parametrize(("call", "words"), [
    (lambda: nudgecli.compare("r9", FRAME), r"^real=<DataFrame of shape \(2, 3\)>: real= takes a path"),
    (lambda: nudgecli.compare(FRAME, "real.csv"), r"^simulated=<DataFrame of shape \(2, 3\)>: simulated="),
    (lambda: nudgecli.analyze("r9", questionnaires=FRAME), r"^questionnaires=<DataFrame .*takes a path"),
    (lambda: nudgecli.fit_people(FRAME), r"^sources=<DataFrame .*: sources= takes a path"),
    (lambda: nudgecli.habits(FRAME), r"^source=<DataFrame .*: source= takes a path"),
    (lambda: nudgecli.save_figures("r9", out=np.array(["figures", "more"])), r"^out=array\(.*takes a path"),
])
def test_a_dataframe_or_array_where_a_path_belongs_is_one_line(tmp_path, monkeypatch, call, words):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=words) as raised:
        call()
    assert "\n" not in str(raised.value)


def test_analysis_table_refuses_an_unknown_reference():
    from nudgecli.report.plans import MIN_RESAMPLES

    metrics = pd.DataFrame({"participant": [0, 0, 1, 1, 2, 2], "condition": ["a", "b"] * 3,
                            "completion_time": [1.0, 2.0, 1.5, 2.5, 1.2, 2.2]})
    with nudgecli.analyze(metrics, bootstrap=MIN_RESAMPLES) as analysis:
        with pytest.raises(ConfigError, match=r"^--reference 'nope' is not a condition of this analysis"):
            analysis.table(reference="nope")
        assert "a" in analysis.table(reference="a")


def test_fit_people_takes_a_run(analysed_smoke_run):
    run = nudgecli.Run.open(analysed_smoke_run)
    assert len(nudgecli.fit_people([run]).table) == len(nudgecli.fit_people([analysed_smoke_run]).table)


def test_fit_refuses_an_unknown_variant_before_reading(tmp_path):
    with pytest.raises(ConfigError, match=r"^variant='nope': choose auto, pilot, ciaa"):
        nudgecli.fit(tmp_path, variant="nope")
