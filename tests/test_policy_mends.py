"""A researcher's policy in a run: the code a run starts with is the code all its participants run,
a draw from a global random generator at import time is a warning, and a failure of the policy's
own code names its file and line (docs/policies.md)."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path

import pytest
from cli_helpers import nudge
from policy_helpers import policy_experiment

from nudgecli.errors import ConfigError
from nudgecli.sim import policy_files

#: A policy that edits its own file while the run's first trial runs, and logs which code made
#: each of its policies (beside itself, ``ran.log``).
SELF_EDITING = """
import pathlib

from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

HERE = pathlib.Path(__file__)
VERSION = "first"


class Mine:
    infers = True
    takes_turns = False
    edited = False

    def __init__(self):
        with HERE.with_name("ran.log").open("a") as log:
            log.write(VERSION + "\\n")

    def assist(self, view):
        if not Mine.edited:
            Mine.edited = True
            text = HERE.read_text()
            HERE.write_text(text.replace('VERSION = "first"', 'VERSION = "second"  # edited in the run'))
        return Assistance(view.u_h)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def test_a_policy_file_edited_during_a_run_leaves_the_run_on_the_code_it_started_with(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "mymodule:Mine"},
                                   modules={"mymodule.py": SELF_EDITING}, participants=2)
    result = nudge("simulate", experiment, "--out", tmp_path / "run", "--workers", "1")
    assert result.exit_code == 0, result.output
    assert 'VERSION = "second"' in (tmp_path / "exp" / "mymodule.py").read_text()  # the file was edited
    ran = (tmp_path / "exp" / "ran.log").read_text().split()
    assert len(ran) >= 3 and set(ran) == {"first"}, ran  # the check's policy and both participants'
    assert 'VERSION = "first"' in (tmp_path / "run" / "mymodule.py").read_text()  # the copy: the code run


