"""The built-in policies' settings as their sources define them: ``[blending]``'s gate (on by
default, as ADA's code gates; a ``gap`` with no gate to use it refused), the sections a ``--set``
supplies, the coupling of additive blending to ``[hindsight]``, the paper's rho_i in [0, 1] and
the Gopinath projection's 0.1 s updates at any step rate (docs/baselines.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from cli_helpers import nudge, stderr_error_line

from nudgecli.config import BlendingPolicySection, experiment_from_toml, load_experiment
from nudgecli.errors import ConfigError
from nudgecli.model import hindsight
from nudgecli.model.interface import NO_INPUT, SOFT_PUFF, SOFT_SIP
from nudgecli.model.mode_criteria import gopinath_disamb_metric
from nudgecli.model.world import N_CELLS_X, N_CELLS_Y, N_HEADINGS, N_MODES, cell_centre, state_index
from nudgecli.sim.protocol import ProtocolSettings, TrialSession
from nudgecli.steplog import NO_GOAL
from tests.test_policies import POLICY_TOML, _layout_model, _spec

BLENDING = '[blending]\ngate = "gap"\ngap = 0.4\n'


def _blending_step(toml: str, belief: np.ndarray, pressure: float = 0.0) -> dict:
    """The row of one step of a ``blending`` trial from layout 5's start with ``belief``."""
    settings_ = ProtocolSettings.from_config(experiment_from_toml(toml))
    layout, model = _layout_model(5)
    session = TrialSession(_spec("blending", layout), settings_, model, 10, np.random.default_rng(2))
    session._set_belief(belief)
    session.human_step(SOFT_PUFF if pressure else NO_INPUT, pressure)
    return {c: v[-1] for c, v in session.columns.items()}


# --- 1. [blending]'s gate ---------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["convex", "additive"])
def test_a_blending_section_without_gate_is_gated_by_adas_gap(kind: str) -> None:
    toml = POLICY_TOML.replace(BLENDING, f'[blending]\nkind = "{kind}"\n')
    gap = ProtocolSettings.from_config(experiment_from_toml(toml)).blending_gap
    assert gap == hindsight.BLEND_PROB_DIFF_REQUIRED
    # p1 - p2 = 0.3 <= 0.4: no assistance, although the paper's ramp alone (p1 > 1.1 / 3) assists
    row = _blending_step(toml, np.array([0.6, 0.3, 0.1]), -0.2)
    assert row["alpha"] == 0.0
    given = POLICY_TOML.replace(BLENDING, f'[blending]\nkind = "{kind}"\ngap = 0.2\n')  # the gate's own gap
    assert ProtocolSettings.from_config(experiment_from_toml(given)).blending_gap == 0.2


@pytest.mark.parametrize("gap", ["0.4", "0.2"])
def test_a_gap_without_the_gate_that_uses_it_is_one_error_line(tmp_path: Path, gap: str) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(POLICY_TOML.replace(BLENDING, f'[blending]\ngate = "none"\ngap = {gap}\n'))
    with pytest.raises(ConfigError) as refused:
        load_experiment(str(path))
    assert str(refused.value).startswith(f"{path}: blending.gap: {gap} is not used with gate = \"none\"")
    refused_cli = nudge("simulate", path, "--participants", "1", "--out", tmp_path / "run")
    assert "remove gap" in stderr_error_line(refused_cli)
    assert not (tmp_path / "run").exists()
    # by --set: a gap given with the gate turned off is refused; turning a file's gate off takes
    # its gap with it (a preset's, or a sweep's point), as the file's own key would go
    named = r"^--set blending\.gate=none and blending\.gap=0\.3: blending\.gap: 0\.3 is not used"
    with pytest.raises(ConfigError, match=named):
        load_experiment("baselines", ["blending.gate=none", "blending.gap=0.3"])
    ungated = load_experiment("baselines", ["blending.gate=none"])
    assert ungated.blending is not None and ungated.blending.gate == "none"
    assert ProtocolSettings.from_config(ungated).blending_gap is None


