"""A refused ``nudge replicate ... --resume`` or ``nudge power ... --resume`` names the full command
that resumes the batch (from the experiment, plan and people file its folder keeps), as a sweep's
refusals do: another setting or ``--target``, another batch kind, other people, a changed policy
module. It once said only
``resume it with the same settings`` (or ``nudge power ... --resume``). The command named is one that
the folder accepts."""

from __future__ import annotations

import shlex
import textwrap
from pathlib import Path
from typing import Any

import pytest
from cli_helpers import nudge, one_error_line
from people_helpers import PEOPLE_BYTES
from policy_helpers import QUIET_POLICY, policy_experiment

from nudgecli.config_files import resolve_preset
from nudgecli.runs import batch as batch_module

REPLICATE = ("replicate", "smoke", "-R", "2", "--participants", "2", "--seed", "5")
POWER = ("power", "smoke", "--participants", "2,3", "-R", "1", "--target", "0.2")


class StopBatchError(Exception):
    """Stops a batch once its executor is asked for: its folder and batch.json are written, nothing
    is simulated."""


@pytest.fixture
def no_executor(monkeypatch: pytest.MonkeyPatch) -> None:
    def stop(workers: int, client: Any) -> Any:
        raise StopBatchError

    monkeypatch.setattr(batch_module, "make_executor", stop)


def started(folder: Path, *args: str) -> Path:
    made = nudge(*args, "--out", folder)
    assert isinstance(made.exception, StopBatchError), made.output
    return folder


def named_command(line: str) -> list[str]:
    """The command between backticks in a refusal, as words (without ``nudge``)."""
    words = shlex.split(line.split("`")[-2])
    assert words[0] == "nudge" and words[-1] == "--resume", words
    return words[1:]


def accepted(words: list[str]) -> None:
    """The named command gets past every check of the folder (to its executor)."""
    resumed = nudge(*words)
    assert isinstance(resumed.exception, StopBatchError), resumed.output


@pytest.mark.usefixtures("no_executor")
def test_replicate_with_other_settings_names_its_command(tmp_path: Path) -> None:
    batch = started(tmp_path / "B", *REPLICATE)
    line = one_error_line(nudge("replicate", "smoke", "-R", "3", "--participants", "2", "--seed", "5",
                                "--out", batch, "--resume").output)
    assert "holds a different batch" in line and "--force" in line, line
    words = named_command(line)
    assert words == ["replicate", str(batch / "experiment.toml"), "--out", str(batch), "--replications", "2",
                     "--seed", "5", "--participants", "2", "--plan", str(batch / "plan.toml"), "--resume"]
    accepted(words)


@pytest.mark.usefixtures("no_executor")
def test_power_with_another_target_names_its_command(tmp_path: Path) -> None:
    batch = started(tmp_path / "P", *POWER)
    line = one_error_line(nudge(*POWER[:-1], "0.5", "--out", batch, "--resume").output)
    assert "target" in line, line
    words = named_command(line)
    assert words[:2] == ["power", str(batch / "experiment.toml")], words
    assert "--target 0.2" in shlex.join(words) and "--participants 2,3" in shlex.join(words), words
    accepted(words)


@pytest.mark.usefixtures("no_executor")
def test_a_resume_of_another_kind_names_the_batch_command(tmp_path: Path) -> None:
    batch = started(tmp_path / "P", *POWER)
    line = one_error_line(nudge(*REPLICATE, "--out", batch, "--resume").output)
    assert "holds a power batch, not a replicate batch" in line and "..." not in line, line
    accepted(named_command(line))


@pytest.mark.usefixtures("no_executor")
def test_other_people_name_the_command_with_the_kept_copy(tmp_path: Path) -> None:
    people = tmp_path / "p.csv"
    people.write_bytes(PEOPLE_BYTES)
    batch = started(tmp_path / "P", *POWER, "--people", str(people))
    line = one_error_line(nudge(*POWER, "--out", batch, "--resume").output)  # without --people
    assert "was simulated with --people p.csv" in line, line
    words = named_command(line)
    assert "--people " + str(batch / "people" / "p.csv") in shlex.join(words), words
    accepted(words)


@pytest.mark.usefixtures("no_executor")
def test_a_changed_policy_module_names_the_command(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    library = tmp_path / "lib"
    library.mkdir()
    module = library / "syspol_fixa_resume.py"
    module.write_text(textwrap.dedent(QUIET_POLICY.replace("class Quiet:", "class Mine:")))
    monkeypatch.syspath_prepend(str(library))
    experiment = policy_experiment(tmp_path / "exp", {"mine": "syspol_fixa_resume:Mine"}, participants=2)
    plan = tmp_path / "plan.toml"  # the shipped custom-policy plan, of these conditions
    plan.write_text(resolve_preset("custom-policy", "analysis").read_text(encoding="utf-8").replace(
        'conditions = ["disambiguation", "blending", "threshold"]', 'conditions = ["control", "mine"]'))
    batch = started(tmp_path / "B", "replicate", str(experiment), "-R", "1", "--plan", str(plan))
    module.write_text(module.read_text() + "\n# edited\n")
    line = one_error_line(nudge("replicate", experiment, "-R", "1", "--plan", plan, "--out", batch,
                                "--resume").output)
    assert str(module) in line and "mix two policies" in line, line
    words = named_command(line)
    assert words[:2] == ["replicate", str(batch / "experiment.toml")], words
