"""A policy of the calling script (``factory = "__main__:Mine"``, docs/policies.md) in every path of
a run: one whose source Python cannot show is refused before any folder exists (its run could never
be resumed), a misspelt name on a fresh run gets its "did you mean" and no advice about resuming, a
run of one names the Python call that resumes it (a ``nudge`` command cannot import the policy), and
``workers=2`` (forked from the script) gives the tables of ``workers=1``.

The calling script's ``__main__`` is this process's (pytest's): the tests set the policy on it, as a
script defines it there."""

from __future__ import annotations

import linecache
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest
from cli_helpers import nudge, one_error_line
from policy_helpers import QUIET_POLICY, policy_experiment

import nudgecli
from nudgecli.config import load_experiment
from nudgecli.errors import PolicyError
from nudgecli.sim.policy_files import outside_policy_sources


class Mine:
    """The calling script's policy: the person's own command, unassisted."""

    infers = True
    takes_turns = False

    def assist(self, view):  # type: ignore[no-untyped-def]
        from nudgecli.sim.policy_interface import Assistance

        return Assistance(view.u_h)

    def start_turn(self, view):  # type: ignore[no-untyped-def]
        from nudgecli.sim.policy_interface import AutonomyTurn

        return AutonomyTurn.stay()


def _script_policy(monkeypatch: pytest.MonkeyPatch, name: str, policy: object) -> None:
    """Define ``policy`` as ``name`` in the calling script (``__main__``)."""
    monkeypatch.setattr(sys.modules["__main__"], name, policy, raising=False)


def _compiled_class(source: str, filename: str) -> type:
    """The class ``Quiet`` of ``source`` made as ``exec`` of code read from ``filename`` makes it in
    the calling script (its ``__module__`` is ``__main__``)."""
    namespace: dict[str, object] = {"__name__": "__main__"}
    exec(compile(textwrap.dedent(source), filename, "exec"), namespace)
    made = namespace["Quiet"]
    assert isinstance(made, type)
    return made


def test_a_script_policy_whose_source_python_cannot_show_is_refused_before_any_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # python - < study.py, or exec: no file holds the class, nor its methods
    _script_policy(monkeypatch, "Quiet", _compiled_class(QUIET_POLICY, "<stdin>"))
    experiment = policy_experiment(tmp_path / "exp", {"mine": "__main__:Quiet"})
    with pytest.raises(PolicyError) as refused:
        nudgecli.simulate(experiment, out=tmp_path / "run")
    message = str(refused.value)
    assert message.startswith("condition 'mine' (policy __main__:Quiet): Python cannot show the source")
    assert "could never be checked and resumed" in message and "put the policy in a file" in message
    assert not (tmp_path / "run").exists()


def test_a_notebook_cells_class_is_digested_by_its_methods_sources(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a notebook's cell: its source is in linecache, but Python finds a class only in its module's file
    def cell(source: str, filename: str) -> type:
        text = textwrap.dedent(source)
        monkeypatch.setitem(linecache.cache, filename, (len(text), None, text.splitlines(True), filename))
        return _compiled_class(text, filename)

    experiment = policy_experiment(tmp_path / "exp", {"mine": "__main__:Quiet"})
    _script_policy(monkeypatch, "Quiet", cell(QUIET_POLICY, "<cell-1>"))
    first = outside_policy_sources(load_experiment(str(experiment)))["__main__:Quiet"]
    _script_policy(monkeypatch, "Quiet", cell(QUIET_POLICY, "<cell-2>"))  # the same cell, run again
    again = outside_policy_sources(load_experiment(str(experiment)))["__main__:Quiet"]
    _script_policy(monkeypatch, "Quiet", cell(QUIET_POLICY.replace("takes_turns = False",
                                                                   "takes_turns = True"), "<cell-3>"))
    edited = outside_policy_sources(load_experiment(str(experiment)))["__main__:Quiet"]
    assert first == again != edited and len(first) == 64


def test_a_misspelt_script_policy_on_a_fresh_run_gets_did_you_mean_and_no_resume_advice(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _script_policy(monkeypatch, "Mine", Mine)
    misspelt = policy_experiment(tmp_path / "typo", {"mine": "__main__:Mien"})
    with pytest.raises(PolicyError) as refused:
        nudgecli.simulate(misspelt, out=tmp_path / "run")
    assert str(refused.value) == ("condition 'mine' (policy __main__:Mien): module '__main__' has no "
                                  "attribute 'Mien' (did you mean 'Mine'?)")
    # a name the script does not come close to: where such a policy runs, not how to resume
    elsewhere = policy_experiment(tmp_path / "other", {"mine": "__main__:Threshold"})
    with pytest.raises(PolicyError) as missing:
        nudgecli.simulate(elsewhere, out=tmp_path / "run")
    assert "run the experiment from that script (nudgecli.simulate)" in str(missing.value)
    assert "resume" not in str(missing.value)
    assert not (tmp_path / "run").exists()


def test_a_script_policys_run_names_the_python_call_that_resumes_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _script_policy(monkeypatch, "Mine", Mine)
    run = tmp_path / "run"
    nudgecli.simulate(policy_experiment(tmp_path / "exp", {"mine": "__main__:Mine"}), out=run).close()
    (run / "trials" / "part-0000.parquet").unlink()  # a damaged run: analyze names what restores it
    line = one_error_line(nudge("analyze", run).output)
    advice = line.split("restore with `")[1].rstrip("`")
    assert advice.startswith(f"nudgecli.simulate({str(run / 'config.toml')!r}, out={str(run)!r}, ")
    assert "resume=True)  # in the script that defines __main__:Mine" in advice, line
    assert "nudge simulate" not in line
    # the call, run where the policy is, restores the run
    resumed = eval(advice.split("  #")[0], {"nudgecli": nudgecli})
    assert resumed.mode == "resume" and resumed.computed == [0]
    assert (run / "trials" / "part-0000.parquet").is_file()


def test_a_script_policy_on_two_forked_workers_gives_the_tables_of_one(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _script_policy(monkeypatch, "Mine", Mine)
    experiment = policy_experiment(tmp_path / "exp", {"mine": "__main__:Mine"}, participants=2)
    tables = []
    for workers in (1, 2):
        with nudgecli.simulate(experiment, workers=workers) as run:
            tables.append(run.trials.drop(columns=["wall_s"], errors="ignore"))
    pd.testing.assert_frame_equal(tables[0], tables[1], check_exact=True)
    assert set(tables[0]["condition"]) == {"control", "mine"}