#: A policy whose module draws from numpy's global generator when it is imported.
DRAWS_ON_IMPORT = """
import numpy as np

from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

W = float(np.random.uniform(0.2, 0.9))


class Mine:
    infers = True
    takes_turns = False

    def assist(self, view):
        return Assistance(view.u_h) if W else None

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def test_a_draw_from_the_global_generator_at_import_is_the_runs_warning(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "drawing:Mine"},
                                   modules={"drawing.py": DRAWS_ON_IMPORT})
    result = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if line.startswith("Warning:")]
    assert len(warnings) == 1, result.output
    assert "condition 'mine' (policy drawing:Mine)" in warnings[0] and "view.rng" in warnings[0]


#: A policy in a package whose assist fails an assertion at its fifth step (line 11 of its file).
ASSERTS = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn


class Mine:
    infers = True
    takes_turns = False

    def assist(self, view):
        assert view.step < 5
        return Assistance(view.u_h)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def test_a_failure_in_the_policys_code_names_its_file_and_line(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "p.assertp:Mine"},
                                   modules={"p/assertp.py": ASSERTS})
    result = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert result.exit_code == 1
    assert result.output.startswith(
        "Error: condition 'mine' (policy p.assertp:Mine): assist raised AssertionError "
        "(p/assertp.py line 10: "
        "assert view.step < 5); nudge --debug, or the exception's __cause__ in Python, shows the whole "
        "traceback"), result.output


def test_a_failure_in_making_the_policy_names_its_file_and_line(tmp_path: Path) -> None:
    failing = ASSERTS.replace("    def assist(self, view):", "    def __init__(self):\n        1 / 0\n\n"
                              "    def assist(self, view):")
    experiment = policy_experiment(tmp_path / "exp", {"mine": "mymodule:Mine"},
                                   modules={"mymodule.py": failing})
    result = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert result.exit_code == 1
    assert ("making the policy failed: ZeroDivisionError: division by zero (mymodule.py line 10: 1 / 0); "
            "nudge --debug, or the exception's __cause__ in Python, shows the whole traceback"
            ) in result.output, result.output


def test_a_policy_module_importing_a_module_not_installed_names_the_import(tmp_path: Path) -> None:
    module = "import math\nimport torchy_nonexist\n" + ASSERTS
    experiment = policy_experiment(tmp_path / "exp", {"mine": "p.missingmod:Mine"},
                                   modules={"p/missingmod.py": module})
    result = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert result.exit_code == 1
    assert result.output.strip() == (
        "Error: condition 'mine' (policy p.missingmod:Mine): cannot import module 'p.missingmod': "
        "ModuleNotFoundError: No module named 'torchy_nonexist'; p/missingmod.py line 2 imports "
        "'torchy_nonexist', which is not installed in this Python"), result.output


#: A policy in a package that imports a module of it only as it runs (inside ``assist``).
LAZY = ASSERTS.replace("        assert view.step < 5\n", "        from .common import W\n\n"
                       "        assert W\n")


def test_a_module_the_policy_imports_as_it_runs_is_copied_and_hashed(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "pk.lazy:Mine"},
                                   modules={"pk/lazy.py": LAZY, "pk/common.py": "W = 1\n"}, participants=2)
    result = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "run" / "pk" / "common.py").read_text() == "W = 1\n"
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert set(manifest["policy_files"]) == {"pk/common.py", "pk/lazy.py"}
    (tmp_path / "run" / "trials" / "part-0001.parquet").unlink()  # a run to resume from its own copies
    replayed = nudge("simulate", tmp_path / "run" / "config.toml", "--out", tmp_path / "run", "--resume")
    assert replayed.exit_code == 0, replayed.output
    (tmp_path / "run" / "trials" / "part-0001.parquet").unlink()
    (tmp_path / "exp" / "pk" / "common.py").write_text("W = 2\n")  # a resume would mix two policies
    resumed = nudge("simulate", experiment, "--out", tmp_path / "run", "--resume")
    assert resumed.exit_code == 1 and "common.py is not the policy module" in resumed.output, resumed.output


def test_a_policy_importing_too_many_module_files_is_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "pk").mkdir()
    (tmp_path / "pk" / "lazy.py").write_text("def f():\n    from . import common, more\n")
    for name in ("common", "more", "unused"):
        (tmp_path / "pk" / f"{name}.py").write_text("")
    monkeypatch.setattr(policy_files, "MAX_PACKAGE_FILES", 2)
    with pytest.raises(ConfigError, match="more than the 2 module files"):
        policy_files.package_files(tmp_path.resolve(), [tmp_path / "pk" / "lazy.py"])
    top = tmp_path / "alone.py"  # a module at the folder's top that imports nothing is kept alone
    top.write_text("import json\n")
    assert policy_files.package_files(tmp_path.resolve(), [top]) == [top.resolve()]


def _loaded(experiment: Path) -> dict[str, bytes]:
    from nudgecli.config import load_experiment

    return policy_files.loaded_policy_files(load_experiment(str(experiment)))


def test_a_policy_module_linked_from_outside_the_folder_is_kept_by_its_path_in_the_folder(
        tmp_path: Path) -> None:
    shared = tmp_path / "shared" / "helpers.py"
    shared.parent.mkdir()
    shared.write_text("W = 1\n")
    experiment = policy_experiment(tmp_path / "exp", {"mine": "mypol.linked:Mine"},
                                   modules={"mypol/linked.py": LAZY.replace(".common", ".helpers")})
    (tmp_path / "exp" / "mypol" / "helpers.py").symlink_to(Path("..", "..", "shared", "helpers.py"))
    assert _loaded(experiment) == {"mypol/linked.py": (tmp_path / "exp" / "mypol" / "linked.py").read_bytes(),
                                   "mypol/helpers.py": b"W = 1\n"}


def test_only_the_modules_a_policy_imports_are_kept_not_their_folders_other_scripts(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "pols.mine:Mine"},  # a folder, no __init__.py
                                   modules={"pols/mine.py": LAZY, "pols/common.py": "W = 1\n",
                                            "pols/habits_check.py": "print('a script of its own')\n",
                                            "pols/tests/test_mine.py": "from ..mine import Mine\n"})
    assert set(_loaded(experiment)) == {"pols/mine.py", "pols/common.py"}


def test_a_module_at_the_folders_top_keeps_the_module_it_imports_relatively_as_it_runs(
        tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "toppol:Mine"},
                                   modules={"toppol.py": LAZY.replace(".common", ".tophelp"),
                                            "tophelp.py": "W = 1\n", "other.py": "W = 3\n"},
                                   participants=2)
    result = nudge("simulate", experiment, "--out", tmp_path / "run")
    assert result.exit_code == 0, result.output
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert set(manifest["policy_files"]) == {"toppol.py", "tophelp.py"}
    assert (tmp_path / "run" / "tophelp.py").read_text() == "W = 1\n"
    (tmp_path / "run" / "trials" / "part-0001.parquet").unlink()
    (tmp_path / "exp" / "tophelp.py").write_text("W = 2\n")  # a resume would mix two policies
    resumed = nudge("simulate", experiment, "--out", tmp_path / "run", "--resume")
    assert resumed.exit_code == 1 and "tophelp.py is not the policy module" in resumed.output, resumed.output


#: A script whose policy class reads a script-level constant and a function of the script.
SCRIPT = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn

W = WEIGHT


def scaled(command):
    return tuple(W * value for value in command)


class Mine:
    infers = True
    takes_turns = False

    def assist(self, view):
        return Assistance(scaled(view.u_h))

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def _script_source(tmp_path: Path, name: str, weight: str, monkeypatch: pytest.MonkeyPatch,
                   script_text: str = SCRIPT) -> str | None:
    path = tmp_path / name
    path.write_text(script_text.replace("WEIGHT", weight))
    script = types.ModuleType("__main__")
    script.__file__ = str(path)
    monkeypatch.setitem(sys.modules, "__main__", script)
    exec(compile(path.read_text(), str(path), "exec"), vars(script))  # as python SCRIPT runs it
    return policy_files.script_policy_source(vars(script)["Mine"])


def test_a_script_policys_recorded_source_holds_the_script_globals_it_reads(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    first = _script_source(tmp_path, "study.py", "0.3", monkeypatch)
    assert first is not None and "W = 0.3" in first and "def scaled(command):" in first
    assert _script_source(tmp_path, "again.py", "0.3", monkeypatch) == first  # another script, same policy
    assert _script_source(tmp_path, "edited.py", "0.4", monkeypatch) != first  # a global edited


def test_a_policy_module_already_imported_is_loaded_without_reading_the_global_generators(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nudgecli.sim import policy_registry

    (tmp_path / "digested.py").write_text("class Mine:\n    pass\n")
    spec = policy_registry.PolicySpec("mine", "digested:Mine", search_path=str(tmp_path))
    digests: list[int] = []
    digest = policy_registry.global_rng_digest
    monkeypatch.setattr(policy_registry, "global_rng_digest", lambda: digests.append(1) or digest())
    first = policy_registry.load_factory(spec, reload_changed=False)  # imported: a draw is looked for
    assert len(digests) == 2
    assert policy_registry.load_factory(spec, reload_changed=False) is first  # a trial's: nothing imported
    assert len(digests) == 2


def test_a_script_global_named_like_an_attribute_the_policy_reads_is_not_recorded(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    script = SCRIPT.replace("W = WEIGHT", "W = WEIGHT\nstep = 7").replace(
        "return Assistance(scaled(view.u_h))",
        "return Assistance(scaled(view.u_h)) if view.step >= 0 else None")
    source = _script_source(tmp_path, "study.py", "0.3", monkeypatch, script)
    assert source is not None and "W = 0.3" in source and "step = 7" not in source  # view.step: not it
