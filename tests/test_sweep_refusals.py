"""Sweep files a design would run short of what they say, refused before anything runs with one
``Error:`` line that names the fix (nudgecli.runs.sweep_file, nudgecli.runs.sweep, ``nudge sweep``):

- a Morris design's set of more values than levels (some values would never run);
- a range of reals over a key that takes whole numbers (the fix is ``integer = true``);
- a set's value or a range's end the experiment does not take, which a Sobol design may not draw.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner
from SALib.sample import morris

from nudgecli.cli import main
from nudgecli.runs.sweep import (
    Design,
    SweepFile,
    Values,
    design_values,
    load_sweep,
    map_sample,
    salib_problem,
)

HEAD = """\
experiment = "smoke"
replications = 1
seed = 3

[design]
method = "{method}"
samples = 2
{design}
[parameters]
"""

KAPPAS = "[0.5, 0.6, 0.7, 0.8, 0.9]"


def _sweep(folder: Path, parameters: str, *, method: str, design: str = "") -> Path:
    path = folder / "s.toml"
    path.write_text(HEAD.format(method=method, design=design) + parameters + "\n")
    return path


def _refused(path: Path) -> str:
    """The one ``Error:`` line ``nudge sweep`` refuses ``path`` with, having written nothing."""
    out = path.parent / "out"
    result = CliRunner().invoke(main, ["sweep", str(path), "--out", str(out)])
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"Error: {path}: "), result.output
    assert not out.exists()
    return lines[0]


# --- a Morris design takes one value of a set per grid level --------------------------------------

def _values_drawn(count: int, levels: int) -> set[int]:
    """The values (by index) SALib's Morris grid reaches over a set of ``count``: 200 trajectories,
    every level of the grid among their points."""
    problem = {"num_vars": 1, "names": ["a.b"], "bounds": [[0.0, float(count)]]}
    samples = morris.sample(problem, 200, num_levels=levels, seed=1)
    assert len({round(x * (levels - 1) / count) for x in samples[:, 0]}) == levels  # every level
    choices = Values(values=list(range(count)))
    return {map_sample(choices, float(x), (0.0, float(count)), levels) for x in samples[:, 0]}


@pytest.mark.parametrize("levels", [2, 4, 6])
def test_a_morris_set_is_sampled_whole_exactly_when_it_has_no_more_values_than_levels(levels: int) -> None:
    # SALib 1.6.0's own levels through the documented mapping: every value is reached for a set of
    # at most L values, and some never for more (L levels take at most L values); exactly the
    # sets of more values are refused
    for count in range(2, 12):
        whole = _values_drawn(count, levels) == set(range(count))
        assert whole == (count <= levels), (count, levels)
        design = Design(method="morris", samples=2, levels=levels)
        parameters = {"a.b": Values(values=list(range(count)))}
        if whole:
            SweepFile(experiment="smoke", design=design, parameters=parameters)
        else:
            with pytest.raises(ValueError, match="would never run"):
                SweepFile(experiment="smoke", design=design, parameters=parameters)


def test_a_morris_set_of_more_values_than_levels_is_refused_naming_the_fix(tmp_path: Path) -> None:
    path = _sweep(tmp_path, f'"inference.kappa" = {KAPPAS}', method="morris", design="levels = 4")
    line = _refused(path)
    assert "parameters.inference.kappa" in line and "levels = 4" in line and "5 values" in line
    assert "set levels = 6" in line and "at most 4 values" in line
    # the advice runs: six levels reach all five values
    advised = path.read_text().replace("levels = 4", "levels = 6").replace("samples = 2", "samples = 10")
    path.write_text(advised)
    drawn = {point.parameters["inference.kappa"] for point in load_sweep(str(path)).points}
    assert drawn == {0.5, 0.6, 0.7, 0.8, 0.9}


def test_a_sobol_design_and_an_integer_range_keep_their_rules(tmp_path: Path) -> None:
    # Sobol has no grid, and an integer range is documented to take at most L of its integers
    load_sweep(str(_sweep(tmp_path, f'"inference.kappa" = {KAPPAS}', method="sobol")))
    path = _sweep(tmp_path, '"study.participants" = { low = 1, high = 6, integer = true }', method="morris",
                  design="levels = 4")
    assert len(load_sweep(str(path)).points) == 4


# --- a range of reals over a whole-number key ------------------------------------------------------

@pytest.mark.parametrize(("method", "bounds", "integers"), [
    ("sobol", "low = 2.5, high = 6", {3, 4, 5, 6}),
    ("sobol", "low = 2.0, high = 6.0", {2, 3, 4, 5, 6}),
    ("morris", "low = 1, high = 4", {1, 2, 3, 4}),
])
def test_a_real_range_over_a_whole_number_key_is_told_to_take_integer_true(
        tmp_path: Path, method: str, bounds: str, integers: set[int]) -> None:
    path = _sweep(tmp_path, f'"study.participants" = {{ {bounds} }}', method=method,
                  design="levels = 4" if method == "morris" else "")
    line = _refused(path)
    assert "parameters.study.participants" in line and "whole number" in line
    assert "integer = true" in line and "give a whole number" not in line
    # the advised entry, as the line writes it, validates and runs the range's integers
    advised = line.split("add integer = true: ", 1)[1].split(" (the integers", 1)[0]
    assert advised.startswith('"study.participants" = {') and "integer = true" in advised
    path.write_text(path.read_text().replace(f'"study.participants" = {{ {bounds} }}', advised)
                    .replace("samples = 2", "samples = 16"))
    drawn = {point.parameters["study.participants"] for point in load_sweep(str(path)).points}
    assert drawn == integers


# --- a value the experiment does not take, drawn or not --------------------------------------------

def test_a_set_value_outside_the_keys_bounds_is_refused_though_sobol_never_draws_it(tmp_path: Path) -> None:
    kappas = Values(values=[0.5, 0.6, 0.7, 0.8, 1.5])
    spec = SweepFile(experiment="smoke", design=Design(method="sobol", samples=2, seed=2),
                     parameters={"inference.kappa": kappas})
    assert 1.5 not in {p["inference.kappa"] for p in design_values(spec)[0]}  # with these seeds, unseen
    path = _sweep(tmp_path, f'"inference.kappa" = {kappas.values}', method="sobol", design="seed = 2")
    line = _refused(path)
    assert "parameters.inference.kappa" in line and "1.5" in line and "at most 1" in line
    assert "drop it" in line


def test_a_range_end_outside_the_keys_bounds_is_refused_though_sobol_never_draws_it(tmp_path: Path) -> None:
    spec = SweepFile.model_validate({"experiment": "smoke", "design": {"method": "sobol", "samples": 2},
                                     "parameters": {"inference.kappa": {"low": 0.5, "high": 1.02}}})
    (_, high), = salib_problem(spec)["bounds"]
    assert max(p["inference.kappa"] for p in design_values(spec)[0]) <= 1.0 < high  # unseen
    line = _refused(_sweep(tmp_path, '"inference.kappa" = { low = 0.5, high = 1.02 }', method="sobol"))
    assert "parameters.inference.kappa" in line and "high end 1.02" in line and "at most 1" in line
    assert "keep the range within" in line
