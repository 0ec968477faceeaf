"""Configuration and input files whose misspelt or look-alike names were read without a word, or
refused without naming the name: a real log's optional columns (any case; a near miss refused),
... Each test was seen failing on the code before its fix."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import experiment_from_toml
from nudgecli.errors import ConfigError, DataError
from nudgecli.report.questionnaires import questionnaire_scores, read_questionnaires
from nudgecli.runs.batch_kinds import power
from nudgecli.runs.sweep import load_sweep
from nudgecli.sim.calibration_profile import fit_calibration_dir

PILOT = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / "pilot-1.csv"


def refused(*args: str) -> str:
    """The one error line of ``nudge ARGS``, which must exit 1 with nothing on stdout."""
    result = CliRunner().invoke(main, list(args))
    assert result.exit_code == 1 and result.stdout == "", result.output
    return one_error_line(result.stderr)


def pilot_with_header(tmp_path: Path, old: str, new: str) -> Path:
    """The pilot log with its header's ``old`` written ``new``."""
    header, rest = PILOT.read_text().split("\n", 1)
    columns = [new if c == old else c for c in header.split(",")]
    path = tmp_path / "log.csv"
    path.write_text(",".join(columns) + "\n" + rest)
    return path


# --- a real log's optional columns ---------------------------------------------------------------


def test_a_log_s_optional_columns_are_read_in_any_case(tmp_path: Path) -> None:
    # before: a header `Participant` made the file one participant named after the file (`log`)
    path = pilot_with_header(tmp_path, "participant", "Participant")
    path.write_text(path.read_text().replace("Participant,layout", "Participant,Layout"))
    result = CliRunner().invoke(main, ["habits", str(path)])
    expected = CliRunner().invoke(main, ["habits", str(PILOT)])
    assert result.exit_code == 0 and expected.exit_code == 0
    assert result.stdout.replace(str(path), "LOG") == expected.stdout.replace(str(PILOT), "LOG")


@pytest.mark.parametrize(("old", "new"), [("layout", "layuot"), ("participant", "particpant")])
def test_a_log_column_close_to_an_optional_one_is_refused(tmp_path: Path, old: str, new: str) -> None:
    # before: read without it, exit 0 (no stop -> switch; the file one participant)
    line = refused("habits", str(pilot_with_header(tmp_path, old, new)))
    assert f"column '{new}' is not a log column (did you mean '{old}'?)" in line


def test_a_misspelt_turn_column_is_refused(tmp_path: Path) -> None:
    # before: every row was the person's, the autonomy's motion counted as theirs
    path = pilot_with_header(tmp_path, "layout", "layout")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0] + ",trun"] + [line + ",human" for line in lines[1:]]) + "\n")
    assert "column 'trun' is not a log column (did you mean 'turn'?)" in refused("habits", str(path))


def test_an_optional_column_written_twice_is_refused(tmp_path: Path) -> None:
    path = pilot_with_header(tmp_path, "layout", "layout")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0] + ",Layout"] + [line + ",1" for line in lines[1:]]) + "\n")
    assert "the column 'layout' is written 2 times ('layout', 'Layout')" in refused("habits", str(path))


# --- a misspelt required key ---------------------------------------------------------------------

SWEEP = ('experiment = "smoke"\nreplications = 1\n[design]\nmethod = "grid"\n[parameters]\n'
         '"disambiguation.window" = [3, 5]\n')


@pytest.mark.parametrize(("old", "new", "named"), [
    ('experiment = "smoke"', 'experment = "smoke"', "unknown key 'experment' (did you mean 'experiment'?)"),
    ("[parameters]", "[parameter]", "unknown key 'parameter' (did you mean 'parameters'?)")])
def test_a_sweep_file_s_misspelt_required_key_is_named(tmp_path: Path, old: str, new: str,
                                                       named: str) -> None:
    # before: "experiment: Field required (and 1 more problem(s))", the key written never named
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.replace(old, new))
    with pytest.raises(ConfigError) as caught:
        load_sweep(str(path))
    assert named in str(caught.value)


def test_an_experiment_s_misspelt_required_key_is_named() -> None:

    text = (Path(__file__).resolve().parents[1] / "experiments" / "custom-policy.toml").read_text()
    assert "\nfactory = " in text
    with pytest.raises(ConfigError) as caught:
        experiment_from_toml(text.replace("\nfactory = ", "\nfactry = "), "custom.toml")
    assert "unknown key 'policies.threshold.factry' (did you mean 'factory'?)" in str(caught.value)


# --- a sweep file's parameter tables -------------------------------------------------------------


@pytest.mark.parametrize(("entry", "named"), [
    ("disambiguation.window = [3, 5]",
     'a dotted key must be quoted, e.g. "disambiguation.window" = [3, 5]'),
    ('"disambiguation.window" = { value = [3, 5] }', "unknown key 'value' (did you mean 'values'?)"),
    ('"disambiguation.window" = { low = 0.5, hgh = 0.8 }', "unknown key 'hgh' (did you mean 'high'?)")])
def test_a_parameter_s_unknown_key_is_named(tmp_path: Path, entry: str, named: str) -> None:
    # before: "a range needs low and high ..." of each, the key written never named
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.replace('"disambiguation.window" = [3, 5]', entry))
    with pytest.raises(ConfigError) as caught:
        load_sweep(str(path))
    assert named in str(caught.value) and "a range needs" not in str(caught.value)


