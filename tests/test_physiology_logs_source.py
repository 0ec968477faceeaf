"""A ``population.physiology_logs`` folder that is not there is refused in one line that names where
the list was written (the experiment file, or the ``--set`` that gave it), the key and the folder as
written; it once named the key alone, not the file whose key named it."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line


@pytest.fixture
def experiment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``experiments/x.toml``: the smoke experiment whose physiology_logs names ``logs/p1``, a
    relative path read from the working directory (``tmp_path``), where it is not."""
    from nudgecli.config_files import resolve_preset

    monkeypatch.chdir(tmp_path)
    smoke = resolve_preset("smoke", "experiments").read_text(encoding="utf-8")
    assert "[population]" not in smoke
    (tmp_path / "experiments").mkdir()
    logs = '\n[population]\nphysiology_logs = ["logs/p1"]\n'
    (tmp_path / "experiments" / "x.toml").write_text(smoke + logs)
    return Path("experiments/x.toml")


@pytest.mark.parametrize("command", [("simulate",), ("replicate", "-R", "1", "--participants", "2")])
def test_the_file_that_named_the_folder_is_named(experiment: Path, command: tuple[str, ...]) -> None:
    line = one_error_line(nudge(command[0], experiment, *command[1:], "--out", "out").output)
    assert line.startswith("Error: experiments/x.toml: population.physiology_logs[0] names folder "
                           "'logs/p1', which does not exist"), line
    assert not Path("out").exists()


def test_a_set_value_names_the_set(tmp_path: Path) -> None:
    setting = f'population.physiology_logs=["{tmp_path / "nope"}"]'
    line = one_error_line(nudge("simulate", "smoke", "--set", setting, "--out", tmp_path / "out").output)
    assert line.startswith(f"Error: --set {setting}: population.physiology_logs[0] names folder "
                           f"'{tmp_path / 'nope'}', which does not exist"), line
