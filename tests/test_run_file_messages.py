"""A run folder's damaged files named with what restores them: an unreadable manifest, a deleted
``layouts.parquet`` or ``participants.parquet`` (files the manifest records), through the command
line where a researcher meets them; the analysis already written stays as it was."""

from __future__ import annotations

import shlex

import pytest
from cli_helpers import copy_run, file_digests, nudge, one_error_line

ANALYSIS_FILES = ("stats.json", "stats.csv", "summary.md")


def _command_in(line: str) -> list[str]:
    """The command a message quotes between backticks, as words (the last quoted one)."""
    return shlex.split(line.rsplit("`", 2)[-2])


@pytest.mark.parametrize("damage", ["{not json", "\xff\xfe".encode("latin-1").decode("latin-1")])
def test_an_unreadable_manifest_says_how_to_restore_the_run(tmp_path, analysed_smoke_run, damage):
    run = copy_run(analysed_smoke_run, tmp_path / "run")
    (run / "manifest.json").write_bytes(damage.encode("latin-1"))
    before = file_digests(run, ANALYSIS_FILES)
    for args in (["analyze", run], ["plot", run], ["simulate", "smoke", "--out", run, "--resume"]):
        line = one_error_line(nudge(*args).output)
        assert line.startswith(f"Error: {run / 'manifest.json'}: unreadable manifest ("), (args, line)
        assert line.endswith(f"); neither reading nor --resume can use the run without it: put it back "
                             f"from a copy, or delete it and simulate again: `nudge simulate "
                             f"{run / 'config.toml'} --out {run} --force` (with its --seed)"), (args, line)
    assert file_digests(run, ANALYSIS_FILES) == before
    # what it says restores the run (--force alone cannot tell a person's live sessions from a run)
    (run / "manifest.json").unlink()
    assert nudge(*_command_in(line)[1:], "--seed", "5", "--participants", "2").exit_code == 0
    assert nudge("analyze", run, "--bootstrap", "100").exit_code == 0


@pytest.mark.parametrize("name", ["participants.parquet", "layouts.parquet"])
def test_a_deleted_run_file_the_manifest_records_is_named_with_the_resume_command(
        tmp_path, analysed_smoke_run, name):
    """participants.parquet deleted: analyze and plot passed without a word."""
    run = copy_run(analysed_smoke_run, tmp_path / "run")
    (run / name).unlink()
    before = file_digests(run, ANALYSIS_FILES)
    for args in (["analyze", run, "--bootstrap", "100"], ["plot", run, "--trial", "0:0", "--formats", "png"]):
        line = one_error_line(nudge(*args).output)
        expected = f"Error: {run} is incomplete: {name} (missing); restore with `nudge simulate "
        assert line.startswith(expected), (args, line)
        assert line.endswith("--resume`"), line
    assert file_digests(run, ANALYSIS_FILES) == before
    assert not (run / "figures" / "trial_0_0.png").exists()
    # the command it names writes the file again, as it was
    assert nudge(*_command_in(line)[1:]).exit_code == 0
    assert (run / name).read_bytes() == (analysed_smoke_run / name).read_bytes()
    assert nudge("analyze", run, "--bootstrap", "100").exit_code == 0


def test_read_layouts_names_the_command_that_writes_them_again(tmp_path, analysed_smoke_run):
    """Reached without check_complete (a manifest of an older nudge, which records no files)."""
    from nudgecli.store import RunFolder

    run = copy_run(analysed_smoke_run, tmp_path / "run")
    (run / "layouts.parquet").unlink()
    with pytest.raises(Exception, match=r"no layouts\.parquet; the run folder is incomplete; restore it with "
                                        r"`nudge simulate .* --resume`$"):
        RunFolder(run).read_layouts()