# --- a questionnaire's columns -------------------------------------------------------------------


@pytest.mark.parametrize(("column", "named"), [
    ("likrt_Q3", "unknown column 'likrt_Q3' (did you mean 'likert_Q3'?)"),
    ("conditon", "unknown column 'conditon' (did you mean 'condition'?)")])
def test_a_questionnaire_column_of_no_kind_is_refused(tmp_path: Path, column: str, named: str) -> None:
    # before: dropped without a word (likrt_Q3's answers left out of the scores)
    path = tmp_path / "q.csv"
    path.write_text(f"participant,condition,likert_q4,{column}\n0,a,5,4\n0,b,6,3\n")
    with pytest.raises(DataError) as caught:
        questionnaire_scores(read_questionnaires(path), str(path))
    assert named in str(caught.value)


# --- a habits table with a misspelt column -------------------------------------------------------

HABITS_TABLE = ("scope,participant,habit,n,median,q25,q75,people_min,people_max\n"
                "participant,p1,pause_between_blows,20,0.4,0.3,0.6,,\n")


@pytest.mark.parametrize(("column", "misspelt"), [("median", "medain"), ("habit", "habbit")])
def test_a_habits_table_s_misspelt_column_is_named(tmp_path: Path, column: str, misspelt: str) -> None:
    # before: taken for a real log, "no t (or time), trial, label, ... column(s)"
    path = tmp_path / "habits.csv"
    path.write_text(HABITS_TABLE.replace(f",{column},", f",{misspelt},", 1))
    line = refused("fit-people", str(path), "--out", str(tmp_path / "people.csv"))
    assert f"no column {column!r} (is {misspelt!r} it, misspelt? rename it {column!r})" in line
    assert not (tmp_path / "people.csv").exists()


# --- comma-separated counts ----------------------------------------------------------------------


@pytest.mark.parametrize(("counts", "named"), [
    ("3,,4", "'3,,4': an empty item"), ("6,9,", "'6,9,': an empty item"), ("3,3", "'3,3': 3 is given twice")])
def test_power_s_empty_or_repeated_count_is_refused(tmp_path: Path, counts: str, named: str) -> None:
    # before: 3,,4 ran [3, 4] and 3,3 ran [3], without a word
    result = CliRunner().invoke(main, ["power", "smoke", "--participants", counts, "--replications", "1",
                                       "--out", str(tmp_path / "p")])
    assert result.exit_code == 2 and not (tmp_path / "p").exists()
    assert named in result.stderr and "each once" in result.stderr


def test_power_s_repeated_count_is_refused_in_python(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="3 is given twice"):
        power("smoke", [3, 3], 1, tmp_path / "p")
    assert not (tmp_path / "p").exists()


# --- a calibration folder's look-alike names -----------------------------------------------------

SHARED_CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"
needs_shared = pytest.mark.skipif(not SHARED_CALIBRATION.is_dir(),
                                  reason=f"the real pilot logs are not here ({SHARED_CALIBRATION})")


def calibration_copy(tmp_path: Path, mapping_folder: str = "p_phi_given_a", distortion: bool = True) -> Path:
    """andrewtest's calibration folder, its mapping session's folder named ``mapping_folder``."""
    folder = tmp_path / "p1"
    folder.mkdir()
    source = SHARED_CALIBRATION / "andrewtest"
    for session, name in (("p_phi_given_a", mapping_folder), ("p_phm_given_phi", "p_phm_given_phi")):
        if session == "p_phm_given_phi" and not distortion:
            continue
        (folder / name).mkdir()
        for log in (source / session).iterdir():
            (folder / name / log.name).write_bytes(log.read_bytes())
    return folder


@needs_shared
def test_a_session_folder_of_a_look_alike_name_is_refused(tmp_path: Path) -> None:
    # before: fitted with the default p(phi_i | a) table, "no p(phi_i | a) session"
    folder = calibration_copy(tmp_path, "p_phi_given_A")
    line = refused("fit", str(folder), "--out", str(tmp_path / "profile.json"))
    assert "p_phi_given_A: not read as the mapping session's 'p_phi_given_a'" in line
    assert not (tmp_path / "profile.json").exists()


@needs_shared
@pytest.mark.parametrize(("names", "named"), [
    (("distortion_prompts.CSV", "distortion_stream.CSV"), "not read as the distortion session's"),
    (("distortion_prompts.csv", "distortion_stream.CSV"),
     "('distortion_stream.CSV' is not read: rename it 'distortion_stream.csv')")])
def test_a_tidy_file_of_a_look_alike_name_is_refused(tmp_path: Path, names: tuple[str, str],
                                                     named: str) -> None:
    # before: the default p(phi_m | phi_i) table, or the stream said missing without its look-alike
    folder = calibration_copy(tmp_path, distortion=False)
    for name in names:
        (folder / name).write_text("t,command\n")
    assert named in refused("fit", str(folder), "--out", str(tmp_path / "profile.json"))


@needs_shared
def test_a_real_folder_with_one_session_still_falls_back() -> None:
    warnings = fit_calibration_dir(SHARED_CALIBRATION / "deepak").warnings
    assert any("no p(phi_m | phi_i) session; using the default table" in w for w in warnings)
