"""Where a researcher's policy module comes from: the experiment's own folder, by file (two folders'
modules of one name never collide, an edited file is loaded again, the folder never goes on
``sys.path``), else a plain import from ``sys.path``."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from click.testing import CliRunner
from policy_helpers import policy_experiment

from nudgecli.cli import main
from nudgecli.config import load_experiment
from nudgecli.errors import PolicyError
from nudgecli.sim.policy_registry import PolicySpec, check_custom_policy, load_factory, policy_specs

ROOT = Path(__file__).resolve().parents[1]

POLICY = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

WEIGHT = {weight}

class ThresholdAssist:
    infers = True
    takes_turns = False

    def assist(self, view):
        goal = int(view.belief.argmax())
        return Assistance(view.u_h, alpha=WEIGHT, goal=goal)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""

def _folder(root: Path, weight: float, *, package: bool = True,
            factory: str = "policies.threshold:ThresholdAssist") -> Path:
    """An experiment folder with ``policies/threshold.py`` whose policy's alpha is ``weight``."""
    modules = {"policies/threshold.py": POLICY.format(weight=weight)}
    if package:
        modules["policies/__init__.py"] = ""
    policy_experiment(root, {"threshold": factory}, modules=modules)
    return root


def _spec(folder: Path, factory: str = "policies.threshold:ThresholdAssist") -> PolicySpec:
    return PolicySpec("threshold", factory, (), str(folder.resolve()))


def _alphas(out: Path) -> set[float]:
    import pandas as pd

    steps, trials = pd.read_parquet(out / "steps"), pd.read_parquet(out / "trials")
    mine = steps.merge(trials.loc[trials["condition"] == "threshold", ["participant", "trial"]])
    return set(mine["alpha"].unique())


def test_two_folders_modules_of_one_name_are_each_their_own(tmp_path):
    first = _folder(tmp_path / "a", 0.25)
    second = _folder(tmp_path / "b", 0.75, package=False)  # a namespace package: no __init__.py
    one, two = load_factory(_spec(first)), load_factory(_spec(second))
    assert one is not two
    assert sys.modules[one.__module__].WEIGHT == 0.25
    assert sys.modules[two.__module__].WEIGHT == 0.75
    # asked again, each folder's is the one already loaded
    assert load_factory(_spec(first)) is one and load_factory(_spec(second)) is two


def test_two_experiments_in_one_process_each_run_their_own_policy(tmp_path):
    runs = {}
    for name, weight in (("a", 0.25), ("b", 0.75)):
        folder = _folder(tmp_path / name, weight)
        out = tmp_path / f"run-{name}"
        result = CliRunner().invoke(main, ["simulate", str(folder / "mine.toml"), "--out", str(out)])
        assert result.exit_code == 0, result.output
        runs[name] = _alphas(out)
    assert runs == {"a": {0.25}, "b": {0.75}}


