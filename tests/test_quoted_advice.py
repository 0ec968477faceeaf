"""A command a message advises names its folder quoted for the shell (``shell_words``): pasted as
it is, ``nudge analyze my run`` would name two folders, neither of them the run."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import nudgecli
from nudgecli.errors import NudgeError, RunFolderError


@pytest.fixture()
def spaced(tmp_path: Path) -> Path:
    """A folder whose name holds a space, inside this test's own."""
    return tmp_path / "my run"


def test_plot_of_a_run_not_analysed_quotes_the_analyze_command(spaced):
    nudgecli.simulate("smoke", participants=1, seed=2, out=spaced).close()
    with pytest.raises(RunFolderError, match="no metrics yet") as raised:
        nudgecli.plot(spaced, figure="fig4")
    assert f"run `nudge analyze '{spaced}'` first" in str(raised.value)


def test_plot_of_a_damaged_metrics_copy_quotes_the_command_that_writes_it(analysed_smoke_run, spaced):
    shutil.copytree(analysed_smoke_run, spaced)
    (spaced / "metrics.csv").write_text("participant,condition\n0,\"cut")
    with pytest.raises(NudgeError) as raised:
        nudgecli.plot(spaced, figure="fig4")
    assert f"`nudge analyze '{spaced}'`" in str(raised.value)


def test_plot_of_a_table_not_analysed_quotes_the_analyze_command(spaced):
    from nudgecli.report.plotting import analysis_folder_of_table

    spaced.mkdir()
    table = spaced / "metrics table.csv"
    table.write_text("participant,condition,x\n0,a,1\n")
    with pytest.raises(RunFolderError) as raised:
        analysis_folder_of_table(table)
    assert f"run `nudge analyze '{table}'` first" in str(raised.value)


def test_an_out_that_holds_a_run_quotes_the_plot_command(analysed_smoke_run, spaced):
    from nudgecli.outputs import check_output_folder

    shutil.copytree(analysed_smoke_run, spaced)
    with pytest.raises(RunFolderError) as raised:
        check_output_folder(spaced, force=False)
    assert f"(`nudge plot '{spaced}'` would draw them)" in str(raised.value)


def test_a_run_folders_advice_quotes_its_folder(spaced):
    from nudgecli.store import RunFolder

    spaced.mkdir()
    folder = RunFolder(spaced)
    assert folder.lost_run_command() == f"nudge simulate '{spaced}/config.toml' --out '{spaced}' --force"
    assert f"`nudge simulate EXPERIMENT --out '{spaced}'` first" in folder.no_parts_message("trials", None)
    (spaced / "metrics.csv").write_text("participant,condition,x\n0,a,1\n")
    assert f"`nudge analyze '{spaced}/metrics.csv'`" in folder.no_parts_message("trials", None)


def test_fit_of_several_sibling_session_folders_quotes_the_one_to_fit(tmp_path):
    folder = tmp_path / "my logs"
    for participant in ("p 1", "p2"):
        (folder / f"{participant}_p_ui_given_a").mkdir(parents=True)
    with pytest.raises(NudgeError) as raised:
        nudgecli.fit(folder)
    assert f"e.g. `nudge fit '{folder}/p 1_p_ui_given_a'`" in str(raised.value)


def test_fit_of_several_sessions_quotes_each_folder():
    from nudgecli.sim.calibration_readers import _several_sessions

    folder = Path("my logs")
    apart = _several_sessions(folder, [folder / "a 1" / "prompts.csv", folder / "b" / "prompts.csv"], "maps")
    assert "`nudge fit 'my logs/a 1'` or `nudge fit 'my logs/b'`" in str(apart)
    shared = _several_sessions(folder, [folder / "prompts.csv", folder / "b 2" / "prompts.csv"], "mapping")
    assert "fit the other with `nudge fit 'my logs/b 2'`" in str(shared)


def test_fit_of_a_folder_of_participants_quotes_the_one_to_fit(tmp_path):
    folder = tmp_path / "my logs"
    (folder / "person 1" / "p_phi_given_a").mkdir(parents=True)
    with pytest.raises(NudgeError) as raised:
        nudgecli.fit(folder)
    assert f"fit it with `nudge fit '{folder}/person 1'`" in str(raised.value)
