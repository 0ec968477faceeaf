"""``nudge plot-population`` and ``nudge validate`` make a new ``--out`` folder only when they write
into it: checking that it can be written makes none (:func:`nudgecli.store.check_writable`), so a
command refused for a bad input leaves no empty folder behind, as every other command does."""

from __future__ import annotations

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli
from nudgecli.errors import NudgeError
from nudgecli.store import check_writable

#: A folder name longer than any file system allows: its parent is made, then it fails.
TOO_LONG = "x" * 300


def test_the_write_check_makes_no_folder_and_keeps_an_existing_one(tmp_path):
    check_writable(tmp_path / "new" / "deeper")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "mine").mkdir()
    check_writable(tmp_path / "mine")
    assert [p.name for p in tmp_path.iterdir()] == ["mine"] and not any((tmp_path / "mine").iterdir())


def test_plot_population_refused_after_the_out_check_leaves_no_folder(tmp_path):
    out = tmp_path / "population"
    missing = tmp_path / "no-such-recording"
    result = nudge("plot-population", "smoke", "--participants", "1", "--out", out,
                   "--set", f'population.physiology_logs=["{missing}"]')
    assert result.exit_code == 1
    assert str(missing) in one_error_line(result.output)
    assert not out.exists()
    with pytest.raises(NudgeError, match="no p\\(phi_m"):
        nudgecli.plot_population("smoke", participants=1, out=out,
                                 overrides={"population.physiology_logs": [str(missing)]})
    assert not out.exists()


@pytest.mark.parametrize("command", [["validate", "--simulations", "1", "--mc-queries", "0"],
                                     ["plot-population", "smoke", "--participants", "1"]])
def test_an_out_that_cannot_be_made_leaves_no_folder_above_it(tmp_path, command):
    new = tmp_path / "new"
    result = nudge(*command, "--out", new / TOO_LONG)
    assert result.exit_code == 1
    assert one_error_line(result.output).startswith(f"Error: cannot write {new / TOO_LONG}")
    assert not new.exists()


def test_validate_writes_into_a_new_out_it_makes(tmp_path):
    out = tmp_path / "a" / "validation"
    result = nudge("validate", "--simulations", "1", "--mc-queries", "0", "--out", out)
    assert result.exit_code == 0, result.output
    assert {"validation.json", "validation.csv"} <= {p.name for p in out.iterdir()}
    assert not (out / ".nudge-write-check").exists()
