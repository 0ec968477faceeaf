"""Sweep files: the integer rule of sampled designs, the keys a sweep refuses, where its paths
resolve, and the one error line of a bad sweep file (nudgecli.runs.sweep, ``nudge sweep``)."""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.config_files import list_presets, parse_override
from nudgecli.errors import ConfigError
from nudgecli.report.plans import load_plan
from nudgecli.runs.sweep import (
    Design,
    Range,
    SweepFile,
    Values,
    design_values,
    load_sweep,
    map_sample,
    point_overrides,
    salib_problem,
)

HEAD = """\
experiment = "smoke"
replications = 1
seed = 3
{extra}
[design]
method = "{method}"

[parameters]
"""


def _sweep(folder: Path, parameters: str, *, extra: str = "", method: str = "grid") -> Path:
    path = folder / "s.toml"
    path.write_text(HEAD.format(extra=extra, method=method) + parameters)
    return path


def _integers(low: float, high: float, method: str, **design: int) -> list[int]:
    spec = SweepFile(experiment="unused", design=Design(method=method, **design),  # type: ignore[arg-type]
                     parameters={"study.participants": Range(low=low, high=high, integer=True)})
    return [p["study.participants"] for p in design_values(spec)[0]]


def _error_line(args: list[str]) -> str:
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    return lines[0]


# --- 1: an integer range gives every integer in it an equal share ------------------------------

def test_an_integer_range_gives_each_integer_an_equal_share_of_the_unit_interval() -> None:
    # brute force: 6000 evenly spaced coordinates of [0, 1) through the problem's bounds; the six
    # integers 4..9 must own 1000 each (the floor over [4, 9] gave 9 none, 4..8 1200 each)
    whole = Range(low=4, high=9, integer=True)
    spec = SweepFile(experiment="unused", design=Design(method="sobol"),
                     parameters={"study.participants": whole})
    (low, high), = salib_problem(spec)["bounds"]
    counts = Counter(map_sample(whole, low + (k / 6000) * (high - low)) for k in range(6000))
    assert counts == {n: 1000 for n in range(4, 10)}
    assert map_sample(whole, high) == 9  # the top of the interval: the last integer


def test_sobol_over_an_integer_range_draws_every_integer_of_it() -> None:
    drawn = _integers(4, 9, "sobol", samples=64, seed=0)
    assert len(drawn) == 64 * 3 and set(drawn) == set(range(4, 10))
    assert all(isinstance(n, int) for n in drawn)


@pytest.mark.parametrize("levels", [2, 4, 6, 8])
def test_morris_levels_of_an_integer_range_follow_the_documented_rule(levels: int) -> None:
    # level k of L is u = k / (L - 1), which gives ceil(low) + floor(u n), the last level the last
    # integer (n = 6 integers 4..9); L = n levels visit every integer once. (Odd L is refused: SALib's
    # own grid is then not k / (L - 1), tested below.)
    n = 6
    expected = {min(4 + math.floor(k * n / (levels - 1)), 9) for k in range(levels)}
    drawn = set(_integers(4, 9, "morris", samples=12, levels=levels, seed=1))
    assert drawn == expected
    if levels == n:
        assert drawn == set(range(4, 10))


def test_an_integer_range_never_leaves_its_bounds() -> None:
    assert set(_integers(2.5, 3.5, "sobol", samples=16)) == {3}  # the floor over [2.5, 3.5] gave 2
    assert set(_integers(2.5, 4.5, "morris", samples=8, levels=4)) <= {3, 4}


@given(low=st.floats(-50, 50), width=st.floats(0.01, 30), u=st.floats(0, 1))
def test_an_integer_range_maps_every_coordinate_to_an_integer_inside_it(low: float, width: float,
                                                                        u: float) -> None:
    high = low + width
    if math.ceil(low) > math.floor(high) or not low < high:
        return  # no integer inside: refused, tested below
    whole = Range(low=low, high=high, integer=True)
    spec = SweepFile(experiment="unused", design=Design(method="sobol"), parameters={"a.n": whole})
    (lo, hi), = salib_problem(spec)["bounds"]
    value = map_sample(whole, lo + u * (hi - lo))
    assert isinstance(value, int) and math.ceil(low) <= value <= math.floor(high)
    count = math.floor(high) - math.ceil(low) + 1
    assert value == min(math.ceil(low) + math.floor(u * count), math.floor(high)) or \
        abs(u * count - round(u * count)) < 1e-9  # at a share's edge rounding may pick either side


