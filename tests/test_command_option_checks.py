"""The option checks the simulating commands share: an empty ``--out`` (every command) and a
participant count above ``study.participants``' bound (the one ``--set study.participants`` meets)
are one ``Error:`` line before any work, and ``--yes`` promises no question that is never asked."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner

from nudgecli.cli import main


def invoke(*args: str | Path):
    return CliRunner().invoke(main, [str(a) for a in args])


# --- the options every command shares ----------------------------------------------------------


@pytest.mark.parametrize("args", [
    ("replicate", "smoke", "-R", "1", "--participants", "2"),
    ("sweep", "example"),
    ("run", "smoke", "--participants", "2"),
    ("simulate", "smoke", "--participants", "2"),
    ("fit-people", "ciaa-people"),
], ids=lambda args: args[0])
def test_an_empty_out_is_refused_before_any_work(tmp_path, monkeypatch, args) -> None:
    monkeypatch.chdir(tmp_path)
    result = invoke(*args, "--out", "")
    assert result.exit_code == 1
    assert '--out "": an empty path' in one_error_line(result.output)
    assert list(tmp_path.iterdir()) == []  # no default folder made


@pytest.mark.parametrize("args", [
    ("replicate", "smoke", "-R", "1", "--participants", "10001"),
    ("power", "smoke", "-R", "1", "--participants", "2,10001"),
    ("run", "smoke", "--participants", "10001"),
    ("simulate", "smoke", "--participants", "10001"),
], ids=lambda args: args[0])
def test_participants_over_the_fields_bound_are_refused_as_set_refuses_them(tmp_path, monkeypatch,
                                                                             args) -> None:
    def started(*_: object, **__: object) -> None:
        raise AssertionError("the study started")  # a count the bound let through fails fast, not for hours

    monkeypatch.setattr("nudgecli.runs.study._run_locked", started)
    monkeypatch.setattr("nudgecli.runs.batch_kinds.run_batch", started)
    by_set = invoke(*[a.replace("10001", "3") for a in args], "--set", "study.participants=10001",
                    "--out", tmp_path / "set")
    bound = "study.participants: must be at most 10000"
    assert bound in one_error_line(by_set.output)
    result = invoke(*args, "--yes", "--out", tmp_path / "out")  # the size limit is not what refuses it
    assert result.exit_code == 1
    line = one_error_line(result.output)
    assert line.startswith("Error: --participants 10001: ") and bound in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["run", "simulate", "replicate", "plot-population", "validate"])
def test_the_yes_help_promises_no_question(command) -> None:
    result = invoke(command, "--help")
    assert result.exit_code == 0
    assert "--yes" in result.output and "without asking" not in result.output


def test_the_condition_order_help_names_the_counterbalancing_design() -> None:
    result = invoke("study", "--help")
    assert result.exit_code == 0
    text = " ".join(result.output.split())  # click wraps the help
    assert "--condition-order A,B,..." in text
    assert "rotates" not in text
    assert "any order the experiment's [study] counterbalancing design assigns" in text
