"""`nudge study`'s choices of a session: ``--condition-order`` takes every order the experiment's
counterbalancing assigns (and only those), two IDs with one number are one participant, the
folder's config.toml records the seed used, and the commands the messages suggest carry the
``--condition-order`` a session needs."""

from __future__ import annotations

import hashlib
import itertools
import json
import shlex
import tomllib
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

from cli_helpers import one_error_line
from click.testing import CliRunner
from live_helpers import DEFAULT_TABLES, TWO_TRIALS, free_port

from nudgecli.cli import main
from nudgecli.config import ExperimentConfig, experiment_from_toml, load_experiment
from nudgecli.errors import ConfigError, RunFolderError
from nudgecli.live.app import build_session, chosen_order
from nudgecli.run_folder_record import RunRecord
from nudgecli.sim.counterbalance import (
    DESIGNS,
    check_design_order,
    condition_orders,
    order_choice,
    participant_order,
    recorded_order_choice,
)
from nudgecli.sim.study import build_layouts, participant_schedule

OVERRIDES = TWO_TRIALS + DEFAULT_TABLES
#: Three conditions, the Williams square and its mirror (6 orders): the experiment of the report.
CUSTOM = str(Path(__file__).resolve().parents[1] / "experiments" / "custom-policy.toml")
#: P03's order by the design (order 3: the mirror of the first row), which P04 may be given.
MIRROR = ["threshold", "blending", "disambiguation"]


def _session(participant: str, out: Path, experiment: str = CUSTOM, **options):
    """Open ``participant``'s session (of the custom-policy study) and stop it (as Ctrl-C does)."""
    session = build_session(experiment, participant, out, overrides=OVERRIDES, **options)
    session.folder.release()
    return session


def _fingerprint(folder: Path) -> dict[str, str]:
    return {str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(folder.rglob("*")) if path.is_file() and not path.name.startswith(".nudge-")}


def _study(out: Path, *args: str, experiment: str = CUSTOM) -> str:
    """``nudge study EXPERIMENT --out OUT ARGS`` refused before serving: its one ``Error:`` line. It binds
    its port before the checks refuse: a free one (:func:`free_port`), not a fixed one another test may
    hold."""
    sets = itertools.chain.from_iterable(("--set", o) for o in OVERRIDES)
    result = CliRunner().invoke(main, ["study", experiment, "--out", str(out), "--port", str(free_port()),
                                       *args, *sets])
    assert result.exit_code == 1, result.output
    return one_error_line(result.output)


# --- 1: every order of the design, and only those ---------------------------------------------------

@pytest.mark.parametrize("design", DESIGNS)
@pytest.mark.parametrize("k", [2, 3, 4, 5])
def test_the_design_orders_are_exactly_the_orders_a_session_may_be_given(design, k):
    if design == "williams" and k % 2:
        pytest.skip("one Williams square balances an even count only")
    conditions = [f"c{i}" for i in range(k)]
    # the orders participants are assigned, by brute force over many indices
    assigned = {tuple(participant_order(conditions, design, i)) for i in range(4 * k)}
    for order in itertools.permutations(conditions):
        if order in assigned:
            assert check_design_order(conditions, design, order) == list(order)
            assert participant_order(conditions, design, 0, order) == list(order)
        else:
            with pytest.raises(ConfigError, match="is not one of the orders"):
                check_design_order(conditions, design, order)


def test_order_choice_names_only_an_order_the_design_would_not_assign_by_itself():
    conditions = ["a", "b", "c"]
    rows = condition_orders(3, "williams-pair")
    for participant in range(6):
        for row in rows:
            order = [conditions[c] for c in row]
            expected = None if row == rows[participant] else ",".join(order)
            assert order_choice(conditions, "williams-pair", participant, order) == expected


def test_an_order_a_manifest_records_is_named_only_when_a_resume_needs_it():
    experiment = {"study": {"conditions": ["disambiguation", "blending", "threshold"],
                            "counterbalancing": "williams-pair"}}
    assert recorded_order_choice(experiment, 3, MIRROR) is None  # P03's own order
    assert recorded_order_choice(experiment, 4, MIRROR) == ",".join(MIRROR)
    # a damaged manifest: the order as recorded (a resume with it is checked by the folder), or none
    damaged = {"study": {**experiment["study"], "counterbalancing": "latin"}}
    assert recorded_order_choice(damaged, 3, MIRROR) == ",".join(MIRROR)
    assert recorded_order_choice(experiment, 3, None) is None
    assert recorded_order_choice(["not", "a", "table"], 3, MIRROR) is None


def test_the_mirror_order_of_the_report_is_accepted_and_runs_the_blocks_in_that_order(tmp_path):
    config = load_experiment(CUSTOM, OVERRIDES)
    assert chosen_order(config, CUSTOM, ",".join(MIRROR)) == MIRROR
    layouts = build_layouts(config, 2022)
    schedule = participant_schedule(config, 2022, 4, layouts, condition_order=MIRROR)
    assert list(dict.fromkeys(spec.condition for spec in schedule)) == MIRROR
    _session("P03", tmp_path / "cp")  # P03's own order is the mirror
    session = _session("P04", tmp_path / "cp", condition_order=",".join(MIRROR))
    manifest = json.loads((tmp_path / "cp" / "manifest.json").read_text())
    assert manifest["live"]["3"]["condition_order"] == MIRROR == manifest["live"]["4"]["condition_order"]
    assert session.entry["condition_order"] == MIRROR


