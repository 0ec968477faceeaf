"""A researcher's own policy in the harness: the shipped example runs from the command line, its
tables do not depend on the executor, and every way a policy can be wrong is one Error line."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from click.testing import CliRunner
from policy_helpers import policy_experiment

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import PolicyError
from nudgecli.runs.study import run_study
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn, Policy
from nudgecli.sim.policy_registry import (
    CheckedPolicy,
    PolicySpec,
    constant_metrics_of,
    load_factory,
    policy_specs,
)
from tests.test_sim_study import assert_same_run

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "experiments" / "custom-policy.toml"


def test_the_example_runs_from_the_command_line_and_its_policy_acts(tmp_path):
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["run", str(EXAMPLE), "--participants", "2", "--out", str(out)])
    assert result.exit_code == 0, result.output
    stats = json.loads((out / "stats.json").read_text())
    assert stats["conditions"] == ["disambiguation", "blending", "threshold"]
    # the run recorded what each policy makes constant, and the analysis leaves those out
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["constant_metrics"]["threshold"] == ["assistance_strength", "human_effort", "human_turns"]
    entries = {entry["metric"]: entry for entry in stats["metrics"]}
    assert entries["human_effort"]["not_applicable"] == ["blending", "threshold"]
    assert entries["human_turns"]["not_applicable"] == ["blending", "threshold"]
    assert not entries["completion_time"].get("not_applicable")
    import pandas as pd

    steps = pd.read_parquet(out / "steps")
    trials = pd.read_parquet(out / "trials")
    threshold = trials.loc[trials["condition"] == "threshold", ["participant", "trial"]]
    mine = steps.merge(threshold, on=["participant", "trial"])
    assert len(mine) > 1000
    # the threshold policy blends at its fixed weight and never otherwise
    assert set(np.unique(mine["alpha"])) == {0.0, 0.5}
    # it takes no turns: the person's turn is the whole trial
    assert (mine["turn"] == "human").all()


@pytest.mark.usefixtures("restored_environ")  # the cluster sets its workers' settings in os.environ
def test_a_custom_policys_tables_are_identical_with_one_and_two_workers_and_dask(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    config = load_experiment(str(EXAMPLE))
    run_study(config, tmp_path / "one", participants=2, workers=1)
    run_study(config, tmp_path / "two", participants=2, workers=2)
    # worker processes of their own: the policy's module is imported there from the experiment's folder
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster:  # ":0": every interface
        run_study(config, tmp_path / "dask", participants=2, scheduler=cluster.scheduler_address)
    assert_same_run(tmp_path / "one", tmp_path / "two")
    assert_same_run(tmp_path / "one", tmp_path / "dask")


def test_the_example_policy_has_the_interface_and_its_traits_set_the_constant_metrics():
    config = load_experiment(str(EXAMPLE))
    constant = constant_metrics_of(config)  # imports the module from the experiment's folder
    # no turns; alpha 0 or its weight: a constant strength, which the policy names
    assert constant["threshold"] == {"assistance_strength", "human_effort", "human_turns"}
    assert constant["disambiguation"] == frozenset()
    # the gap-gated blend's alpha is 0.8 whenever it acts: its strength is constant too
    assert constant["blending"] == {"assistance_strength", "human_effort", "human_turns"}
    (spec,) = policy_specs(config)
    policy = load_factory(spec)()
    assert isinstance(policy, Policy)


# --- bad policies: one Error line naming the condition and the policy, exit 1 ----------------------

GOOD = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

class Mine:
    infers = True
    takes_turns = False

    def __init__(self, weight=0.5):
        self.weight = weight

    def assist(self, view):
        return Assistance(view.u_h)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def _experiment(tmp_path: Path, module: str, factory: str = "mymodule:Mine", params: str = "{}") -> Path:
    return policy_experiment(tmp_path, {"mine": factory}, modules={"mymodule.py": module},
                             params={"mine": params})


def _simulate(tmp_path: Path, experiment: Path, *extra: str):
    import sys

    sys.modules.pop("mymodule", None)  # each test's module is its own
    out = tmp_path / "run"
    return out, CliRunner().invoke(main, ["simulate", str(experiment), "--out", str(out), *extra])


def _one_error_line(result, *words: str) -> None:
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("Error:")]
    assert len(errors) == 1, result.output
    assert "Traceback" not in result.output
    for word in words:
        assert word in errors[0], (word, errors[0])


def test_a_good_policy_of_ones_own_runs(tmp_path):
    _, result = _simulate(tmp_path, _experiment(tmp_path, GOOD, params="{ weight = 0.3 }"))
    assert result.exit_code == 0, result.output


def test_a_policy_may_answer_with_numpys_scalars(tmp_path):
    module = "import numpy as np\n" + GOOD.replace(
        "return Assistance(view.u_h)",
        "return Assistance(view.u_h, alpha=np.float32(0.0), goal=np.argmax(view.belief))")
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(("module", "factory", "params", "words"), [
    ("raise ImportError('no such thing')\n", "mymodule:Mine", "{}", ["cannot import module 'mymodule'"]),
    ("x = 1\n", "nomodule_here:Mine", "{}", ["cannot import module 'nomodule_here'"]),
    (GOOD, "mymodule:Yours", "{}", ["has no attribute 'Yours'"]),
    (GOOD + "\nNOT_CALLABLE = 3\n", "mymodule:NOT_CALLABLE", "{}", ["not callable"]),
    (GOOD + "\nclass Half:\n    infers = True\n    def assist(self, view): pass\n", "mymodule:Half", "{}",
     ["lacks takes_turns, start_turn"]),
    (GOOD.replace("takes_turns = False", "takes_turns = 'no'"), "mymodule:Mine", "{}",
     ["takes_turns must be True or False"]),
    (GOOD, "mymodule:Mine", "{ strength = 2 }", ["do not fit its signature"]),
    (GOOD.replace("self.weight = weight", "raise ValueError('weight out of range')"), "mymodule:Mine", "{}",
     ["making the policy failed", "weight out of range"]),
])
def test_a_policy_that_cannot_run_is_refused_before_any_work(tmp_path, module, factory, params, words):
    out, result = _simulate(tmp_path, _experiment(tmp_path, module, factory, params))
    _one_error_line(result, "condition 'mine'", *words)
    assert not (out / "trials").exists()


@pytest.mark.parametrize(("assist", "words"), [
    ("raise RuntimeError('lost')", ["assist raised RuntimeError: lost"]),
    ("return Assistance((float('nan'), 0.0, 0.0))", ["must be finite"]),
    ("return Assistance((1.0, 0.0))", ["must be three numbers"]),
    ("return (view.u_h, view.u_h, 0.0, -1)", ["not an Assistance"]),
    ("return Assistance(view.u_h, alpha=float('inf'))", ["alpha inf"]),
    ("return Assistance(view.u_h, goal=7)", ["goal 7"]),
])
@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_policy_that_fails_at_run_time_is_one_error_line_and_the_run_is_interrupted(
        tmp_path, assist, words, workers):
    module = GOOD.replace("return Assistance(view.u_h)", assist)
    # made and checked once before the run: the failure comes with the first step
    out, result = _simulate(tmp_path, _experiment(tmp_path, module), "--workers", workers)
    _one_error_line(result, "condition 'mine' (policy mymodule:Mine)", *words)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["status"] == "interrupted"
    analysed = CliRunner().invoke(main, ["analyze", str(out)])
    assert analysed.exit_code == 1 and "Error:" in analysed.output


def test_a_condition_that_names_no_policy_points_to_policy_sections(tmp_path):
    path = policy_experiment(tmp_path, {"mine": "mymodule:Mine"}, params={"mine": "{}"},
                             conditions=["control", "mien"])
    _, result = _simulate(tmp_path, path)
    _one_error_line(result, "unknown condition 'mien'", "did you mean 'mine'", "[policies.mien]")


def test_a_policy_section_may_not_reuse_a_built_in_name(tmp_path):
    path = policy_experiment(tmp_path, {"control": "mymodule:Mine"}, params={"control": "{}"},
                             conditions=["control", "mine"])
    _, result = _simulate(tmp_path, path)
    _one_error_line(result, "[policies.control]", "built-in")


def test_the_assistance_helpers_blend_and_add_as_documented():
    # hand-computed: convex 0.25 * (4, 0, 1) + 0.75 * (0, 2, 1) = (1, 1.5, 1); additive (4, 2, 2)
    convex = Assistance.convex((0.0, 2.0, 1.0), (4.0, 0.0, 1.0), 0.25, 1)
    assert convex.command == (1.0, 1.5, 1.0) and convex.alpha == 0.25 and convex.goal == 1
    additive = Assistance.additive((0.0, 2.0, 1.0), (4.0, 0.0, 1.0), 2)
    assert tuple(additive.command) == (4.0, 2.0, 2.0) and additive.alpha == 1.0


def test_a_batch_leaves_out_what_each_policy_makes_constant(tmp_path):
    out = tmp_path / "batch"
    result = CliRunner().invoke(main, ["replicate", str(EXAMPLE), "-R", "1", "--participants", "2",
                                       "--out", str(out)])
    assert result.exit_code == 0, result.output
    (document,) = [json.loads(p.read_text()) for p in (out / "analyses").glob("*.json")]
    entries = {entry["metric"]: entry for entry in document["metrics"]}
    assert entries["human_effort"]["not_applicable"] == ["blending", "threshold"]
    assert not entries["assistance_engagement"].get("not_applicable")


def test_blendings_strength_is_constant_where_its_alpha_has_one_value():
    every = {"assistance_strength", "human_effort", "human_turns"}
    config = load_experiment("baselines", ["blending.kind=additive"])  # alpha 1 whenever it acts
    assert constant_metrics_of(config)["blending"] == every
    # the gap gate with 3 goals: p1 - p2 > 0.4 and p2 >= (1 - p1) / 2 give p1 > 0.6 >= rho2 = 0.4
    # (4 goals: p1 > 0.55 >= 0.3): the ramp is at rho3 whenever the gate passes
    assert constant_metrics_of(load_experiment("baselines"))["blending"] == every
    # at the bound (1.2 <= 0.1 * 2 + 1) still constant; below it (gap 0.05: p1 > 0.3667 < 0.4 with 3
    # goals, e.g. 0.38, 0.32, 0.30) the ramp's rising part comes through
    assert constant_metrics_of(load_experiment("baselines", ["blending.gap=0.1"]))["blending"] == every
    varying = load_experiment("baselines", ["blending.gap=0.05"])
    assert constant_metrics_of(varying)["blending"] == {"human_effort", "human_turns"}
    for change in ("blending.gate=none", "assistance.distance_weighting=true"):
        metrics = constant_metrics_of(load_experiment("baselines", [change]))["blending"]
        assert "assistance_strength" not in metrics


def test_a_policy_may_answer_the_persons_mode_switches(tmp_path):
    import pandas as pd

    module = GOOD + "\n    def choose_mode(self, view, requested):\n        return 2\n"
    out, result = _simulate(tmp_path, _experiment(tmp_path, module))
    assert result.exit_code == 0, result.output
    steps, trials = pd.read_parquet(out / "steps"), pd.read_parquet(out / "trials")
    mine = steps.merge(trials.loc[trials["condition"] == "mine", ["participant", "trial"]])
    selected = mine[mine["event"].astype(str).str.contains("mode_select")]
    assert len(selected) > 0 and len(selected) == trials.loc[trials["condition"] == "mine",
                                                             "human_mode_switches"].sum()
    # the step after each answered switch is in the mode the policy chose (theta)
    after = mine.loc[mine.index.isin(selected.index + 1)]
    assert (after["mode"] == "theta").all()


@pytest.mark.parametrize(("hook", "words"), [
    ("return 7", ["choose_mode returned 7"]),
    ("raise KeyError('no mode')", ["choose_mode raised KeyError"]),
])
def test_a_mode_switch_hook_that_fails_is_one_error_line(tmp_path, hook, words):
    module = GOOD + f"\n    def choose_mode(self, view, requested):\n        {hook}\n"
    _, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, "condition 'mine' (policy mymodule:Mine)", *words)


def test_mode_switch_on_request_takes_no_turns_so_effort_and_turns_are_constant():
    config = load_experiment("baselines", ["mode-switch.trigger=request"])
    assert constant_metrics_of(config)["mode-switch"] == {"human_effort", "human_turns"}
    assert constant_metrics_of(load_experiment("baselines"))["mode-switch"] == frozenset()


# --- a policy's own sys.exit() is a policy error; Ctrl-C stays Ctrl-C ------------------------------

class _Raising:
    """A policy each of whose hooks raises ``failure``."""

    infers = True
    takes_turns = True

    def __init__(self, failure: BaseException) -> None:
        self.failure = failure

    def assist(self, view):
        raise self.failure

    def start_turn(self, view):
        raise self.failure

    def assist_quiet(self, view, steps):
        raise self.failure

    def choose_mode(self, view, requested):
        raise self.failure


def _call(checked: CheckedPolicy, hook: str) -> None:
    view = SimpleNamespace(step=0, goal_poses=np.zeros((3, 3)), u_h=(0.0, 0.0, 0.0))
    arguments = {"assist": (view,), "start_turn": (view,), "assist_quiet": (view, 2),
                 "choose_mode": (view, 1)}
    getattr(checked, hook)(*arguments[hook])


@pytest.mark.parametrize("hook", ["assist", "start_turn", "assist_quiet", "choose_mode"])
def test_a_policy_hook_that_calls_sys_exit_is_a_policy_error(hook):
    checked = CheckedPolicy(_Raising(SystemExit(3)), PolicySpec("mine", "mymodule:Mine"))
    described = r"condition 'mine' \(policy mymodule:Mine\)"
    with pytest.raises(PolicyError, match=rf"{described}: {hook} raised SystemExit: 3"):
        _call(checked, hook)


@pytest.mark.parametrize("hook", ["assist", "start_turn", "assist_quiet", "choose_mode"])
def test_ctrl_c_inside_a_policy_hook_stays_ctrl_c(hook):
    checked = CheckedPolicy(_Raising(KeyboardInterrupt()), PolicySpec("mine", "mymodule:Mine"))
    with pytest.raises(KeyboardInterrupt):
        _call(checked, hook)


@pytest.mark.parametrize("workers", ["1", "2"])
def test_a_policy_that_calls_sys_exit_in_a_run_is_one_error_line_and_exit_1(tmp_path, workers):
    module = "import sys\n" + GOOD.replace("return Assistance(view.u_h)", "sys.exit(0)")
    out, result = _simulate(tmp_path, _experiment(tmp_path, module), "--workers", workers)
    _one_error_line(result, "condition 'mine' (policy mymodule:Mine)", "assist raised SystemExit: 0")
    assert json.loads((out / "manifest.json").read_text())["status"] == "interrupted"


@pytest.mark.parametrize(("module", "words"), [
    ("import sys\nsys.exit('bye')\n", ["cannot import module 'mymodule'", "SystemExit: bye"]),
    ("import sys\n" + GOOD.replace("self.weight = weight", "sys.exit(2)"),
     ["making the policy failed", "SystemExit: 2"]),
])
def test_a_policy_module_or_factory_that_calls_sys_exit_is_refused_before_any_work(tmp_path, module, words):
    out, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, "condition 'mine'", *words)
    assert not (out / "trials").exists()


# --- constant_metrics: a set of known metric names, checked when the experiment is loaded ---------

@pytest.mark.parametrize(("value", "words"), [
    ('{"completion_tme"}', ["constant_metrics", "unknown metric 'completion_tme'",
                            "did you mean 'completion_time'"]),
    ('"completion_time"', ["constant_metrics", "a set of metric names", "{'completion_time'}"]),
    ("3", ["constant_metrics", "a set of metric names"]),
    ('{"completion_time", 4}', ["constant_metrics", "unknown metric 4"]),
])
def test_a_policys_constant_metrics_must_be_a_set_of_known_metric_names(tmp_path, value, words):
    module = GOOD.replace("takes_turns = False", f"takes_turns = False\n    constant_metrics = {value}")
    out, result = _simulate(tmp_path, _experiment(tmp_path, module))
    _one_error_line(result, "condition 'mine' (policy mymodule:Mine)", *words)
    assert not (out / "trials").exists()


@pytest.mark.parametrize("value", ['{"completion_time"}', '["completion_time"]', '("completion_time",)',
                                   'frozenset({"completion_time"})'])
def test_a_policys_constant_metrics_are_added_to_those_of_its_traits(tmp_path, value):
    module = GOOD.replace("takes_turns = False", f"takes_turns = False\n    constant_metrics = {value}")
    config = load_experiment(str(_experiment(tmp_path, module)))
    assert constant_metrics_of(config)["mine"] == {"completion_time", "human_effort", "human_turns"}


@pytest.mark.parametrize(("target", "words"), [
    ((1.0, 2.0), ["start_turn: its target must be three numbers (x, y, theta), got 2"]),
    ("here", ["start_turn: its target must be three numbers (x, y, theta), got 'here'"]),
    ((1.0, float("nan"), 0.0), ["start_turn: its target must be finite"]),
])
def test_an_autonomy_turns_target_is_a_pose(target, words):
    plan = AutonomyTurn(target)
    mine = SimpleNamespace(infers=True, takes_turns=True, assist=None, start_turn=lambda view: plan)
    checked = CheckedPolicy(mine, PolicySpec("mine", "mymodule:Mine"))
    with pytest.raises(PolicyError) as raised:
        checked.start_turn(SimpleNamespace())
    for word in words:
        assert word in str(raised.value)
    assert "vx" not in str(raised.value)
