"""The ``[model]`` section cannot make an observation impossible under every goal.

Eq. 1 of the paper takes epsilon in (0, 1): at epsilon = 0 the assumed human picks only the goal's
optimal action, and with the default tables made noiseless (``default_table_noise = 0``) a label
no goal's optimal action maps to has probability 0 under every goal, so the Bayesian update has
nothing to normalise (a ``ValueError`` traceback mid-run, before the fix). ``epsilon = 0`` is
refused in the configuration; every other probability-like field of the section keeps each label
possible as long as epsilon is positive, which the brute-force check below shows.

The command-line tests were seen failing before the fix (a traceback and an interrupted run).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import copy_run, files_of, one_error_line
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.config import experiment_from_toml, load_experiment
from nudgecli.errors import ConfigError
from nudgecli.model.human_actions import action_likelihood
from nudgecli.model.interface import (
    N_ACTIONS,
    N_LABELS,
    default_distortion_table,
    default_mapping_table,
    observation_model,
)
from nudgecli.model.world import N_MODES
from nudgecli.runs.study import run_study

NOISELESS = ["--set", "model.tables=\"default\"", "--set", "model.default_table_noise=0"]


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("observation-support") / "run"
    run_study(load_experiment("smoke"), out, participants=1)
    return out


@pytest.mark.parametrize("value", ["0", "0.0", "-0.0"])
def test_epsilon_zero_is_refused_naming_the_field_the_range_and_why(value: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_experiment("smoke", [f"model.epsilon={value}"])
    message = str(info.value)
    assert "model.epsilon" in message and "(0, 1)" in message and "Eq. 1" in message
    assert "zero probability" in message


def test_epsilon_zero_in_a_file_is_refused_naming_the_file() -> None:
    with pytest.raises(ConfigError, match=r"exp\.toml: model\.epsilon: .*\(0, 1\)"):
        experiment_from_toml("[model]\nepsilon = 0.0\n", source="exp.toml")


@pytest.mark.parametrize(("value", "said"), [("1", r"\(0, 1\)"), ("-0.1", r"\(0, 1\)"),
                                           ("nan", "finite number"), ("inf", "finite number")])
def test_epsilon_outside_the_open_interval_is_refused(value: str, said: str) -> None:
    with pytest.raises(ConfigError, match=rf"model\.epsilon: .*{said}"):
        load_experiment("smoke", [f"model.epsilon={value}"])


@pytest.mark.parametrize("value", [1e-9, 0.1, 0.999999])
def test_epsilon_inside_the_open_interval_is_kept(value: float) -> None:
    assert load_experiment("smoke", [f"model.epsilon={value!r}"]).model.epsilon == value


def test_simulate_with_epsilon_zero_is_one_error_line_and_writes_no_folder(tmp_path: Path) -> None:
    out = tmp_path / "Z"
    args = ["simulate", "smoke", "--seed", "1", *NOISELESS,
            "--set", "model.epsilon=0", "--out", str(out)]
    result = CliRunner().invoke(main, args)
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "model.epsilon" in line
    assert not out.exists()


@pytest.mark.parametrize("flag", ["--resume", "--force"])
def test_resume_or_force_with_epsilon_zero_leaves_the_run_untouched(tmp_path: Path, smoke_run: Path,
                                                                   flag: str) -> None:
    run = copy_run(smoke_run, tmp_path / "run")
    before = files_of(run)
    result = CliRunner().invoke(main, ["simulate", "smoke", "--participants", "1", "--set", "model.epsilon=0",
                                       "--out", str(run), flag])
    assert result.exit_code == 1 and "model.epsilon" in one_error_line(result.output)
    assert files_of(run) == before


def test_resuming_a_run_recorded_with_epsilon_zero_names_its_config_file(tmp_path: Path,
                                                                        smoke_run: Path) -> None:
    # a run an earlier version began with epsilon = 0 (it stopped at the first impossible label):
    # resuming it with its own config.toml, as the resume hint says, is one Error line
    run = copy_run(smoke_run, tmp_path / "run")
    config = run / "config.toml"
    head, model, tail = config.read_text().partition("[model]\n")
    config.write_text(head + model + tail.replace("epsilon = 0.1\n", "epsilon = 0.0\n", 1))
    manifest = json.loads((run / "manifest.json").read_text())
    manifest["config"]["model"]["epsilon"] = 0.0
    (run / "manifest.json").write_text(json.dumps(manifest, indent=2))
    before = files_of(run)
    result = CliRunner().invoke(main, ["simulate", str(config), "--out", str(run), "--resume"])
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "config.toml" in line and "model.epsilon" in line
    assert files_of(run) == before


def observation_likelihood_brute_force(greedy: np.ndarray, mode: int, epsilon: float,
                                       noise: float) -> np.ndarray:
    """``(G, F)`` p(phi_m | g, s) by explicit sums over actions and intended labels (Eqs. 1, 12)."""
    mapping, distortion = default_mapping_table(noise), default_distortion_table(noise)
    likelihood = np.zeros((len(greedy), N_LABELS))
    for g, best in enumerate(greedy):
        for a, phi_i, phi_m in itertools.product(range(N_ACTIONS), range(N_LABELS), range(N_LABELS)):
            p_action = (1 - epsilon) * (a == best) + epsilon / N_ACTIONS
            likelihood[g, phi_m] += p_action * mapping[mode, a, phi_i] * distortion[phi_i, phi_m]
    return likelihood


def test_the_brute_force_matches_the_models_tables() -> None:
    greedy, epsilon, noise = np.array([0, 2, 3]), 0.1, 0.2
    model = np.einsum("gsa,maf->gmsf", action_likelihood(greedy[:, None], epsilon),
                      observation_model(default_mapping_table(noise), default_distortion_table(noise)))
    for mode in range(N_MODES):
        np.testing.assert_allclose(model[:, mode, 0],
                                   observation_likelihood_brute_force(greedy, mode, epsilon, noise))


def test_noiseless_tables_with_epsilon_zero_leave_a_label_impossible_under_every_goal() -> None:
    # the hole the refusal closes: every goal greedy on move_p, so Hard Sip (to_mode_l) is impossible
    likelihood = observation_likelihood_brute_force(np.array([0, 0]), mode=0, epsilon=0.0, noise=0.0)
    assert (likelihood.max(axis=0) == 0).any()


@settings(max_examples=60, deadline=None)
@given(greedy=st.lists(st.integers(0, N_ACTIONS - 1), min_size=1, max_size=6),
       mode=st.integers(0, N_MODES - 1),
       epsilon=st.floats(1e-6, 0.999999), noise=st.sampled_from([0.0, 1.0]) | st.floats(0.0, 1.0))
def test_any_positive_epsilon_keeps_every_label_possible_under_every_goal(
        greedy: list[int], mode: int, epsilon: float, noise: float) -> None:
    # default_table_noise may be 0 or 1: with epsilon > 0 every action, and so every label it maps
    # to, keeps probability at least epsilon / A (the true mapping is a permutation of the labels)
    likelihood = observation_likelihood_brute_force(np.array(greedy), mode, epsilon, noise)
    assert (likelihood > 0).all()
    np.testing.assert_allclose(likelihood.sum(axis=1), 1.0)
