"""Mistakes in an experiment's own policies are refused when the experiment is loaded, each with one
line naming the file (or ``--set``), the field and the fix: a condition with an empty name
(docs/policies.md)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def experiment(tmp_path: Path) -> Path:
    """A copy of the shipped custom-policy experiment, with its policy module beside it."""
    shutil.copytree(ROOT / "experiments" / "policies", tmp_path / "policies",
                    ignore=shutil.ignore_patterns("__pycache__"))
    return Path(shutil.copy(ROOT / "experiments" / "custom-policy.toml", tmp_path / "mine.toml"))


def refusal(path: Path, *overrides: str) -> str:
    with pytest.raises(ConfigError) as refused:
        load_experiment(str(path), overrides)
    return str(refused.value)


@pytest.mark.parametrize("name", ["", " ", " threshold2"])
def test_a_policy_without_a_plain_name_is_refused_when_the_experiment_is_loaded(experiment: Path,
                                                                                 name: str) -> None:
    text = experiment.read_text().replace('"threshold"]', f'"threshold", "{name}"]')
    experiment.write_text(text + f'\n[policies."{name}"]\nfactory = "policies.threshold:ThresholdAssist"\n')
    message = refusal(experiment)
    assert message.startswith(f"{experiment}: policies: [policies.\"{name}\"]")
    assert "study.conditions" in message


def test_the_empty_name_is_one_error_line_and_nothing_is_written(experiment: Path, tmp_path: Path) -> None:
    text = experiment.read_text().replace('"threshold"]', '"threshold", ""]')
    experiment.write_text(text + '\n[policies.""]\nfactory = "policies.threshold:ThresholdAssist"\n')
    refused = nudge("simulate", experiment, "--participants", "1", "--out", tmp_path / "run")
    assert refused.exit_code == 1
    assert "[policies.\"\"]" in one_error_line(refused.stderr)
    assert not (tmp_path / "run").exists()