def test_an_integer_range_without_an_integer_is_refused(tmp_path: Path) -> None:
    path = _sweep(tmp_path, '"study.participants" = { low = 2.2, high = 2.8, integer = true }\n',
                  method="sobol")
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert "study.participants" in line and "no integer" in line
    assert not (tmp_path / "out").exists()


# --- 2: the experiment's seed is not a sweep parameter --------------------------------------------

@pytest.mark.parametrize(("parameters", "extra"), [
    ('"experiment.seed" = [1, 2]\n', ""),
    ('" experiment . seed" = [1, 2]\n', ""),  # read as --set reads it: the same key
    ('"inference.kappa" = [0.6]\n', 'set = ["experiment.seed=5"]\n'),
])
def test_a_swept_or_set_experiment_seed_is_refused(tmp_path: Path, parameters: str, extra: str) -> None:
    path = _sweep(tmp_path, parameters, extra=extra)
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert str(path) in line and "experiment.seed" in line
    assert "seed =" in line and "--seed" in line and "replications" in line
    assert not (tmp_path / "out").exists()


# --- 3: relative paths are to the sweep file's folder ---------------------------------------------

def test_a_relative_experiment_path_is_looked_for_beside_the_sweep_file_only(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    smoke = list_presets("experiments")["smoke"].read_text()
    (tmp_path / "experiments").mkdir()
    (tmp_path / "experiments" / "smoke.toml").write_text(smoke)  # in the current folder only
    (tmp_path / "sweeps").mkdir()
    path = tmp_path / "sweeps" / "s.toml"
    path.write_text(HEAD.format(extra="", method="grid").replace('"smoke"', '"experiments/smoke.toml"')
                    + '"inference.kappa" = [0.6]\n')
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as caught:
        load_sweep(str(path))
    message = str(caught.value)
    assert str(path) in message and "experiment" in message
    assert str(tmp_path / "sweeps" / "experiments" / "smoke.toml") in message
    # beside the sweep file it is found, from any folder
    (tmp_path / "sweeps" / "experiments").mkdir()
    (tmp_path / "sweeps" / "experiments" / "smoke.toml").write_text(smoke)
    monkeypatch.chdir(tmp_path / "experiments")
    assert load_sweep(str(path)).points[0].config.inference.kappa == 0.6


def test_a_plan_beside_the_sweep_file_is_found_from_any_folder(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "study").mkdir()
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "study" / "myplan.toml").write_text(list_presets("analysis")["paper"].read_text())
    path = _sweep(tmp_path / "study", '"inference.kappa" = [0.6]\n', extra='plan = "myplan.toml"\n')
    monkeypatch.chdir(tmp_path / "elsewhere")
    plan = load_sweep(str(path)).spec.plan
    assert plan is not None and Path(plan).resolve() == (tmp_path / "study" / "myplan.toml").resolve()
    assert load_plan(plan) == load_plan("paper")


