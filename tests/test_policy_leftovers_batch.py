"""A batch (``replicate``, ``power``, ``sweep``) of a researcher's own policy behaves as a run of it
does (docs/policies.md): a policy drawing from numpy's or Python's global random generator is one
``Warning:`` line (the run's check and words), and the digest of a policy imported from outside the
experiment's folder (a module on ``sys.path``, a class of the calling script) is recorded in
``batch.json`` (``policy_sources``), so a resume after it changed is refused naming it."""

from __future__ import annotations

import hashlib
import json
import textwrap
from pathlib import Path

import pytest
from policy_helpers import QUIET_POLICY, policy_experiment

from nudgecli.config import load_experiment
from nudgecli.errors import DataError
from nudgecli.report.plans import load_plan
from nudgecli.runs.batch import Batch, run_batch, single_point

ROOT = Path(__file__).resolve().parents[1]
#: the shipped custom-policy plan, for the conditions of policy_helpers' experiment
PLAN = (ROOT / "analysis" / "custom-policy.toml").read_text().replace(
    'name = "custom-policy"', 'name = "mine"').replace(
    'conditions = ["disambiguation", "blending", "threshold"]', 'conditions = ["control", "mine"]')
#: a policy drawing from numpy's global generator (not view.rng)
DRAWING = QUIET_POLICY.replace("class Quiet:", "import numpy as np\n\n\nclass Mine:").replace(
    "        return Assistance(view.u_h)",
    "        np.random.randint(0, 10)\n        return Assistance(view.u_h)")


def _replicate(experiment: Path, out: Path, lines: list[str], resume: bool = False) -> None:
    """A replicate batch of the experiment (one study of two participants) into ``out``, without the
    command's tables and figures (what a batch checks and records is the same)."""
    plan = experiment.parent / "mine-plan.toml"
    plan.write_text(PLAN)
    config = load_experiment(str(experiment))
    batch = Batch("replicate", single_point(config, (2,)), 1, 3, load_plan(plan))
    run_batch(batch, out, resume=resume, log=lines.append)


def test_a_batch_of_a_policy_drawing_from_the_global_generator_warns_once_as_a_run_does(
        tmp_path: Path) -> None:
    experiment = policy_experiment(tmp_path / "exp", {"mine": "mymodule:Mine"},
                                   modules={"mymodule.py": DRAWING})
    lines: list[str] = []
    _replicate(experiment, tmp_path / "batch", lines)
    warnings = [line for line in lines if line.startswith("Warning:")]
    assert len(warnings) == 1, lines
    assert warnings[0].startswith(f"Warning: {tmp_path / 'batch'}: condition 'mine' (policy mymodule:Mine): "
                                  "a policy drew from numpy's or Python's global random generator")
    assert "view.rng" in warnings[0]


def test_a_batch_records_a_sys_path_policys_digest_and_refuses_a_resume_after_it_changed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    library = tmp_path / "lib"
    library.mkdir()
    module = library / "syspol_batch_leftover.py"
    module.write_text(textwrap.dedent(QUIET_POLICY))
    monkeypatch.syspath_prepend(str(library))
    experiment = policy_experiment(tmp_path / "exp", {"mine": "syspol_batch_leftover:Quiet"})
    out, lines = tmp_path / "batch", []
    _replicate(experiment, out, lines)
    assert not [line for line in lines if line.startswith("Warning:")], lines  # it draws from view.rng only
    recorded = json.loads((out / "batch.json").read_text())["policy_sources"]
    assert recorded == {"syspol_batch_leftover": hashlib.sha256(module.read_bytes()).hexdigest()}
    module.write_text(module.read_text() + "\n# edited\n")
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    with pytest.raises(DataError) as refused:
        _replicate(experiment, out, [], resume=True)
    message = str(refused.value)
    assert message.startswith(f"{module} is not the policy module {out} was simulated with")
    assert "resuming would mix two policies in one batch" in message and "--force" in message
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
