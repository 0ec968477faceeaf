"""A "should be a list" error's example fits the field (the items the value named, quoted where they
are text, else the field's default) and, for a --set, is the --set to type: each runs."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line


def _suggested_set(line: str) -> list[str]:
    """The ``--set '...'`` an error line suggests, as a shell splits it."""
    found = re.search(r"e\.g\. (--set '[^']*')", line)
    assert found is not None, line
    return shlex.split(found.group(1))


@pytest.mark.parametrize(("given", "example"), [
    ("study.corners=[tr]", 'study.corners=["tr"]'),
    ("study.corners=tr,bl", 'study.corners=["tr", "bl"]'),
    ("study.conditions=disambiguation,control", 'study.conditions=["disambiguation", "control"]'),
])
def test_a_list_of_text_is_suggested_quoted_as_a_set_that_works(tmp_path: Path, given: str,
                                                                 example: str) -> None:
    result = nudge("simulate", "smoke", "--set", given, "--out", tmp_path / "refused")
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "[0.5, 1.0]" not in line
    assert _suggested_set(line) == ["--set", example], line
    assert not (tmp_path / "refused").exists()
    suggested = nudge("simulate", "smoke", "--participants", "1", *_suggested_set(line),
                      "--out", tmp_path / "run")
    assert suggested.exit_code == 0, suggested.output


@pytest.mark.parametrize(("given", "example"), [
    ("population.rest_s=abc", "population.rest_s=[0.3, 1.5]"),  # nothing usable: the field's default
    ("population.rest_s=0.5,1", "population.rest_s=[0.5, 1]"),
    ("population.rest_s=1", "population.rest_s=[0.3, 1.5]"),  # one number for a pair: the default
])
def test_a_list_of_numbers_is_suggested_as_numbers(given: str, example: str) -> None:
    line = one_error_line(nudge("simulate", "smoke", "--set", given, "--out", "never-made").output)
    assert _suggested_set(line) == ["--set", example], line


def test_a_file_is_given_the_list_itself(tmp_path: Path) -> None:
    experiment = tmp_path / "exp.toml"
    experiment.write_text('[experiment]\nname = "x"\n\n[study]\ncorners = "tr"\n')
    line = one_error_line(nudge("simulate", str(experiment), "--out", tmp_path / "out").output)
    assert 'study.corners: should be a list, e.g. ["tr"] (got "tr")' in line, line


@pytest.mark.parametrize("written", ["[{}]", "{}"])
def test_a_physiology_log_given_as_text_is_suggested_as_a_list_that_runs(tmp_path: Path, monkeypatch,
                                                                         written: str) -> None:
    monkeypatch.chdir(tmp_path)
    assert nudge("simulate", "smoke", "--participants", "1", "--out", "results/pilot").exit_code == 0
    folder = "results/pilot/calibration/participant-0000"
    result = nudge("simulate", "smoke", "--participants", "1", "--set",
                   f"population.physiology_logs={written.format(folder)}", "--out", "refused")
    line = one_error_line(result.output)
    assert "should be a list of folders of calibration logs" in line
    assert _suggested_set(line) == ["--set", f'population.physiology_logs=["{folder}"]'], line
    suggested = nudge("simulate", "smoke", "--participants", "1", *_suggested_set(line), "--out", "run")
    assert suggested.exit_code == 0, suggested.output


def test_physiology_logs_separated_by_commas_are_suggested_one_item_each() -> None:
    line = one_error_line(nudge("simulate", "smoke", "--set", "population.physiology_logs=a,b",
                                "--out", "never-made").output)
    assert _suggested_set(line) == ["--set", 'population.physiology_logs=["a", "b"]'], line
