"""``nudge validate --states`` sizes the two-mode world only; the three-mode reading has the study's.
(``--belief-concentration`` likewise shapes the Dirichlet readings' beliefs only.)

``--reading three-mode --states 50`` is one ``Error:`` line (as ``--reading`` beside
``--all-readings`` is refused rather than ignored); with ``--all-readings`` ``--states`` still sizes
the two-mode rows, so a ``Note:`` line says the three-mode row keeps its own world. Before, both
took ``--states`` and ignored it for the three-mode world. Seen failing before the fix.
"""

from __future__ import annotations

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner

from nudgecli import command_defaults as defaults
from nudgecli.api.validation import validate
from nudgecli.cli import main
from nudgecli.errors import ConfigError
from nudgecli.sim.validation.readings import READINGS
from nudgecli.sim.validation.settings import states_note

SMALL = ["validate", "--simulations", "1", "--min-goals", "3", "--max-goals", "3", "--mc-queries", "0"]


def _never(*args: object, **kwargs: object) -> None:
    raise AssertionError("the validation ran before the option check")


@pytest.mark.parametrize("states", ["50", "72", "2400"])
def test_states_with_the_three_mode_reading_is_one_error_line(tmp_path, monkeypatch, states: str) -> None:
    monkeypatch.setattr("nudgecli.sim.validation.run_validation", _never)
    out = tmp_path / "v"
    result = CliRunner().invoke(main, [*SMALL, "--reading", "three-mode", "--states", states,
                                       "--out", str(out)])
    line = one_error_line(result.output)
    assert result.exit_code == 1
    assert f"--states {states}" in line and "three-mode" in line and "2400" in line
    assert not out.exists()


def test_the_api_refuses_states_with_the_three_mode_reading() -> None:
    with pytest.raises(ConfigError, match="--states 72 does not apply to --reading three-mode"):
        validate(simulations=1, min_goals=3, max_goals=3, states=72, mc_queries=0, reading="three-mode")


@pytest.mark.parametrize("reading", ["three-mode", "two-goal"])
def test_a_reading_without_the_option_it_ignores_runs_with_the_defaults(monkeypatch, reading: str) -> None:
    ran = []
    monkeypatch.setattr("nudgecli.sim.validation.run_validation",
                        lambda settings, progress: ran.append(settings))
    monkeypatch.setattr("nudgecli.sim.validation.runner.mc_queries_notes", lambda results: [])  # of no result
    monkeypatch.setattr("nudgecli.api.validation.Validation.text", lambda self: "")
    result = CliRunner().invoke(main, [*SMALL, "--reading", reading])
    assert result.exit_code == 0, result.output
    assert [s.reading for s in ran] == [reading] and "Note" not in result.output
    assert ran[0].states == defaults.VALIDATION_STATES
    assert ran[0].belief_concentration == defaults.VALIDATION_BELIEF_CONCENTRATION


def test_all_readings_with_states_notes_that_the_three_mode_row_keeps_its_world(monkeypatch) -> None:
    seen = []
    monkeypatch.setattr("nudgecli.sim.validation.run_all_readings",
                        lambda settings, names, progress: seen.append((settings, names)) or [])
    monkeypatch.setattr("nudgecli.api.validation.Validation.text", lambda self: "the table")
    result = CliRunner().invoke(main, [*SMALL, "--all-readings", "--states", "72"])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines() if line.startswith("Note: ")]
    assert len(notes) == 1 and "--states 72" in notes[0] and "three-mode" in notes[0] and "2400" in notes[0]
    assert result.stdout.strip() == "the table"
    (settings, names), = seen
    assert settings.states == 72 and names == list(READINGS)


def test_all_readings_without_states_has_no_note(monkeypatch) -> None:
    monkeypatch.setattr("nudgecli.sim.validation.run_all_readings", lambda settings, names, progress: [])
    monkeypatch.setattr("nudgecli.api.validation.Validation.text", lambda self: "the table")
    result = CliRunner().invoke(main, [*SMALL, "--all-readings"])
    assert result.exit_code == 0, result.output
    assert "Note" not in result.output


@pytest.mark.parametrize("names", [["dirichlet"], ["two-goal", "lambda-1"], list(READINGS), ["three-mode"]])
def test_states_not_given_needs_no_word(names: list[str]) -> None:
    assert states_note(None, names) is None


def test_states_given_as_its_default_is_still_given(monkeypatch) -> None:
    # 200 typed out is as much a request for a 10 x 10 two-mode world as 50 is
    monkeypatch.setattr("nudgecli.sim.validation.run_validation", _never)
    result = CliRunner().invoke(main, [*SMALL, "--reading", "three-mode", "--states",
                                       str(defaults.VALIDATION_STATES)])
    assert result.exit_code == 1 and f"--states {defaults.VALIDATION_STATES} does not apply" in result.output
    with pytest.raises(ConfigError, match="does not apply to --reading three-mode"):
        validate(simulations=1, min_goals=3, max_goals=3, states=defaults.VALIDATION_STATES, mc_queries=0,
                 reading="three-mode")


def test_states_for_two_mode_readings_alone_needs_no_word() -> None:
    assert states_note(72, [name for name, r in READINGS.items() if r.world == "two-mode"]) is None


def test_states_for_the_three_mode_reading_alone_is_refused() -> None:
    with pytest.raises(ConfigError, match="--states 50 does not apply"):
        states_note(50, ["three-mode"])


def test_belief_concentration_with_the_two_goal_reading_is_one_error_line(tmp_path, monkeypatch) -> None:
    # the two-goal reading splits each query's belief between two goals: no Dirichlet to shape
    monkeypatch.setattr("nudgecli.sim.validation.run_validation", _never)
    out = tmp_path / "v"
    result = CliRunner().invoke(main, [*SMALL, "--reading", "two-goal", "--belief-concentration", "5",
                                       "--out", str(out)])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and not out.exists()
    assert "--belief-concentration 5 does not apply to --reading two-goal" in line and "two goals" in line
    with pytest.raises(ConfigError, match="--belief-concentration 1 does not apply"):
        validate(simulations=1, min_goals=3, max_goals=3, belief_concentration=1.0, mc_queries=0,
                 reading="two-goal")


def test_all_readings_with_belief_concentration_notes_the_two_goal_row(monkeypatch) -> None:
    seen = []
    monkeypatch.setattr("nudgecli.sim.validation.run_all_readings",
                        lambda settings, names, progress: seen.append(settings) or [])
    monkeypatch.setattr("nudgecli.api.validation.Validation.text", lambda self: "the table")
    result = CliRunner().invoke(main, [*SMALL, "--all-readings", "--belief-concentration", "5"])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.stderr.splitlines() if line.startswith("Note: ")]
    assert len(notes) == 1 and "--belief-concentration 5" in notes[0] and "two-goal row" in notes[0]
    assert seen[0].belief_concentration == 5.0
