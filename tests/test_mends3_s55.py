"""A manifest's seed edited by hand is told from an older nudge's run by what its parts record (the
resume it prints runs only for the older run), and further mends of input checks."""

from __future__ import annotations

import json
import shlex
import shutil
from pathlib import Path

import pytest
from cli_helpers import copy_run, nudge, one_error_line
from click.testing import CliRunner
from run_builders import with_seeds

from nudgecli.cli import main


def _run_printed(line: str) -> object:
    words = shlex.split(line.split("`")[1])
    assert words[0] == "nudge", line
    return nudge(*words[1:])


def test_a_hand_edited_seed_is_refused_and_prints_no_resume_that_would_run(tmp_path, analysed_smoke_run):
    # the manifest's seed edited to 4 (its experiment and its parts say 5): the parts tell it apart
    run = with_seeds(copy_run(analysed_smoke_run, tmp_path / "run"), seed=4)
    (run / "trials" / "part-0001.parquet").unlink()
    line = one_error_line(nudge("analyze", run).output)
    assert "needs a resume" in line and "put back the run's own manifest.json from a copy" in line
    assert "not made with seed 4" in line and "`" not in line  # no command printed
    resumed = nudge("simulate", run / "config.toml", "--out", run, "--seed", "4", "--participants", "2",
                    "--resume")  # the command printed before: refused now
    assert resumed.exit_code == 1
    assert "cannot resume with seed 4" in one_error_line(resumed.output)
    assert not (run / "trials" / "part-0001.parquet").exists()  # nothing of seed 4 simulated


def test_no_surviving_participants_part_refuses_the_resume(tmp_path, analysed_smoke_run):
    run = with_seeds(copy_run(analysed_smoke_run, tmp_path / "run"), experiment_seed=3)
    for index in (0, 1):
        (run / "participants" / f"part-{index:04d}.parquet").unlink()
    line = one_error_line(nudge("analyze", run).output)
    assert "no participants part survives" in line and "`" not in line
    resumed = nudge("simulate", run / "config.toml", "--out", run, "--seed", "5", "--participants", "2",
                    "--resume")
    assert resumed.exit_code == 1 and "cannot resume with seed 5" in one_error_line(resumed.output)


def test_an_older_runs_printed_resume_runs_and_rebuilds_the_part(tmp_path, analysed_smoke_run):
    # an older nudge's `--set experiment.seed=3 --seed 5`: its parts made with 5, as the manifest says
    run = with_seeds(copy_run(analysed_smoke_run, tmp_path / "run"), experiment_seed=3)
    part = "trials/part-0001.parquet"
    (run / part).unlink()
    line = one_error_line(nudge("analyze", run).output)
    assert "(--seed 5)" in line
    resumed = _run_printed(line)
    assert resumed.exit_code == 0, resumed.output  # type: ignore[attr-defined]
    assert (run / part).read_bytes() == (analysed_smoke_run / part).read_bytes()


# --- nudge fit's look-alike names: a folder's name by a folder, a file's by a .csv ---------------

CALIBRATION = Path("/work/shared/data/calibration")
needs_calibration = pytest.mark.skipif(not (CALIBRATION / "andrewtest").is_dir(),
                                       reason=f"the real pilot logs are not here ({CALIBRATION})")


def _fit_refused(*args: str) -> str:
    result = CliRunner().invoke(main, ["fit", *args])
    assert result.exit_code == 1, result.output
    return one_error_line(result.output)


@needs_calibration
def test_a_folder_of_session_json_files_is_told_no_session_not_to_rename_one() -> None:
    # before: "andrewtest.p_phi_given_a.json: ... rename it 'p_phi_given_a'" (a JSON file for a folder)
    line = _fit_refused(str(CALIBRATION / "reference"))
    assert "no calibration session found" in line and "rename" not in line


@needs_calibration
def test_a_notes_file_beside_a_session_is_no_look_alike(tmp_path: Path) -> None:
    # before: refused, "rename it 'distortion_prompts.csv'"; now the mapping session is fitted
    folder = tmp_path / "p1"
    shutil.copytree(CALIBRATION / "andrewtest" / "p_phi_given_a", folder / "p_phi_given_a")
    (folder / "distortion_notes.txt").write_text("the stream was not recorded\n")
    result = CliRunner().invoke(main, ["fit", str(folder), "--out", str(tmp_path / "profile.json")])
    assert result.exit_code == 0, result.output
    assert "no p(phi_m | phi_i) session; using the default table" in result.output