def test_a_missing_plan_names_the_sweep_file_the_field_and_where_it_looked(tmp_path: Path) -> None:
    path = _sweep(tmp_path, '"inference.kappa" = [0.6]\n', extra='plan = "nope.toml"\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert str(path) in line and "plan" in line and str(tmp_path / "nope.toml") in line


def test_presets_by_name_still_work_for_experiment_and_plan(tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    path = _sweep(tmp_path, '"inference.kappa" = [0.6]\n', extra='plan = "study-code"\n')
    monkeypatch.chdir(tmp_path)
    loaded = load_sweep(str(path))
    assert loaded.spec.plan == "study-code" and loaded.points[0].config.experiment.name == "smoke"


# --- 4: one readable line for a bad sweep file ----------------------------------------------------

@pytest.mark.parametrize(("parameter", "expected"), [
    ('"inference.kappa" = []', "at least one value"),
    ('"inference.kappa" = { low = 0.8, high = 0.5 }', "low must be below high"),
    ('"inference.kappa" = { low = nan, high = 0.5 }', "finite"),
    ('"inference.kappa" = "abc"', "a list of values"),
    ('"inference.kappa" = { low = 0.5, high = 0.8, values = [0.6] }', "not both"),
    ('"inference.kappa" = { low = 0.5 }', "high"),
    ('"inference.kappa" = [0.5, 0.6, 0.5]', "0.5 is given twice"),  # a grid would weigh it twice
    ('"inference.kappa" = { values = [0, 0] }', "0 is given twice"),
])
def test_a_bad_parameter_gets_one_plain_line(tmp_path: Path, parameter: str, expected: str) -> None:
    path = _sweep(tmp_path, parameter + "\n", method="sobol")
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert f"{path}: parameters.inference.kappa: " in line and expected in line
    assert "function-after" not in line and "more problem" not in line and "Range" not in line


def test_a_bad_set_entry_names_the_sweep_files_set_not_a_set_option(tmp_path: Path) -> None:
    path = _sweep(tmp_path, '"inference.kappa" = [0.6]\n', extra='set = ["inference.kapa=0.3"]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert line.startswith(f"Error: {path}: set: inference.kapa=0.3: ") and "--set" not in line
    assert "kappa" in line  # the suggestion stays


@pytest.mark.parametrize(("hard", "expected"), [
    # the set alone is invalid (soft 0.6 above the default hard threshold), but point 1 runs with it:
    # point 0 (hard 0.5) is at fault, and named
    ("[0.5, 0.9]", "design point 0 (interface.hard_threshold=0.5) is not a valid experiment: "),
    ("[0.9, 0.5]", "design point 1 (interface.hard_threshold=0.5) is not a valid experiment: "),
    # every point fails: the set is at fault whatever the point
    ("[0.5, 0.55]", "set: interface.soft_threshold=0.6: "),
])
def test_a_set_is_blamed_only_when_every_point_fails(tmp_path: Path, hard: str, expected: str) -> None:
    path = _sweep(tmp_path, f'"interface.hard_threshold" = {hard}\n',
                  extra='set = ["interface.soft_threshold=0.6"]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert line.startswith(f"Error: {path}: {expected}"), line
    assert "soft_threshold <= hard_threshold" in line


def test_a_key_both_set_and_swept_is_refused(tmp_path: Path) -> None:
    path = _sweep(tmp_path, '"inference.kappa" = [0.6, 0.7]\n', extra='set = ["inference.kappa = 0.3"]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert str(path) in line and "inference.kappa" in line and "set" in line and "[parameters]" in line


def test_a_set_key_inside_a_swept_table_is_refused(tmp_path: Path) -> None:
    # the points' tables come after the set and would drop its weight at every point
    tables = '"policies.threshold.params" = [{threshold=0.5}, {threshold=0.9}]'
    path = _custom_sweep(tmp_path, tables + "\n")
    fixed = 'set = ["policies.threshold.params.weight=0.1"]'
    path.write_text(path.read_text().replace("replications = 1\n", f"replications = 1\n{fixed}\n"))
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert line.startswith(f"Error: {path}: policies.threshold.params.weight in set lies inside "
                           "policies.threshold.params, which [parameters] sets whole"), line
    assert "give weight in each of policies.threshold.params's values" in line
    # the other way round, a key inside a table the set fixes, is varied within it
    path.write_text(path.read_text().replace(tables, '"policies.threshold.params.weight" = [0.2, 0.4]')
                    .replace("params.weight=0.1", "params={threshold=0.7}"))
    params = [point.config.policies["threshold"].params for point in load_sweep(str(path)).points]
    assert params == [{"threshold": 0.7, "weight": 0.2}, {"threshold": 0.7, "weight": 0.4}]


def test_an_experiment_file_given_as_the_sweep_file_is_named_as_such(tmp_path: Path) -> None:
    line = _error_line(["sweep", str(list_presets("experiments")["smoke"]), "--out", str(tmp_path / "out")])
    assert "looks like an experiment file, not a sweep file" in line and "valid string" not in line


def test_a_folder_given_as_the_sweep_file_is_named_a_folder(tmp_path: Path) -> None:
    line = _error_line(["sweep", str(tmp_path), "--out", str(tmp_path / "out")])
    assert f"{tmp_path} is a folder" in line and "does not exist" not in line


# --- 5: the help names the default folder a sweep writes ------------------------------------------

def test_the_sweep_help_names_its_default_folder() -> None:
    result = CliRunner().invoke(main, ["sweep", "--help"], terminal_width=200)
    assert "results/<sweep file>-sweep-<UTC time>" in result.output
    assert "<experiment>-<command>" not in result.output


# --- 6: a sweep varies any key --set accepts, a custom policy's parameter too ---------------------

THRESHOLD = "policies.threshold.params.threshold"


def _custom_sweep(folder: Path, parameters: str, method: str = "grid") -> Path:
    """A sweep over the shipped custom-policy experiment (its policy module beside it)."""
    path = folder / "s.toml"
    design = f'method = "{method}"' + ("\nsamples = 2\nlevels = 4" if method != "grid" else "")
    path.write_text(f'experiment = "{list_presets("experiments")["custom-policy"]}"\nreplications = 1\n\n'
                    f"[design]\n{design}\n\n[parameters]\n{parameters}")
    return path


def test_a_custom_policys_parameter_is_swept_over_a_list_of_values(tmp_path: Path) -> None:
    loaded = load_sweep(str(_custom_sweep(tmp_path, f'"{THRESHOLD}" = {{ values = [0.5, 0.9] }}\n')))
    assert [p.parameters for p in loaded.points] == [{THRESHOLD: 0.5}, {THRESHOLD: 0.9}]
    # each point's experiment is what --set gives: the swept value, the other parameter kept
    for point in loaded.points:
        config = load_experiment(str(list_presets("experiments")["custom-policy"]),
                                 [f"{THRESHOLD}={point.parameters[THRESHOLD]}"])
        assert point.config == config
        assert point.config.policies is not None
        assert point.config.policies["threshold"].params == {"threshold": point.parameters[THRESHOLD],
                                                             "weight": 0.5}


@pytest.mark.parametrize("method", ["sobol", "morris"])
def test_a_custom_policys_parameter_is_swept_over_a_range(tmp_path: Path, method: str) -> None:
    path = _custom_sweep(tmp_path, f'"{THRESHOLD}" = {{ low = 0.5, high = 0.9 }}\n'
                                   '"policies.threshold.params.weight" = [0.25, 0.75]\n', method)
    loaded = load_sweep(str(path))
    assert loaded.problem is not None and loaded.problem["names"][0] == THRESHOLD
    drawn = [p.parameters[THRESHOLD] for p in loaded.points]
    assert len(set(drawn)) > 1 and all(0.5 <= t <= 0.9 for t in drawn)
    for point in loaded.points:
        assert point.config.policies is not None
        weight = point.parameters["policies.threshold.params.weight"]
        assert point.config.policies["threshold"].params == {"threshold": point.parameters[THRESHOLD],
                                                             "weight": weight}


def test_sweep_help_names_the_page_of_the_format() -> None:
    shown = " ".join(CliRunner().invoke(main, ["sweep", "--help"]).output.split())
    assert "see docs/batches.md for the format" in shown and "README" not in shown


def test_a_later_set_wins_and_a_later_table_replaces_an_earlier_nested_key() -> None:
    # the rule docs/batches.md states for --set and a sweep's set then parameters
    custom = str(list_presets("experiments")["custom-policy"])
    params = [load_experiment(custom, overrides).policies["threshold"].params for overrides in (
        ["policies.threshold.params.weight=0.1", "policies.threshold.params={threshold=0.7}"],
        ["policies.threshold.params={threshold=0.7}", "policies.threshold.params.weight=0.1"],
        ["policies.threshold.params.weight=0.1", "policies.threshold.params.weight=0.3"])]
    assert params == [{"threshold": 0.7}, {"threshold": 0.7, "weight": 0.1},
                      {"threshold": 0.6, "weight": 0.3}]


def test_a_table_is_a_parameter_value_as_it_is_a_set_value(tmp_path: Path) -> None:
    # a whole params table per point, as --set 'policies.threshold.params={threshold=0.5}' gives it
    loaded = load_sweep(str(_custom_sweep(
        tmp_path, '"policies.threshold.params" = [{threshold=0.5}, {threshold=0.9, weight=0.2}]\n')))
    params = [point.config.policies["threshold"].params for point in loaded.points]
    assert params == [{"threshold": 0.5}, {"threshold": 0.9, "weight": 0.2}]


_TOML_VALUES = st.recursive(
    st.one_of(st.text(), st.booleans(), st.integers(-(2**63), 2**63 - 1), st.floats(allow_nan=False)),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(), inner, max_size=3), max_leaves=6)


@given(value=_TOML_VALUES)
def test_every_value_reaches_a_point_as_written(value: object) -> None:
    # a point's override text is what --set reads back as the value itself
    (text,) = point_overrides([], {"study.x": value})
    assert parse_override(text) == (["study", "x"], value)


def test_a_point_whose_policy_refuses_its_parameter_is_named_before_anything_runs(tmp_path: Path) -> None:
    # the check --set gives (nudge simulate --set policies.threshold.params.weight=2 is refused by the
    # policy itself), at every point, before a folder exists
    path = _custom_sweep(tmp_path, '"policies.threshold.params.weight" = [0.5, 2.0]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert str(path) in line and "design point 1" in line and "weight" in line
    assert "weight must lie in [0, 1], got 2" in line
    assert not (tmp_path / "out").exists()


def test_a_parameter_the_policy_does_not_take_is_named_with_its_signature(tmp_path: Path) -> None:
    path = _custom_sweep(tmp_path, '"policies.threshold.params.treshold" = [0.5]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert "design point 0" in line and "treshold" in line and "signature" in line


@pytest.mark.parametrize(("key", "expected"), [
    ("inference.kapa", "(did you mean 'kappa'?)"),
    ("polices.threshold.params.threshold", "(did you mean 'policies'?)"),
])
def test_a_wrong_key_still_gets_the_did_you_mean(tmp_path: Path, key: str, expected: str) -> None:
    path = _custom_sweep(tmp_path, f'"{key}" = [0.5]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert str(path) in line and key in line and expected in line


@pytest.mark.parametrize("key", ["kappa", "inference.", ". kappa", "inference..", ""])
def test_a_key_without_a_section_and_a_key_is_refused_as_set_refuses_it(tmp_path: Path, key: str) -> None:
    path = _sweep(tmp_path, f'"{key}" = [0.5]\n')
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert f"parameter {key!r}" in line and "section.key" in line
    with pytest.raises(ConfigError, match="name the section and the key"):
        parse_override(f"{key}=0.5")


@given(st.lists(st.text(alphabet="ab. ", max_size=4), min_size=1, max_size=4).map(".".join))
def test_a_sweep_takes_exactly_the_keys_set_takes(key: str) -> None:
    try:
        parse_override(f"{key}=1")
    except ConfigError:
        takes = False
    else:
        takes = True
    try:
        SweepFile(experiment="unused", parameters={key: Values(values=[1])})
    except ValidationError:
        swept = False
    else:
        swept = True
    assert swept == takes


# --- 7: Morris takes an even number of levels only ------------------------------------------------

@pytest.mark.parametrize("levels", [3, 5, 7])
def test_odd_morris_levels_are_refused_in_one_line(tmp_path: Path, levels: int) -> None:
    path = _sweep(tmp_path, '"inference.kappa" = { low = 0.5, high = 0.8 }\n', method="morris")
    path.write_text(path.read_text().replace('method = "morris"', f'method = "morris"\nlevels = {levels}'))
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert f"{path}: design.levels: " in line and "even" in line and f"got {levels}" in line
    assert f"{levels - 1} or {levels + 1}" in line
    assert not (tmp_path / "out").exists()


def test_levels_unused_by_a_design_are_not_checked() -> None:
    assert Design(method="sobol", levels=5).levels == 5  # sobol and grid ignore levels
    assert Design(method="grid", levels=3).levels == 3


@pytest.mark.parametrize("levels", [2, 4, 6, 10])
def test_even_morris_levels_put_every_coordinate_on_the_k_over_l_minus_1_grid(levels: int) -> None:
    # brute force over every drawn coordinate of two unit ranges: u (L - 1) is a whole k in 0..L-1
    spec = SweepFile(experiment="unused", design=Design(method="morris", samples=20, levels=levels, seed=3),
                     parameters={"a.x": Range(low=0, high=1), "a.y": Range(low=0, high=1)})
    samples = design_values(spec)[2]
    assert samples is not None and samples.shape == (20 * 3, 2)
    steps = samples * (levels - 1)
    assert abs(steps - steps.round()).max() < 1e-9 and steps.min() >= 0 and steps.max() <= levels - 1


# --- 8: a name that is both a preset and a file beside the sweep file is ambiguous ----------------

@pytest.mark.parametrize(("field", "name", "kind"), [("experiment", "smoke", "experiments"),
                                                    ("plan", "paper", "analysis")])
def test_a_name_both_a_preset_and_a_file_beside_the_sweep_file_is_refused_naming_both(
        tmp_path: Path, field: str, name: str, kind: str) -> None:
    preset = list_presets(kind)[name]  # type: ignore[arg-type]
    (tmp_path / name).write_text(preset.read_text())  # a file of that name, without .toml
    extra = f'plan = "{name}"\n' if field == "plan" else ""
    path = _sweep(tmp_path, '"inference.kappa" = [0.6]\n', extra=extra)
    line = _error_line(["sweep", str(path), "--out", str(tmp_path / "out")])
    assert line.startswith(f"Error: {path}: {field}: ")
    assert str(preset) in line and str(tmp_path / name) in line  # both candidates, by their paths
    assert f"./{name}" in line  # how to name the file
    assert not (tmp_path / "out").exists()


def test_a_file_beside_the_sweep_file_written_as_a_path_is_taken_over_the_preset(tmp_path: Path) -> None:
    smoke = list_presets("experiments")["smoke"].read_text()
    (tmp_path / "smoke").write_text(smoke.replace('name = "smoke"', 'name = "mine"'))
    path = _sweep(tmp_path, '"inference.kappa" = [0.6]\n')
    path.write_text(path.read_text().replace('"smoke"', '"./smoke"'))
    assert load_sweep(str(path)).points[0].config.experiment.name == "mine"
