"""The Python API's rough edges a QA pass found, each one clear ``Error:`` line before any work:

- ``out=`` naming an existing file gets the one message of every ``--out`` that is a file
  (:func:`nudgecli.outputs.check_not_a_file`), not "check that the folder exists";
- ``plot(..., ax=)`` takes one matplotlib Axes, named as ``ax=`` (not an error deep in matplotlib);
- a questionnaire "file" that is a folder, and a calibration "folder" that is a file, are named so;
- the size guard's refusal names the API's switch (``confirm=True``, ``yes=True``), the command
  line's still ``--yes``;
- ``trial=`` with a figure that is not of one trial, and ``metrics=[]``, are refused, never ignored;
- the commands the API's messages suggest quote a path with spaces for the shell.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli
from nudgecli.errors import ConfigError, DataError, RunFolderError
from nudgecli.runs.size import override_named

#: The analysed smoke run's metric a panel is drawn of, and a trial of it.
METRIC = "completion_time"
TRIAL = (0, 1)
#: A table of real trials the paper plan analyses as it is.
TABLE = Path(__file__).parent / "data" / "metrics_two_conditions_paper.csv"


def files_under(folder: Path) -> dict[Path, bytes]:
    return {path: path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


# --- out= naming a file ----------------------------------------------------------------------------


@pytest.mark.parametrize("call", ["simulate", "replicate", "analyze", "save_figures", "compare",
                                  "plot_population", "validate"])
def test_an_out_that_is_a_file_gets_the_one_message_of_every_command(analysed_smoke_run: Path,
                                                                    tmp_path: Path, call: str) -> None:
    target = tmp_path / "notes.txt"
    target.write_text("mine\n", encoding="utf-8")
    before = files_under(analysed_smoke_run)
    calls = {
        "simulate": lambda: nudgecli.simulate("smoke", participants=2, out=target),
        "replicate": lambda: nudgecli.replicate("smoke", 1, participants=2, out=target),
        "analyze": lambda: nudgecli.analyze(analysed_smoke_run, out=target),
        "save_figures": lambda: nudgecli.save_figures(analysed_smoke_run, out=target, formats="png"),
        "compare": lambda: nudgecli.compare(analysed_smoke_run, analysed_smoke_run / "metrics.csv",
                                            out=target),
        "plot_population": lambda: nudgecli.plot_population("smoke", participants=2, out=target),
        "validate": lambda: nudgecli.validate(simulations=1, min_goals=3, max_goals=3, states=40,
                                              mc_queries=0, out=target),
    }
    with pytest.raises(DataError) as raised:
        calls[call]()
    assert str(raised.value) == f"--out {target} is a file; give a folder"
    assert target.read_text(encoding="utf-8") == "mine\n" and sorted(tmp_path.iterdir()) == [target]
    assert files_under(analysed_smoke_run) == before


# --- plot(ax=) ------------------------------------------------------------------------------------


def test_plot_refuses_an_ax_that_is_not_one_axes(analysed_smoke_run: Path) -> None:
    from matplotlib.figure import Figure

    pair = Figure().subplots(1, 2)
    with pytest.raises(ConfigError, match=r"^ax='left': ax= takes one matplotlib Axes \(e\.g\. "
                                          r"fig\.add_subplot\(\)\) or None, not str$"):
        nudgecli.plot(analysed_smoke_run, METRIC, ax="left")
    with pytest.raises(ConfigError, match=r"^ax=ndarray of 2: ax= takes one matplotlib Axes .* not several "
                                          r"axes; give one of them, e\.g\. ax=axes\[0\]$"):
        nudgecli.plot(analysed_smoke_run, METRIC, ax=pair)
    assert nudgecli.plot(analysed_smoke_run, METRIC, ax=pair[0]) is pair[0].figure  # one of them draws


# --- a folder for a file, a file for a folder ------------------------------------------------------


def test_a_questionnaire_folder_is_named_a_folder(analysed_smoke_run: Path, tmp_path: Path) -> None:
    answers = tmp_path / "answers"
    answers.mkdir()
    run = shutil.copytree(analysed_smoke_run, tmp_path / "run")
    with pytest.raises(DataError, match=rf"^questionnaire file {answers} is a folder, not a file; give a CSV "
                                        "file with participant, condition"):
        nudgecli.analyze(run, questionnaires=answers, bootstrap=100)


def test_a_calibration_file_is_named_a_file(tmp_path: Path) -> None:
    logs = tmp_path / "logs.csv"
    logs.write_text("t,x\n", encoding="utf-8")
    with pytest.raises(DataError, match=rf"^{logs}: a file, not a folder; give one participant's calibration "
                                        "folder"):
        nudgecli.fit(logs)


# --- the size guard's override --------------------------------------------------------------------


@pytest.mark.parametrize(("call", "override"), [
    (lambda: nudgecli.simulate("smoke", participants=2), "confirm=True"),  # 16 trials, over the limit below
    (lambda: nudgecli.replicate("smoke", 100_000, participants=2), "confirm=True"),
    (lambda: nudgecli.validate(simulations=100_000, min_goals=3, max_goals=3, mc_queries=0), "yes=True"),
    (lambda: nudgecli.plot_population("smoke", participants=100_000), "yes=True"),
], ids=["simulate", "replicate", "validate", "plot_population"])
def test_the_size_guard_names_the_apis_switch(call, override: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("nudgecli.runs.size.MAX_TRIALS_WITHOUT_YES", 10)
    with pytest.raises(ConfigError, match=rf"; pass {override} to run it, or use fewer "):
        call()


def test_the_command_line_still_names_yes(tmp_path: Path) -> None:
    result = nudge("validate", "--simulations", "100000", "--min-goals", "3", "--max-goals", "3",
                   "--mc-queries", "0", "--out", tmp_path / "out")
    assert result.exit_code == 1 and "; pass --yes to run it, or use fewer " in one_error_line(result.output)


def test_the_outermost_front_end_names_the_override() -> None:
    from nudgecli.runs.size import check_size

    with pytest.raises(ConfigError, match="pass --yes "), override_named("--yes"), \
            override_named("confirm=True"):
        check_size(2, False, limit=1)
    with pytest.raises(ConfigError, match="pass --yes "):  # the name is set back after the block
        with override_named("confirm=True"):
            pass
        check_size(2, False, limit=1)


# --- what was ignored ------------------------------------------------------------------------------


@pytest.mark.parametrize("figure", ["fig4", METRIC])
def test_plot_refuses_a_trial_its_figure_would_ignore(analysed_smoke_run: Path, figure: str) -> None:
    with pytest.raises(ConfigError, match=rf"^trial=\(0, 1\): figure '{figure}' is not of one trial; trial= "
                                          r"chooses the trial of fig5 and trajectory: leave it out \(None\)"):
        nudgecli.plot(analysed_smoke_run, figure, trial=TRIAL)


def test_an_empty_metrics_list_is_refused(analysed_smoke_run: Path, tmp_path: Path) -> None:
    refused = (r"^metrics=\[\]: an empty list names none; name at least one, or leave metrics= out \(None\) "
               r"for all$")
    with pytest.raises(ConfigError, match=refused):
        nudgecli.analyze(analysed_smoke_run, metrics=[], out=tmp_path / "analysis")
    with pytest.raises(ConfigError, match=refused):
        nudgecli.compare(analysed_smoke_run, analysed_smoke_run / "metrics.csv", metrics=[])
    assert list(tmp_path.iterdir()) == []


# --- suggested commands quote their paths ----------------------------------------------------------


def test_plot_plan_suggests_commands_with_quoted_paths(tmp_path: Path) -> None:
    from nudgecli.api.figures import _check_no_questionnaires

    folder = tmp_path / "my study"
    folder.mkdir()
    (folder / "questionnaire_scores.csv").write_text("participant\n", encoding="utf-8")
    with pytest.raises(ConfigError) as raised:
        _check_no_questionnaires(folder, None, "my plan.toml")
    message = str(raised.value)
    assert f"`nudge analyze '{folder}' --plan 'my plan.toml' --questionnaires ANSWERS.csv`" in message
    assert message.endswith(f"then `nudge plot '{folder}'`")


def test_plot_plan_of_a_table_gone_names_its_folder_quoted(tmp_path: Path) -> None:
    table = tmp_path / "my data" / "t.csv"
    table.parent.mkdir()
    shutil.copyfile(TABLE, table)
    analysis = nudgecli.analyze(table, plan="paper", bootstrap=100)
    table.unlink()  # --plan would analyse it again: it is not there
    with pytest.raises(RunFolderError) as raised:
        nudgecli.save_figures(analysis.path, plan="paper", formats="png")
    assert f"`nudge analyze TABLE --plan PLAN --out '{analysis.path}'`" in str(raised.value)