# --- a questionnaire export's harmless columns ---------------------------------------------------

ANSWERS = Path(__file__).parent / "data" / "questionnaires_two_conditions.csv"
METRICS = Path(__file__).parent / "data" / "metrics_two_conditions.csv"
EXPORT_COLUMNS = ("Timestamp", "notes", "Response ID", "age", "gender", "order")


def test_a_survey_exports_other_columns_are_noted_not_refused(tmp_path: Path) -> None:
    # before: "unknown column 'Timestamp'; rename it or remove it"
    from nudgecli.report.questionnaires import read_questionnaires

    exported = read_questionnaires(ANSWERS)
    for column in EXPORT_COLUMNS:
        exported[column] = "x"
    exported.to_csv(tmp_path / "export.csv", index=False)
    runner = CliRunner()
    plain = runner.invoke(main, ["analyze", str(METRICS), "--questionnaires", str(ANSWERS),
                                 "--out", str(tmp_path / "plain")])
    assert plain.exit_code == 0, plain.output
    result = runner.invoke(main, ["analyze", str(METRICS), "--questionnaires", str(tmp_path / "export.csv"),
                                  "--out", str(tmp_path / "export")])
    assert result.exit_code == 0, result.output
    notes = [line for line in result.output.splitlines() if "not read:" in line]
    assert len(notes) == 1 and notes[0].startswith("Note:")
    assert "not read: Timestamp, notes, Response ID, age, gender, order" in notes[0]
    name = "questionnaire_scores.csv"
    assert (tmp_path / "export" / name).read_bytes() == (tmp_path / "plain" / name).read_bytes()


def test_a_near_miss_of_a_questionnaire_column_is_still_refused(tmp_path: Path) -> None:
    from nudgecli.errors import DataError
    from nudgecli.report.questionnaires import questionnaire_scores, read_questionnaires

    path = tmp_path / "q.csv"
    path.write_text("participant,condition,likert_q4,likrt_Q3,Timestamp\n0,a,5,4,t\n0,b,6,3,t\n")
    with pytest.raises(DataError, match=r"unknown column 'likrt_Q3' \(did you mean 'likert_Q3'\?\)"):
        questionnaire_scores(read_questionnaires(path), str(path), [])


# --- a run's kept policy copy is checked only by the run's own command ----------------------------

def _run_with_kept_policy(tmp_path: Path) -> Path:
    """A run folder (made by hand) whose experiment imports its kept copy of policies/threshold.py,
    a finished participant recorded, and the copy's SHA-256 in its manifest."""
    import hashlib

    experiments = Path(__file__).resolve().parents[1] / "experiments"
    run = tmp_path / "run"
    shutil.copytree(experiments / "policies", run / "policies", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(experiments / "custom-policy.toml", run / "config.toml")
    module = run / "policies" / "threshold.py"
    (run / "manifest.json").write_text(json.dumps({
        "policy_files": {"policies/threshold.py": hashlib.sha256(module.read_bytes()).hexdigest()},
        "checksums": {"0": {}}}))
    with module.open("a") as copy:
        copy.write("# a comment added since the run kept it\n")
    return run


def test_a_runs_experiment_simulates_a_new_folder_though_its_kept_copy_changed(tmp_path):
    # before: refused, "changed since the run kept it ... resume ... or start again with --force"
    run = _run_with_kept_policy(tmp_path)
    made = nudge("simulate", run / "config.toml", "--participants", "2", "--out", tmp_path / "new",
                 "--set", "study.goal_counts=[3]", "--set", "study.corners=['tr']",
                 "--set", "study.start_modes=['x']", "--set", "study.blocks_per_condition=1",
                 "--set", "study.shared_layouts=1")
    assert made.exit_code == 0, made.output
    assert (tmp_path / "new" / "policies" / "threshold.py").read_bytes() == \
        (run / "policies" / "threshold.py").read_bytes()  # the new run keeps the code it imported


def test_a_runs_own_resume_still_names_its_changed_kept_copy(tmp_path):
    run = _run_with_kept_policy(tmp_path)
    resumed = nudge("simulate", run / "config.toml", "--out", run, "--participants", "2", "--resume")
    assert resumed.exit_code == 1
    assert "policies/threshold.py: changed since the run kept it" in one_error_line(resumed.output)
