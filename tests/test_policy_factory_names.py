"""A misspelt factory or parameter of a researcher's policy is one Error line with a "did you mean"
(docs/policies.md, 'When something is wrong'); a module named with its file's ``.py`` is told to
name the module."""

from __future__ import annotations

from pathlib import Path

import pytest
from policy_helpers import policy_experiment

from tests.test_custom_policy import GOOD, _one_error_line, _simulate


def _experiment(tmp_path: Path, factory: str, params: str = "{}") -> Path:
    return policy_experiment(tmp_path, {"mine": factory}, params={"mine": params},
                             modules={"mypol/__init__.py": "", "mypol/turns.py": GOOD})


@pytest.mark.parametrize(("factory", "words"), [
    ("mypol.turn:Mine", ["cannot import module 'mypol.turn'", "did you mean 'mypol.turns'?"]),
    ("mypol.turns:Mien", ["has no attribute 'Mien'", "did you mean 'Mine'?"]),
    ("mypol.turns.py:Mine", ["cannot import module 'mypol.turns.py'", "name the module without .py",
                             "'mypol.turns:Mine'"]),
])
def test_a_misspelt_factory_gets_its_did_you_mean(tmp_path, factory, words):
    out, result = _simulate(tmp_path, _experiment(tmp_path, factory))
    _one_error_line(result, f"condition 'mine' (policy {factory})", *words)
    assert not out.exists()


def test_a_misspelt_parameter_gets_its_did_you_mean(tmp_path):
    out, result = _simulate(tmp_path, _experiment(tmp_path, "mypol.turns:Mine", "{ wieght = 0.3 }"))
    _one_error_line(result, "condition 'mine'", "do not fit its signature", "did you mean 'weight'?")
    assert not out.exists()


# --- a module of the folder importing another absolutely: the folder is not on sys.path -----------

@pytest.mark.parametrize(("line", "relative"), [
    ("from mypol.common import W", "from .common import W"),
    ("import mypol.common", "from . import common"),
    ("from common import W", "from ..common import W"),
])
@pytest.mark.parametrize("init", [True, False])  # a package with or without __init__.py
def test_an_absolute_import_of_a_sibling_module_is_told_its_relative_form(tmp_path, line, relative, init):
    experiment = policy_experiment(tmp_path, {"mine": "mypol.quiet:Mine"}, modules={
        **({"mypol/__init__.py": ""} if init else {}), "mypol/common.py": "W = 1\n", "common.py": "W = 1\n",
        "mypol/quiet.py": f"{line}\n{GOOD}"})
    out, result = _simulate(tmp_path, experiment)
    _one_error_line(result, "cannot import module 'mypol.quiet'", f"mypol/quiet.py line 1 ({line})",
                    "the experiment's folder is not on sys.path", f"import it relatively: {relative}")
    assert not out.exists()


def test_the_relative_form_imports(tmp_path):
    experiment = policy_experiment(tmp_path, {"mine": "mypol.quiet:Mine"}, modules={
        "mypol/__init__.py": "", "mypol/common.py": "W = 1\n",
        "mypol/quiet.py": f"from .common import W\n{GOOD}"})
    _, result = _simulate(tmp_path, experiment)
    assert result.exit_code == 0, result.output


# --- a [policies.NAME] section no condition names: a note, not an error --------------------------

def test_a_policy_section_no_condition_names_is_one_note(tmp_path):
    from nudgecli.config import load_experiment
    from nudgecli.sim.policy_registry import unused_policy_notes

    experiment = policy_experiment(tmp_path, {"mine": "mypol.turns:Mine", "spare": "nowhere:Broken"},
                                   conditions=["control", "mine"],
                                   modules={"mypol/__init__.py": "", "mypol/turns.py": GOOD})
    config = load_experiment(str(experiment))
    assert unused_policy_notes(config) == (
        "[policies.spare] (nowhere:Broken) is not in study.conditions, so not run (nor imported or "
        "checked); list it in study.conditions to run it",)
    assert unused_policy_notes(load_experiment(str(experiment), ['study.conditions=["mine", "spare"]'])) == ()
