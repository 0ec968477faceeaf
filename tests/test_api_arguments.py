"""The Python API refuses an argument of the wrong Python type as a NudgeError (docs/api.md: "Bad
input raises nudgecli.NudgeError"), naming the argument as Python writes it, before any work."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

import nudgecli
from nudgecli import api
from nudgecli.api import arguments
from nudgecli.errors import ConfigError, NudgeError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def smoke(tmp_path_factory: pytest.TempPathFactory) -> api.Run:
    """A kept, analysed smoke run of 2 participants."""
    run = api.simulate("smoke", participants=2, seed=7, out=tmp_path_factory.mktemp("arguments") / "run")
    api.analyze(run)
    return run


# --- the cases of the report, message by message -------------------------------------------------

@pytest.mark.parametrize(("keyword", "value", "message"), [
    ("participants", "2", "participants='2': participants= takes a whole number (an int) or None, not str"),
    ("participants", 2.5, "participants=2.5: participants= takes a whole number (an int) or None, not float"),
    ("participants", True, "participants=True: participants= takes a whole number (an int) or None, "
                           "not bool"),
    ("seed", "abc", "seed='abc': seed= takes a whole number (an int) or None, not str"),
    ("workers", None, "workers=None: workers= takes a whole number (an int), not NoneType"),
    ("out", 3, "out=3: out= takes a path (a str or a pathlib.Path) or None, not int"),
    ("overrides", 5, "overrides=5: give a list of KEY=VALUE texts or a mapping"),
    ("force", "yes", "force='yes': force= takes True or False, not str"),
])
def test_simulate_refuses_a_wrong_type_naming_the_argument(tmp_path: Path, private_tmp: Path, keyword: str,
                                                           value: object, message: str) -> None:
    with pytest.raises(ConfigError) as raised:
        api.simulate("smoke", **{keyword: value})
    assert str(raised.value).startswith(message)
    assert list(private_tmp.iterdir()) == []


def test_a_whole_number_of_numpy_is_a_whole_number(tmp_path: Path) -> None:
    # a count taken from an array is an int as far as the run is concerned: same tables
    by_numpy = api.simulate("smoke", participants=np.int64(1), seed=np.int32(3), out=tmp_path / "numpy")
    by_int = api.simulate("smoke", participants=1, seed=3, out=tmp_path / "int")
    pd.testing.assert_frame_equal(by_numpy.trials, by_int.trials)


def test_the_fitted_people_stand_for_the_file_they_wrote(smoke: api.Run, tmp_path: Path) -> None:
    fitted = api.fit_people(smoke.path, out=tmp_path / "people.csv")
    by_object = api.simulate("smoke", participants=2, seed=1, people=fitted, out=tmp_path / "object")
    written = tmp_path / "people.csv"
    by_file = api.simulate("smoke", participants=2, seed=1, people=written, out=tmp_path / "file")
    pd.testing.assert_frame_equal(by_object.trials, by_file.trials)
    assert (tmp_path / "object" / "people" / "people.csv").read_bytes() == written.read_bytes()


@pytest.mark.parametrize("which", ["unwritten", "table"])
def test_fitted_people_without_a_file_are_refused_with_how_to_write_it(smoke: api.Run, private_tmp: Path,
                                                                       which: str) -> None:
    fitted = api.fit_people(smoke.path)
    given = fitted if which == "unwritten" else fitted.table
    for call in (lambda: api.simulate("smoke", people=given), lambda: api.replicate("smoke", 1, people=given),
                 lambda: api.power("smoke", [2], 1, people=given)):
        with pytest.raises(ConfigError, match=r"people= takes a people file's path; .*fit_people\(sources, "
                                              r"out='people.csv'\)"):
            call()
    assert list(private_tmp.iterdir()) == []


@pytest.mark.parametrize(("frame", "message"), [
    (pd.DataFrame({"participant": [], "condition": [], "time": []}),
     "the metrics DataFrame has no rows; a metrics table needs one row per trial"),
    (pd.DataFrame({"participant": [0, 1], "time": [1.0, 2.0]}),
     "the metrics DataFrame has no 'condition' column"),
])
def test_an_unusable_dataframe_is_named_as_the_dataframe_not_a_temporary_file(
        frame: pd.DataFrame, message: str, private_tmp: Path, tmp_path: Path) -> None:
    for out in (None, tmp_path / "out"):
        with pytest.raises(NudgeError) as raised:
            api.analyze(frame, out=out)
        assert str(raised.value).startswith(message)
        assert "metrics.parquet" not in str(raised.value) and str(tmp_path) not in str(raised.value)
    assert list(private_tmp.iterdir()) == [] and not (tmp_path / "out").exists()


def test_plot_takes_a_trial_as_the_command_writes_it(smoke: api.Run) -> None:
    by_text = api.plot(smoke, "trajectory", trial="0:1")
    by_pair = api.plot(smoke, "trajectory", trial=(0, 1))
    assert [text.get_text() for text in by_text.texts] == [text.get_text() for text in by_pair.texts]
    assert [ax.get_title() for ax in by_text.axes] == [ax.get_title() for ax in by_pair.axes]
    with pytest.raises(ConfigError, match=r"^--trial 9:9: no such trial in "):
        api.plot(smoke, "trajectory", trial="9:9")
    with pytest.raises(ConfigError, match=r"^--trial '0-1': expected PARTICIPANT:TRIAL"):
        api.plot(smoke, "trajectory", trial="0-1")
    with pytest.raises(ConfigError, match=r"^trial=\('0', '1'\): trial= takes \(participant, trial\)"):
        api.plot(smoke, "trajectory", trial=("0", "1"))


# --- every public function, every argument, wrong types --------------------------------------------

#: Each public function of nudgecli.api with arguments that would work (cheap ones): each argument in
#: turn is replaced by values of the wrong type.
def _valid_calls(run: Path, out: Path) -> dict[str, dict[str, Any]]:
    return {
        "simulate": {"experiment": "smoke", "participants": 1, "out": out},
        "experiment_config": {"name_or_path": "smoke"},
        "analyze": {"source": run, "out": out},
        "plot": {"analysis": run},
        "save_figures": {"source": run, "out": out},
        "analyze_and_plot": {"run": run},
        "habits": {"source": run},
        "compare": {"simulated": run, "real": run / "metrics.csv", "resamples": 100, "out": out},
        "parse_matches": {"matches": ["a=b"]},
        "replicate": {"experiment": "smoke", "replications": 1, "participants": 2, "out": out},
        "power": {"experiment": "smoke", "participants": [2], "replications": 1, "out": out},
        "sweep": {"sweep_file": ROOT / "experiments" / "sweeps" / "example.toml", "replications": 1,
                  "out": out},
        "fit": {"calibration_dir": run / "calibration", "out": out / "p.json"},
        "fit_people": {"sources": [run], "out": out / "people.csv"},
        "validate": {"simulations": 1, "states": 18, "mc_queries": 0, "out": out},
        "plot_population": {"experiment": "smoke", "participants": 2, "out": out},
        "plan_of": {"source": run},
        "holds_batch": {"folder": run},
        "progress_line": {"label": "x"},
    }


#: Arguments whose command-line option holds a range (click.IntRange): a negative number is refused too.
NON_NEGATIVE = {("analyze", "seed"), ("analyze", "bootstrap"), ("compare", "seed"), ("compare", "resamples"),
                ("plot_population", "participants"), ("plot_population", "seed"),
                ("simulate", "participants"), ("simulate", "seed"), ("simulate", "workers"),
                ("replicate", "replications"), ("replicate", "workers"), ("validate", "simulations")}


def _wrong_values(function: str, parameter: inspect.Parameter) -> list[object]:
    """Values of the wrong type for ``parameter`` (by its annotation), and -1 where it is a count."""
    annotation = str(parameter.annotation)
    optional = "None" in annotation or parameter.default is None
    if annotation in ("int", "int | None"):
        values: list[object] = ["2", 2.5, True]
    elif annotation in ("float", "float | None"):
        values = ["0.5", float("nan")]
    elif annotation == "bool":
        values = ["yes", 1]
    elif "Sequence[int]" in annotation:
        values = ["6", 6, [2.5]]
    elif "Callable" in annotation or "ProgressCallback" in annotation:
        values = [3]
    else:  # paths, texts, sources, lists of texts
        values = [3, 2.5]
    if (function, parameter.name) in NON_NEGATIVE:
        values.append(-1)
    return values if optional else [*values, None]


def _cases() -> list[tuple[str, str, object]]:
    cases = []
    for function in _valid_calls(Path(), Path()):
        for parameter in inspect.signature(getattr(api, function)).parameters.values():
            if parameter.name != "ax":  # matplotlib's own type
                cases.extend((function, parameter.name, value)
                             for value in _wrong_values(function, parameter))
    return cases


@pytest.mark.parametrize(("function", "name", "value"), _cases(), ids=repr)
def test_every_argument_of_a_wrong_type_is_a_nudge_error_before_any_work(
        smoke: api.Run, tmp_path: Path, private_tmp: Path, function: str, name: str, value: object) -> None:
    out = tmp_path / "out"
    call = _valid_calls(smoke.path, out)[function]
    before = sorted(smoke.path.rglob("*"))
    with pytest.raises(NudgeError):
        getattr(api, function)(**{**call, name: value})
    assert not out.exists() and list(private_tmp.iterdir()) == []
    assert sorted(smoke.path.rglob("*")) == before


def test_the_api_reaches_every_public_function() -> None:
    # a public function added to nudgecli.api is added to the sweep above
    functions = {name for name in api.__all__ if inspect.isfunction(getattr(api, name))}
    assert functions - {"presets"} == set(_valid_calls(Path(), Path()))
    assert inspect.signature(nudgecli.presets).parameters == {}


# --- the checks themselves -----------------------------------------------------------------------

def test_whole_numbers_are_ints_of_python_or_numpy_and_never_bools_or_floats() -> None:
    made = arguments.whole_number("n", np.int16(4))
    assert type(made) is int and made == 4
    assert arguments.whole_number("n", None, optional=True) is None
    for value in (True, 4.0, "4", None, np.float64(4)):
        with pytest.raises(ConfigError, match=r"^n="):
            arguments.whole_number("n", value)
    assert arguments.whole_number("n", 0, minimum=0) == 0
    with pytest.raises(ConfigError, match="at least 1"):
        arguments.whole_number("n", 0, minimum=1)
    assert arguments.whole_numbers("n", (6, np.int64(9))) == [6, 9]


def test_real_numbers_texts_switches_and_trials() -> None:
    assert arguments.real_number("level", 1) == 1.0
    assert arguments.real_number("level", 0.9, between=(0.5, 1.0)) == 0.9
    for value in (0.5, 1.0, float("nan")):
        with pytest.raises(ConfigError):
            arguments.real_number("level", value, between=(0.5, 1.0))
    with pytest.raises(ConfigError, match="a list of texts"):
        arguments.texts("metrics", "completion_time")  # its letters are no list of metrics
    assert arguments.texts("metrics", ("a", "b")) == ["a", "b"]
    assert arguments.switch("force", False) is False
    assert arguments.trial("3:12") == (3, 12) and arguments.trial((np.int64(3), 12)) == (3, 12)
    assert arguments.trial(None) is None
    for value in ((3,), (3, 12, 1), (3.0, 12), (True, 1)):
        with pytest.raises(ConfigError, match=r"^trial="):
            arguments.trial(value)
    assert arguments.formats("png,pdf") == ("png", "pdf") and arguments.formats(["svg"]) == ("svg",)


@pytest.mark.parametrize(("value", "got"), [
    (("0", "1"), "a tuple of str and str: its two items must be whole numbers (int)"),
    ([0, 1.0], "a list of int and float: its two items must be whole numbers (int)"),
    ((3,), "a tuple of 1 item"), ((3, 12, 1), "a tuple of 3 items"), (5, "int")])
def test_a_trial_that_is_no_pair_of_whole_numbers_says_what_is_wrong(value: object, got: str) -> None:
    # before: "..., not tuple" for a tuple of texts, which is a tuple
    with pytest.raises(ConfigError) as raised:
        arguments.trial(value)
    assert str(raised.value) == (f"trial={value!r}: trial= takes (participant, trial) or "
                                 f"'PARTICIPANT:TRIAL', e.g. (0, 12) or '0:12', not {got}")


def test_a_whole_number_below_its_least_says_the_number_not_its_type() -> None:
    with pytest.raises(ConfigError) as raised:
        arguments.whole_number("participants", 0, minimum=1)
    assert str(raised.value) == "participants=0: participants= takes a whole number of at least 1, not 0"
    with pytest.raises(ConfigError, match=r"takes a whole number \(an int\), not str$"):
        arguments.whole_number("participants", "3")
