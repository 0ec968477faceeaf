"""Mistakes in an experiment's own policies are refused when the experiment is loaded, each with one
line naming the file (or ``--set``), the field and the fix: a condition with an empty name, a
misspelt key or entry inside ``[policies.NAME]`` (with its "did you mean"), and the internal
``policy_search_path`` (docs/policies.md)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

from nudgecli.config import ExperimentConfig, load_experiment
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


def test_a_misspelt_key_inside_a_policy_section_gets_its_did_you_mean(experiment: Path) -> None:
    message = refusal(experiment, "policies.threshold.param.threshold=0.7")
    assert message == ("--set policies.threshold.param.threshold=0.7: unknown key "
                       "'policies.threshold.param' (did you mean 'params'?)")
    far = refusal(experiment, "policies.threshold.zzz=1")  # nothing close: the section's own keys
    assert far.endswith("unknown key 'policies.threshold.zzz'; known keys: factory, params")


def test_a_misspelt_policy_name_gets_its_did_you_mean(experiment: Path) -> None:
    message = refusal(experiment, "policies.thresold.params.threshold=0.7")
    assert message == ("--set policies.thresold.params.threshold=0.7: policies.thresold.factory: Field "
                       "required; 'thresold' is no entry of policies yet (did you mean 'threshold'?)")
    # the same in a file; a name like none of the others gets no suggestion
    experiment.write_text(experiment.read_text() + "\n[policies.thresold]\nparams = { weight = 0.1 }\n")
    assert refusal(experiment).endswith("(did you mean 'threshold'?)")
    experiment.write_text(experiment.read_text().replace("policies.thresold", "policies.other"))
    assert refusal(experiment).endswith("policies.other.factory: Field required")


def test_the_internal_search_path_is_refused_in_files_and_set(experiment: Path) -> None:
    experiment.write_text('policy_search_path = "/x"\n' + experiment.read_text())
    assert "unknown key 'policy_search_path'" in refusal(experiment)
    experiment.write_text(experiment.read_text().split("\n", 1)[1])
    assert "unknown key 'policy_search_path'" in refusal(experiment, "policy_search_path.x=1")
    # nor is it offered among the known keys
    assert "policy_search_path" not in refusal(experiment, "zzz.x=2")
    # the loader still records the file's folder itself
    assert load_experiment(str(experiment)).policy_search_path == str(experiment.parent.resolve())
    assert "policy_search_path" not in ExperimentConfig().to_toml()
