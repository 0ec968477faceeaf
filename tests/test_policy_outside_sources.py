"""A factory imported from outside the experiment's folder (a module on ``sys.path``, a class of
the calling script, ``__main__``) is not copied into the run folder: the manifest records its
SHA-256 (``policy_sources``), and a resume after it changed is refused as an edited copy is, one
``Error:`` line naming the file (docs/policies.md)."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line
from policy_helpers import QUIET_POLICY, policy_experiment

POLICY = QUIET_POLICY.replace("class Quiet:", "class Mine:")


def test_a_resume_after_a_sys_path_policy_module_changed_is_refused_naming_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    library = tmp_path / "lib"
    library.mkdir()
    module = library / "syspol_outside.py"
    module.write_text(textwrap.dedent(POLICY))
    monkeypatch.syspath_prepend(str(library))
    experiment = policy_experiment(tmp_path / "exp", {"mine": "syspol_outside:Mine"})
    run = tmp_path / "run"
    assert nudge("simulate", experiment, "--out", run).exit_code == 0
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["policy_sources"] == {"syspol_outside": hashlib.sha256(module.read_bytes()).hexdigest()}
    assert not (run / "syspol_outside.py").exists()  # recorded, not copied
    same = nudge("simulate", experiment, "--out", run, "--resume")
    assert same.exit_code == 0, same.output
    module.write_text(module.read_text() + "\n# edited\n")
    before = {p.name: p.read_bytes() for p in run.rglob("*") if p.is_file()}
    edited = nudge("simulate", experiment, "--out", run, "--resume")
    assert edited.exit_code == 1, edited.output
    line = one_error_line(edited.output)
    assert str(module) in line and "mix two policies" in line and "--force" in line, line
    assert {p.name: p.read_bytes() for p in run.rglob("*") if p.is_file()} == before


SCRIPT = """
import sys

import nudgecli
from nudgecli.errors import NudgeError
POLICY

try:
    nudgecli.simulate(sys.argv[1], out=sys.argv[2], resume=sys.argv[3] == "resume")
except NudgeError as exc:
    print(f"Error: {exc}")
    sys.exit(1)
"""


def _script(tmp_path: Path, name: str, policy: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(SCRIPT).replace("POLICY", textwrap.dedent(policy)))
    return path


def test_a_calling_scripts_policy_resumes_from_that_script_and_is_refused_once_edited(tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "__main__:Mine"})
    run = tmp_path / "run"
    script = _script(tmp_path, "study.py", POLICY)

    def call(path: Path, *mode: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, str(path), str(experiment), str(run), *(mode or ("new",))],
                              capture_output=True, text=True, timeout=300, check=False)

    made = call(script)
    assert made.returncode == 0, made.stdout + made.stderr
    assert set(json.loads((run / "manifest.json").read_text())["policy_sources"]) == {"__main__:Mine"}
    again = call(script, "resume")
    assert again.returncode == 0, again.stdout + again.stderr
    changed = POLICY.replace("Assistance(view.u_h)", "Assistance(view.u_h, alpha=0.0)")
    edited = call(_script(tmp_path, "edited.py", changed), "resume")
    assert edited.returncode == 1
    line = one_error_line(edited.stdout)
    assert "__main__:Mine" in line and "mix two policies" in line, line
    # the command line has no such class: the error says where the run can resume
    cli = nudge("simulate", run / "config.toml", "--out", run, "--resume")
    assert cli.exit_code == 1
    line = one_error_line(cli.output)
    assert "has no attribute 'Mine'" in line, line
    assert "resume the run from the script that started it" in line, line