def test_an_edited_policy_file_is_loaded_again(tmp_path):
    folder = _folder(tmp_path / "a", 0.25)
    first = check_custom_policy(_spec(folder))
    (folder / "policies" / "threshold.py").write_text(POLICY.format(weight=0.125))  # another size
    second = check_custom_policy(_spec(folder))
    assert sys.modules[type(first).__module__] is not None
    assert type(first) is not type(second)
    assert sys.modules[type(second).__module__].WEIGHT == 0.125
    # and through the command line: the second simulate runs the edited code
    out = tmp_path / "run"
    result = CliRunner().invoke(main, ["simulate", str(folder / "mine.toml"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert _alphas(out) == {0.125}
    (folder / "policies" / "threshold.py").write_text(POLICY.format(weight=0.5))
    result = CliRunner().invoke(main, ["simulate", str(folder / "mine.toml"), "--out", str(out), "--force"])
    assert result.exit_code == 0, result.output
    assert _alphas(out) == {0.5}


def test_an_edited_sibling_module_is_loaded_again(tmp_path):
    folder = _folder(tmp_path / "a", 0.25)
    (folder / "policies" / "weights.py").write_text("WEIGHT = 0.25\n")
    (folder / "policies" / "threshold.py").write_text(
        POLICY.format(weight="0.0").replace("WEIGHT = 0.0", "from .weights import WEIGHT"))
    assert sys.modules[load_factory(_spec(folder)).__module__].WEIGHT == 0.25
    (folder / "policies" / "weights.py").write_text("WEIGHT = 0.875\n")
    assert sys.modules[load_factory(_spec(folder)).__module__].WEIGHT == 0.875


@pytest.mark.parametrize("package", [True, False])
def test_relative_imports_inside_the_policies_package_work(tmp_path, package):
    folder = _folder(tmp_path / "a", 0.0, package=package)
    (folder / "policies" / "common.py").write_text("WEIGHT = 0.375\n")
    (folder / "policies" / "threshold.py").write_text(
        POLICY.format(weight="0.0").replace("WEIGHT = 0.0", "from .common import WEIGHT"))
    factory = load_factory(_spec(folder))
    assert sys.modules[factory.__module__].WEIGHT == 0.375


def test_the_folder_never_goes_on_sys_path(tmp_path):
    folder = _folder(tmp_path / "a", 0.25)
    before = list(sys.path)
    check_custom_policy(_spec(folder))
    assert sys.path == before
    # nor under its plain name, where another folder's "policies.threshold" would find it
    plain = sys.modules.get("policies.threshold")
    assert plain is None or not str(plain.__file__).startswith(str(folder.resolve()))


def test_a_module_named_like_a_library_beside_the_experiment_does_not_shadow_it(tmp_path):
    folder = _folder(tmp_path / "a", 0.25)
    for name in ("scipy", "matplotlib", "pandas"):
        (folder / f"{name}.py").write_text("raise ImportError('the experiment folder shadowed me')\n")
    # a fresh interpreter: load the experiment and its policy, then import the libraries
    script = textwrap.dedent(f"""
        from nudgecli.config import load_experiment
        from nudgecli.sim.policy_registry import checked_policy_specs
        checked_policy_specs(load_experiment({str(folder / 'mine.toml')!r}))
        import matplotlib, pandas, scipy.stats
        print("ok")
    """)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_a_module_not_in_the_folder_is_imported_from_sys_path_and_the_folder_comes_first(
        tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "mypolicy_on_path.py").write_text(POLICY.format(weight=0.625))
    monkeypatch.syspath_prepend(str(elsewhere))
    monkeypatch.delitem(sys.modules, "mypolicy_on_path", raising=False)
    folder = tmp_path / "experiment"
    folder.mkdir()
    factory = load_factory(_spec(folder, "mypolicy_on_path:ThresholdAssist"))
    assert factory.__module__ == "mypolicy_on_path"
    assert sys.modules["mypolicy_on_path"].WEIGHT == 0.625
    # the same name beside the experiment: the folder's
    (folder / "mypolicy_on_path.py").write_text(POLICY.format(weight=0.0625))
    beside = load_factory(_spec(folder, "mypolicy_on_path:ThresholdAssist"))
    assert sys.modules[beside.__module__].WEIGHT == 0.0625


def test_the_shipped_example_loads_from_its_folder():
    config = load_experiment(str(ROOT / "experiments" / "custom-policy.toml"))
    (spec,) = policy_specs(config)
    factory = load_factory(spec)
    assert factory.__name__ == "ThresholdAssist"
    assert Path(sys.modules[factory.__module__].__file__).resolve() == (
        ROOT / "experiments" / "policies" / "threshold.py")


@pytest.mark.parametrize("factory", ["../policies.threshold:ThresholdAssist", "policies..threshold:X",
                                     "policies/threshold:ThresholdAssist"])
def test_a_factory_that_is_not_a_module_name_is_refused(tmp_path, factory):
    folder = _folder(tmp_path / "a", 0.25)
    with pytest.raises(PolicyError, match="module:attribute"):
        load_factory(_spec(folder, factory))


def test_an_edit_within_the_same_second_and_of_the_same_size_is_loaded_again(tmp_path, monkeypatch):
    # Python's bytecode cache checks a source's whole seconds and size: it alone would keep the old code
    monkeypatch.setattr(sys, "dont_write_bytecode", False)
    folder = _folder(tmp_path / "a", 0.25)
    path = folder / "policies" / "threshold.py"
    second = 1_700_000_000 * 10**9
    os.utime(path, ns=(second, second))
    assert sys.modules[load_factory(_spec(folder)).__module__].WEIGHT == 0.25
    assert list((folder / "policies" / "__pycache__").glob("threshold.*.pyc"))
    path.write_text(POLICY.format(weight=0.75))  # the same length
    os.utime(path, ns=(second + 1000, second + 1000))
    assert sys.modules[load_factory(_spec(folder)).__module__].WEIGHT == 0.75


def test_the_api_in_one_process_with_workers_runs_each_folders_own_policy(tmp_path):
    import nudgecli

    alphas = {}
    for name, weight in (("a", 0.25), ("b", 0.75)):
        folder = _folder(tmp_path / name, weight)
        for workers in (1, 2):
            out = tmp_path / f"run-{name}-{workers}"
            nudgecli.simulate(folder / "mine.toml", workers=workers, out=out)
            alphas[name, workers] = _alphas(out)
    assert alphas == {("a", 1): {0.25}, ("a", 2): {0.25}, ("b", 1): {0.75}, ("b", 2): {0.75}}