def _four_conditions() -> ExperimentConfig:
    return experiment_from_toml('[study]\nconditions = ["disambiguation", "control", "teleoperation", '
                                '"blending"]\ncounterbalancing = "williams"\n[blending]\ngate = "gap"\n')


def test_an_order_outside_the_design_is_refused_naming_the_design_orders_and_the_file():
    config = _four_conditions()
    rotation = "disambiguation,control,teleoperation,blending"  # a rotation, not a Williams row
    with pytest.raises(ConfigError) as refused:
        chosen_order(config, "four.toml", rotation)
    message = str(refused.value)
    assert "counterbalancing = 'williams'" in message and "four.toml" in message
    assert "disambiguation,control,blending,teleoperation" in message  # the design's first row


# --- 2: two IDs with one number -------------------------------------------------------------------

def test_another_id_of_a_recorded_index_is_told_whose_index_it_is_and_how_to_continue(tmp_path):
    out = tmp_path / "cp"
    _session("01", out)
    before = _fingerprint(out)
    for resume in ([], ["--resume"]):
        line = _study(out, "--participant", "P01", *resume)
        assert "index 1 belongs to participant 01, not P01" in line, line
        assert "--participant 01 --resume" in line and "add --resume" not in line, line
    assert _fingerprint(out) == before
    _session("01", out, resume=True)  # the advice works


# --- 3: the seed used in config.toml --------------------------------------------------------------

def test_config_toml_records_the_seed_used_and_resumes_with_it(tmp_path):
    out = tmp_path / "paper"
    _session("P01", out, seed=11, experiment="paper")
    recorded = tomllib.loads((out / "config.toml").read_text())
    manifest = json.loads((out / "manifest.json").read_text())
    assert recorded["experiment"]["seed"] == 11 == manifest["config"]["experiment"]["seed"]
    assert manifest["seed"] == 11
    # the folder's config.toml runs the same study without --seed, and the experiment with it
    assert _session("P01", out, resume=True, experiment=str(out / "config.toml")).seed == 11
    _session("P02", out, seed=11, experiment="paper")
    line = _study(out, "--participant", "P03", "--seed", "12", experiment="paper")
    assert "another experiment, --set or seed" in line, line


def test_a_folder_whose_config_toml_holds_the_experiments_own_seed_resumes_with_its_command(tmp_path, capsys):
    out = tmp_path / "paper"
    _session("P01", out, seed=11, experiment="paper")
    # as nudge study wrote it before: the experiment's own seed (2022), the manifest's seed 11
    own = load_experiment("paper", OVERRIDES)
    (out / "config.toml").write_text(own.to_toml())
    capsys.readouterr()
    _session("P01", out, seed=11, resume=True, experiment="paper")  # its printed command
    warning = capsys.readouterr().err
    said = f"held the experiment's own seed ({own.experiment.seed}), not the one the sessions use (11)"
    assert said in warning, warning
    assert tomllib.loads((out / "config.toml").read_text())["experiment"]["seed"] == 11
    # and the folder's config.toml with --seed 11, the hint's command for such a folder, still joins
    _session("P02", out, seed=11, experiment=str(out / "config.toml"))


# --- 4: the suggested commands carry the --condition-order a session needs ---------------------------

def test_a_session_started_with_another_order_is_continued_with_it(tmp_path):
    out = tmp_path / "cp"
    _session("P03", out)  # its own order
    _session("P04", out, condition_order=",".join(MIRROR))  # not P04's own order
    before = _fingerprint(out)
    line = _study(out, "--participant", "P04")
    assert "add --resume --condition-order threshold,blending,disambiguation" in line, line
    # first without a server: a wrong acceptance would fail here, not serve on the command line
    with pytest.raises(RunFolderError, match="resume with --condition-order threshold,blending,disambig"):
        _session("P04", out, resume=True)
    line = _study(out, "--participant", "P04", "--resume")
    assert "resume with --condition-order threshold,blending,disambiguation" in line, line
    line = _study(out, "--participant", "P03", "--resume",
                  "--condition-order", "disambiguation,blending,threshold")
    assert "resume without --condition-order" in line, line
    assert _fingerprint(out) == before
    manifest = json.loads((out / "manifest.json").read_text())
    for participant, flag in (("P04", ",".join(MIRROR)), ("P03", None)):
        hint = RunRecord(out).continue_session_hint(manifest, [int(participant[1:])])
        words = shlex.split(hint.split("`")[1])
        given = words[words.index("--condition-order") + 1] if "--condition-order" in words else None
        assert given == flag, hint
        # its options are accepted: they continue the session in the recorded order (the experiment
        # itself, as the folder's config.toml names a policy module that lies beside the experiment)
        session = build_session(CUSTOM, participant, out, condition_order=given, overrides=OVERRIDES,
                                seed=int(words[words.index("--seed") + 1]), resume=True)
        session.folder.release()
    both = RunRecord(out).continue_session_hint(manifest, [3, 4])
    assert "P04 with --condition-order threshold,blending,disambiguation" in both, both
