"""A run's ``manifest.json`` that is JSON but not an object (``[]``, ``"x"``, ``3``) is a damaged
manifest, refused with the one ``Error:`` line an unreadable one gets (as a batch's ``batch.json``
is), by every command that reads it and by ``nudgecli.Run.open``; the analysis already written stays
as it was."""

from __future__ import annotations

import pytest
from cli_helpers import copy_run, file_digests, nudge, one_error_line

import nudgecli
from nudgecli.errors import RunFolderError

ANALYSIS_FILES = ("stats.json", "stats.csv", "summary.md")


@pytest.mark.parametrize(("text", "kind"), [("[]", "an array"), ('"x"', "a string"), ("3", "a number"),
                                            ("null", "null")])
def test_a_manifest_not_a_json_object_is_a_damaged_manifest(tmp_path, analysed_smoke_run, text, kind):
    run = copy_run(analysed_smoke_run, tmp_path / "run")
    (run / "manifest.json").write_text(text, encoding="utf-8")
    before = file_digests(run, ANALYSIS_FILES)
    expected = f"Error: {run / 'manifest.json'}: unreadable manifest ({kind}, not a JSON object); "
    for args in (["analyze", run], ["plot", run],
                 ["simulate", "smoke", "--participants", "2", "--seed", "5", "--out", run, "--resume"]):
        result = nudge(*args)
        assert result.exit_code != 0, args
        line = one_error_line(result.output)
        assert line.startswith(expected), (args, line)
        assert "--force" in line, line  # the fix: simulate again
    with pytest.raises(RunFolderError, match=r"unreadable manifest \(" + kind):
        nudgecli.Run.open(run)
    assert file_digests(run, ANALYSIS_FILES) == before
    assert (run / "manifest.json").read_text(encoding="utf-8") == text