def test_no_gate_runs_and_round_trips_through_the_run_folders_toml() -> None:
    config = experiment_from_toml(POLICY_TOML.replace(BLENDING, '[blending]\ngate = "none"\n'))
    assert ProtocolSettings.from_config(config).blending_gap is None
    assert experiment_from_toml(config.to_toml()) == config
    gated = experiment_from_toml(POLICY_TOML.replace(BLENDING, "[blending]\n"))
    assert experiment_from_toml(gated.to_toml()) == gated and gated.blending.gap == 0.4  # type: ignore[union-attr]


def test_additive_blending_without_a_gate_assists_no_goal_on_a_tie() -> None:
    # a uniform belief (every trial's first step) favours no goal by its index
    assert hindsight.ada_blend_goal(np.full(3, 1 / 3), None) == NO_GOAL
    assert hindsight.ada_blend_goal(np.array([0.4, 0.4, 0.2]), None) == NO_GOAL
    assert hindsight.ada_blend_goal(np.array([0.2, 0.5, 0.3]), None) == 1
    toml = POLICY_TOML.replace(BLENDING, '[blending]\nkind = "additive"\ngate = "none"\n')
    row = _blending_step(toml, np.full(3, 1 / 3))
    assert row["alpha"] == 0.0 and row["inferred_goal"] == NO_GOAL
    row = _blending_step(toml, np.array([0.2, 0.5, 0.3]))
    assert row["alpha"] == 1.0 and row["inferred_goal"] == 1


# --- 2. a condition's section that --set supplies ---------------------------------------------------

NO_SECTION = """[experiment]
name = "t"
seed = 1
[study]
participants = 2
conditions = ["disambiguation", "{condition}"]
goal_counts = [3]
corners = ["tr"]
start_modes = ["x"]
blocks_per_condition = 1
time_limit_s = 5.0
"""


@pytest.mark.parametrize(("condition", "override"), [
    ("blending", "blending.gate=gap"), ("mode-switch", "mode-switch.criterion=paper-mi"),
    ("mode-switch", "mode_switch.trigger=request"), ("hindsight", "hindsight.assist=always")])
def test_the_missing_sections_suggested_set_supplies_it(tmp_path: Path, condition: str,
                                                         override: str) -> None:
    path = tmp_path / "nosec.toml"
    path.write_text(NO_SECTION.format(condition=condition))
    with pytest.raises(ConfigError) as refused:
        load_experiment(str(path))
    suggested = str(refused.value).rpartition("--set ")[2].rstrip(")")
    assert str(refused.value).startswith(f"{path}: study.conditions lists {condition!r}")
    for given in (suggested, override):  # the one the error suggests, and another key of the section
        config = load_experiment(str(path), [given])
        assert getattr(config, condition.replace("-", "_")) is not None


def test_a_file_with_another_fault_is_still_named_as_itself(tmp_path: Path) -> None:
    path = tmp_path / "nosec.toml"
    path.write_text(NO_SECTION.format(condition="blending").replace("seed = 1", "seed = -1"))
    with pytest.raises(ConfigError, match=r"nosec\.toml: experiment\.seed"):
        load_experiment(str(path), ["blending.gate=gap"])
    # a --set of another condition's section supplies nothing
    path.write_text(NO_SECTION.format(condition="blending"))
    with pytest.raises(ConfigError, match=r"nosec\.toml: study\.conditions lists 'blending'"):
        load_experiment(str(path), ["hindsight.assist=always"])


def test_simulate_takes_the_suggested_set(tmp_path: Path) -> None:
    path = tmp_path / "nosec.toml"
    path.write_text(NO_SECTION.format(condition="blending"))
    done = nudge("simulate", path, "--out", tmp_path / "ns", "--set", "blending.gate=gap")
    assert done.exit_code == 0, done.output
    assert (tmp_path / "ns" / "config.toml").read_text().count("[blending]") == 1


# --- 3. additive blending shares [hindsight]'s assistance ------------------------------------------

