"""A batch never writes over or removes one of its own inputs: a people, experiment or sweep file
named like one of its outputs is refused before any work, with one error line naming it."""

from __future__ import annotations

from pathlib import Path

import pytest
from batch_helpers import REPLICATE, an_old_batch, nudge
from cli_helpers import files_of, one_error_line
from people_helpers import PEOPLE_BYTES

from nudgecli.errors import WriteError
from nudgecli.runs.batch_folder import check_inputs_kept

# --- 2. no output replaces an input ------------------------------------------------------------


def refused_untouched(args: tuple[str, ...], out: Path, input_file: Path, label: str) -> None:
    """``nudge args`` is refused with one error line naming ``input_file`` and how it was given
    (``label``), before anything in ``out`` changed."""
    before = files_of(out)
    refused = nudge(*args)
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert f"{input_file} is this command's input ({label} {input_file})" in line, line
    assert files_of(out) == before


def test_a_people_file_named_like_an_output_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "pf"
    out.mkdir()
    people = out / "summary.csv"
    people.write_bytes(PEOPLE_BYTES)
    refused_untouched((*REPLICATE, "--people", str(people), "--out", str(out), "--force"), out, people,
                      "--people")
    assert people.read_bytes() == PEOPLE_BYTES


def test_an_input_a_replaced_batch_would_remove_is_refused(tmp_path: Path) -> None:
    # a replicate batch writes no power.csv, but replacing the power batch there removes it
    out = tmp_path / "pf"
    an_old_batch(out)
    people = out / "power.csv"
    people.write_bytes(PEOPLE_BYTES)
    refused_untouched((*REPLICATE, "--people", str(people), "--out", str(out), "--force"), out, people,
                      "--people")


def test_an_experiment_file_named_like_an_output_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "ef"
    out.mkdir()
    experiment = out / "summary.csv"
    experiment.write_text(Path("experiments/smoke.toml").read_text(encoding="utf-8"))
    refused_untouched(("replicate", str(experiment), "-R", "2", "--out", str(out), "--force"), out,
                      experiment, "EXPERIMENT")


def test_a_sweep_file_named_like_an_output_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "pf2"
    out.mkdir()
    sweep = out / "points.csv"
    sweep.write_text('experiment = "smoke"\nreplications = 1\nseed = 1\n[design]\nmethod = "grid"\n'
                     '[parameters]\n"inference.kappa" = [0.5, 0.6]\n')
    refused_untouched(("sweep", str(sweep), "--out", str(out), "--force"), out, sweep, "SWEEP_FILE")




def test_a_hard_link_to_an_input_is_the_input(tmp_path: Path) -> None:
    out = tmp_path / "pf"
    out.mkdir()
    people = out / "mine.csv"
    people.write_bytes(PEOPLE_BYTES)
    (out / "replications.csv").hardlink_to(people)
    refused = nudge(*REPLICATE, "--people", str(people), "--out", str(out), "--force")
    assert refused.exit_code == 1, refused.output
    line = one_error_line(refused.output)
    assert line.startswith(f"Error: {out / 'replications.csv'} is this command's input (--people {people})")
    assert people.read_bytes() == PEOPLE_BYTES


def test_the_experiment_a_sweep_file_names_beside_it_is_an_input(tmp_path: Path) -> None:
    out = tmp_path / "se"
    out.mkdir()
    experiment = out / "summary.csv"
    experiment.write_text(Path("experiments/smoke.toml").read_text(encoding="utf-8"))
    # an absolute path: the sweep file's experiment whichever folder a relative one is read from
    (out / "sweep.toml").write_text(f'experiment = "{experiment.as_posix()}"\nreplications = 1\n'
                                    'seed = 1\n[design]\nmethod = "grid"\n[parameters]\n'
                                    '"inference.kappa" = [0.5, 0.6]\n')
    refused_untouched(("sweep", str(out / "sweep.toml"), "--out", str(out), "--force"), out, experiment,
                      "the sweep file's experiment")


def test_power_refuses_a_people_file_named_like_its_table(tmp_path: Path) -> None:
    out = tmp_path / "pp"
    out.mkdir()
    people = out / "smallest_n.csv"
    people.write_bytes(PEOPLE_BYTES)
    refused_untouched(("power", "smoke", "--participants", "2,3", "-R", "2", "--people", str(people),
                       "--out", str(out), "--force"), out, people, "--people")


def test_an_input_among_the_parts_a_replaced_batch_removes_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "pa"
    an_old_batch(out)
    people = out / "analyses" / "people.csv"
    people.write_bytes(PEOPLE_BYTES)
    with pytest.raises(WriteError, match="is this command's input"):
        check_inputs_kept(out, [("--people", str(people)), ("EXPERIMENT", "smoke"), ("--plan", None)])
    check_inputs_kept(out, [("--people", str(tmp_path / "elsewhere.csv")), ("EXPERIMENT", "smoke")])