def test_additive_blending_uses_hindsights_strength_and_zone_and_says_so() -> None:
    toml = POLICY_TOML.replace(BLENDING, '[blending]\nkind = "additive"\n')
    belief = np.array([0.1, 0.8, 0.1])
    source = _blending_step(toml, belief)
    doubled = _blending_step(toml.replace("[hindsight]", "[hindsight]\nstrength = 0.612"), belief)
    # ADA's blend adds the one-goal assistance its hindsight policy sums: one strength for both
    assert 1.9 < doubled["u_a_x"] / source["u_a_x"] <= 2.0
    zoned = _blending_step(toml.replace("[hindsight]", "[hindsight]\nzone = 40.0"), belief)
    assert zoned["u_a_x"] != source["u_a_x"]
    assert "[hindsight]" in (BlendingPolicySection.__doc__ or "")
    docs = (Path(__file__).resolve().parents[1] / "docs" / "baselines.md").read_text()
    assert "`[hindsight] strength` and `zone` set the\nadditive blend's assistance" in docs


# --- 5. the Gopinath projection: one update per 0.1 s at any rate ----------------------------------

def _projected(belief: np.ndarray, p: np.ndarray, label: int, updates: int) -> np.ndarray:
    """``belief`` after ``updates`` Bayes updates with ``label`` (``p``: (G, F)), in a loop."""
    b = belief.copy()
    for _ in range(updates):
        b = b * p[:, label]
        b = b / b.sum()
    return b


def _gopinath_choice(belief: np.ndarray, likelihood: np.ndarray, mode: int, per_second: int) -> int:
    """The MATLAB's mode (current mode on ties) with ``per_second`` updates a projected second."""
    scores = np.array([sum(float(gopinath_disamb_metric(_projected(belief, p, label, per_second),
                                                         _projected(belief, p, label, 2 * per_second)))
                           for label in (SOFT_PUFF, SOFT_SIP)) for p in likelihood])
    best = scores.max()  # a tie: within 1e-9 of the best, relative (nudgecli.model.ties)
    tied = [m for m in range(len(scores)) if scores[m] >= best - 1e-9 * max(1.0, abs(best))]
    return mode if mode in tied else tied[0]


def test_gopinath2017_projects_one_update_per_tenth_of_a_second_at_20_hz() -> None:
    toml = POLICY_TOML.replace('criterion = "paper-mi"', 'criterion = "gopinath2017"')
    config = experiment_from_toml(toml.replace("[blending]", "rate_hz = 20.0\n[blending]"))
    settings_ = ProtocolSettings.from_config(config)
    assert settings_.dt == 0.05
    layout, model = _layout_model(3)
    rng = np.random.default_rng(0)
    told_apart = 0
    for _ in range(200):
        i, j = int(rng.integers(N_CELLS_X)), int(rng.integers(N_CELLS_Y))
        h, m = int(rng.integers(N_HEADINGS)), int(rng.integers(N_MODES))
        belief = rng.dirichlet(np.ones(3))
        states = [int(state_index(i, j, h, mode)) for mode in range(N_MODES)]
        likelihood = model.likelihood[:, states, :].transpose(1, 0, 2)
        expected = _gopinath_choice(belief, likelihood, m, 10)  # t_stamps = 0:0.1:1, whatever the rate
        session = TrialSession(_spec("mode-switch", layout), settings_, model, 10, np.random.default_rng(1))
        session.x, session.y = (float(v) for v in cell_centre(i, j))
        session.theta, session.mode = h * np.pi / 4, m
        session._set_belief(belief)
        session._start_autonomy_turn()
        assert session.mode == expected, (belief, m)
        told_apart += _gopinath_choice(belief, likelihood, m, 20) != expected  # one update a 20 Hz step
    assert told_apart >= 1  # the pairs include some where an update per step picks another mode


# --- 4. the baselines preset's trial count as the docs quote it -------------------------------------

def test_the_docs_quote_the_baselines_trial_count_of_four_participants() -> None:
    config = load_experiment("baselines")
    trials = 4 * len(config.study.conditions) * config.study.trials_per_condition
    docs = (Path(__file__).resolve().parents[1] / "docs" / "baselines.md").read_text()
    assert trials == 1344
    assert "`nudge simulate baselines --participants 4 --workers 2` runs 1344 trials" in docs


# --- 7. the baselines preset's header comment ------------------------------------------------------

def test_the_baselines_presets_header_comment_matches_its_settings() -> None:
    import re
    root = Path(__file__).resolve().parents[1]
    text = (root / "experiments" / "baselines.toml").read_text()
    header = text.split("\n[", 1)[0]
    config = load_experiment("baselines")
    words = {5: "five", 6: "six", 7: "seven", 8: "eight"}
    found = re.search(r"under (\w+) assistance conditions \(([\w/.]+)\)", header)
    assert found and found.group(1) == words[len(config.study.conditions)]
    assert (root / found.group(2)).is_file() and "class Blending" in (root / found.group(2)).read_text()
    for condition in config.study.conditions:
        assert re.search(rf"^#   ([\w-]+, )*{re.escape(condition)}[ ,]", header, re.M), condition
    assert config.mode_switch is not None and f"({config.mode_switch.criterion} below)" in header


# --- 8. the paper's rho_i in [0, 1] ----------------------------------------------------------------

@pytest.mark.parametrize(("overrides", "goals"), [
    (("assistance.rho1_factor=3.5", "assistance.rho2_factor=4.5"), 3),
    (("assistance.rho2_factor=3.5",), 3),  # rho_1 = 0.37 is fine, rho_2 = 1.17 is not
    (("study.goal_counts=[2, 4]", "assistance.rho2_factor=2.5"), 2)])  # the fewest goals count
def test_a_rho_factor_above_the_goal_count_is_one_error_line(tmp_path: Path, overrides: tuple[str, ...],
                                                             goals: int) -> None:
    sets = [arg for text in overrides for arg in ("--set", text)]
    refused = nudge("simulate", "paper", "--participants", "2", *sets, "--out", tmp_path / "run")
    line = stderr_error_line(refused)
    assert "assistance.rho1_factor" in line and "rho2_factor" in line and "[0, 1]" in line
    assert f"keep both factors at most {goals}" in line and not (tmp_path / "run").exists()


def test_rho_factors_up_to_the_fewest_goals_are_taken() -> None:
    config = load_experiment("paper", ["assistance.rho1_factor=2.0", "assistance.rho2_factor=3.0"])
    assert config.assistance.rho2_factor / min(config.study.goal_counts) == 1.0
    # the CIAA world has no goal inference, so no ramp to bound: it refuses the key it does not read
    # (nudgecli.config_world), where it was taken and ignored
    with pytest.raises(ConfigError, match=r"rho2_factor = 9\.0: the ciaa world .* does not read it"):
        load_experiment("ciaa-teleop", ["assistance.rho2_factor=9.0"])


# --- 9. the help texts name every preset, by pointing to nudge presets ----------------------------

@pytest.mark.parametrize(("command", "kind"), [("simulate", "experiments"), ("analyze", "analysis")])
def test_the_help_lists_no_preset_subset_and_points_to_nudge_presets(command: str, kind: str) -> None:
    from nudgecli.config_files import list_presets
    shown = " ".join(nudge(command, "--help").output.split())
    assert "a preset (`nudge presets` lists them)" in shown
    listed = nudge("presets").output
    for name in list_presets(kind):  # the one list: every preset of the kind is there
        assert f"  {name} " in listed


# --- 6. docs/baselines.md says where its rates come from and which pairs each Holm family holds ----

def test_the_baselines_docs_name_the_rates_source_and_each_metrics_holm_family() -> None:
    import pandas as pd
    root = Path(__file__).resolve().parents[1]
    docs = " ".join((root / "docs" / "baselines.md").read_text().split())
    stats = pd.read_csv(root / "results" / "baselines" / "stats.csv")
    pairs = stats.dropna(subset=["conover_p"]).groupby("metric").size()
    assert "Holm over all 21 pairs" not in docs
    assert f"the {pairs.max()} of the seven conditions" in docs
    engagement, effort = pairs["assistance_engagement"], pairs["human_effort"]
    assert f"{engagement} for engagement and {effort} for human effort" in docs
    assert pairs["human_turns"] == pairs["assistance_strength"] == pairs["human_effort"]
    # conditions.csv holds each study's median of the 0/1 success, not its rate: the docs say so
    conditions = pd.read_csv(root / "results" / "baselines" / "replicate" / "conditions.csv")
    assert set(conditions.loc[conditions["metric"] == "success", "value"]) <= {0.0, 1.0}
    assert "is 1.0 or 0.0, not a rate" in docs and '.groupby(["study", "condition"])[["success",' in docs
