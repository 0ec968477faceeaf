"""Calibration logs are read honestly: a stream in percent, a response log or stream on another
clock than its prompts, and a folder holding two sessions of one kind are refused with one
``Error:`` line; a response counted for more than one prompt is reported. Small hand-made logs,
and the pilots' logs where the rule is about them."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import nudge

from nudgecli.errors import DataError
from nudgecli.model.interface import HARD_SIP, NO_INPUT, SOFT_SIP
from nudgecli.sim.calibration import estimate_distortion, estimate_mapping
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    STUDY_FILES,
    STUDY_MAPPING_FOLDER,
    TIDY_FILES,
    DistortionSession,
    MappingSession,
    write_sessions,
)
from nudgecli.sim.calibration_profile import fit_calibration_dir
from nudgecli.sim.calibration_readers import read_distortion_session, read_mapping_session

SHARED_CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"
needs_pilots = pytest.mark.skipif(not SHARED_CALIBRATION.is_dir(),
                                  reason="the pilots' logs (../shared/data/calibration) are absent")


def one_showing_each(response_times: list[float]) -> MappingSession:
    """Each of the 12 images shown once, at 10 s intervals for 4 s; one Soft Sip answer per time."""
    shown = 10.0 * np.arange(len(ACTION_IMAGES))
    prompt_times = np.column_stack([shown, shown + 4.0]).ravel()
    commands = tuple(c for image in ACTION_IMAGES for c in (image, ""))
    times = np.array(response_times, dtype=float)
    return MappingSession(prompt_times, commands, times, np.full(len(times), 3),
                          {"prompts": "prompts.csv", "responses": "responses.csv"})


def soft_sip_session(stream_offset_s: float = 0.0, pressure: float = 0.2) -> DistortionSession:
    """Two Soft Sip prompts (0-4 s, 5-9 s) and a 10 Hz stream over 0-10 s, shifted by ``stream_offset_s``."""
    times = np.round(np.arange(0.0, 10.0, 0.1), 3) + stream_offset_s
    return DistortionSession(np.array([0.0, 4.0, 5.0, 9.0]), ("Soft Sip", "", "Soft Sip", ""), times,
                             np.full(len(times), SOFT_SIP), np.full(len(times), pressure),
                             {"prompts": "prompts.csv", "stream": "stream.csv"})


# --- pressures in [-1, 1] ---------------------------------------------------------------------

def test_a_stream_in_percent_is_refused_naming_file_and_line(tmp_path: Path) -> None:
    session = soft_sip_session()
    write_sessions(tmp_path, distortion=session)
    stream = tmp_path / TIDY_FILES["distortion_stream"]
    rows = stream.read_text().splitlines()
    rows[5] = rows[5].replace("0.2", "22.3")  # line 6: the axes column x100
    stream.write_text("\n".join(rows) + "\n")
    with pytest.raises(DataError) as caught:
        read_distortion_session(tmp_path)
    message = str(caught.value)
    assert message.startswith(f"{stream}: line 6: ") and "\n" not in message
    assert "pressure must lie in [-1, 1] (sip positive); is it in percent?" in message
    result = nudge("fit", tmp_path, "--out", tmp_path / "profile.json")
    assert result.exit_code == 1 and result.stderr.startswith("Error: ")
    assert "is it in percent" in result.stderr
    assert not (tmp_path / "profile.json").exists()


def test_full_scale_pressures_and_their_rounding_are_read(tmp_path: Path) -> None:
    write_sessions(tmp_path, distortion=soft_sip_session(pressure=-1.0000004))
    assert read_distortion_session(tmp_path).stream_pressure.min() == pytest.approx(-1.0000004)


# --- one clock for prompts and responses ------------------------------------------------------------

def test_responses_on_another_clock_are_refused() -> None:
    epoch = one_showing_each([1.637e9 + 10.0 * k for k in range(12)])
    clocks = r"responses\.csv: the prompt and response logs are on different clocks"
    with pytest.raises(DataError, match=clocks):
        estimate_mapping(epoch)


def test_responses_that_fall_inside_no_prompt_are_refused() -> None:
    between = one_showing_each([10.0 * k + 7.0 for k in range(11)])  # each in a gap between prompts
    with pytest.raises(DataError, match="no response falls inside any prompt"):
        estimate_mapping(between)


def test_a_stream_on_another_clock_is_refused() -> None:
    with pytest.raises(DataError, match=r"stream\.csv: the prompt and stream logs are on different clocks"):
        estimate_distortion(soft_sip_session(stream_offset_s=1.637e9))
    assert estimate_distortion(soft_sip_session()).table[SOFT_SIP, SOFT_SIP] > 0.9


def test_a_stream_sampled_only_between_prompts_is_refused() -> None:
    session = soft_sip_session()
    gap = (session.stream_times > 4.05) & (session.stream_times < 4.95)
    between = DistortionSession(session.prompt_times, session.prompt_commands, session.stream_times[gap],
                                np.full(int(gap.sum()), HARD_SIP), np.full(int(gap.sum()), 0.9),
                                session.files)
    with pytest.raises(DataError, match="no stream sample falls inside any prompt"):
        estimate_distortion(between)


def test_a_response_taken_by_a_prompt_without_its_own_is_reported() -> None:
    # the last prompt (110-114 s) got no answer: the study's rule gives it the previous one
    estimate = estimate_mapping(one_showing_each([10.0 * k + 2.0 for k in range(11)]))
    assert estimate.reused_responses == 1 and estimate.counts.sum() == 12
    assert estimate_mapping(one_showing_each([10.0 * k + 2.0 for k in range(12)])).reused_responses == 0


@needs_pilots
def test_the_epoch_clock_reproduction_is_refused_by_nudge_fit(tmp_path: Path) -> None:
    source = SHARED_CALIBRATION / "andrewtest" / STUDY_MAPPING_FOLDER
    target = tmp_path / "ep" / STUDY_MAPPING_FOLDER
    target.mkdir(parents=True)
    shutil.copy(source / STUDY_FILES["mapping_prompts"], target)
    with open(source / STUDY_FILES["mapping_responses"], newline="") as handle:
        rows = list(csv.reader(handle))
    with open(target / STUDY_FILES["mapping_responses"], "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(rows[0])
        writer.writerows([f"{int(r[4]) + int(r[5]) / 1e9:.9f}", *r[1:]] for r in rows[1:])
    result = nudge("fit", tmp_path / "ep", "--out", tmp_path / "ep.json")
    assert result.exit_code == 1, result.output
    assert result.stderr.count("\n") == 1
    assert "the prompt and response logs are on different clocks" in result.stderr
    assert not (tmp_path / "ep.json").exists()


@needs_pilots
@pytest.mark.parametrize("pilot", ["andrewtest", "deepak", "deepaktest"])
def test_the_pilots_logs_count_each_response_once(pilot: str) -> None:
    mapping = read_mapping_session(SHARED_CALIBRATION / pilot)
    estimate = estimate_mapping(mapping)
    assert estimate.reused_responses == 0 and estimate.counts.sum() == len(mapping.response_times)
    assert not [w for w in fit_calibration_dir(SHARED_CALIBRATION / pilot).warnings if "more than one" in w]


# --- one session of a kind per folder -----------------------------------------------------------

def _mapping() -> MappingSession:
    return one_showing_each([10.0 * k + 2.0 for k in range(12)])


def test_tidy_files_in_two_places_are_refused_naming_both(tmp_path: Path) -> None:
    write_sessions(tmp_path, mapping=_mapping())
    write_sessions(tmp_path / STUDY_MAPPING_FOLDER, mapping=_mapping())
    with pytest.raises(DataError) as caught:
        read_mapping_session(tmp_path)
    message = str(caught.value)
    assert message.startswith(f"{tmp_path}: holds 2 mapping sessions")
    assert str(tmp_path / TIDY_FILES["mapping_prompts"]) in message
    assert str(tmp_path / STUDY_MAPPING_FOLDER / TIDY_FILES["mapping_prompts"]) in message
    assert f"`nudge fit {tmp_path / STUDY_MAPPING_FOLDER}`" in message
    # the subfolder alone holds one
    assert read_mapping_session(tmp_path / STUDY_MAPPING_FOLDER) is not None


@needs_pilots
def test_a_study_export_beside_tidy_files_is_refused_by_nudge_fit(tmp_path: Path) -> None:
    shutil.copytree(SHARED_CALIBRATION / "deepak" / STUDY_MAPPING_FOLDER, tmp_path / STUDY_MAPPING_FOLDER)
    write_sessions(tmp_path / STUDY_MAPPING_FOLDER, mapping=_mapping())
    result = nudge("fit", tmp_path, "--out", tmp_path / "profile.json")
    assert result.exit_code == 1 and result.stderr.count("\n") == 1, result.output
    assert result.stderr.startswith(f"Error: {tmp_path}: holds 2 mapping sessions")
    folder = tmp_path / STUDY_MAPPING_FOLDER
    assert str(folder / STUDY_FILES["mapping_prompts"]) in result.stderr
    assert str(folder / TIDY_FILES["mapping_prompts"]) in result.stderr
    assert "move the files you do not mean to fit out of" in result.stderr


def test_two_sibling_study_folders_are_still_refused(tmp_path: Path) -> None:
    for participant in ("p01", "p02"):
        write_sessions(tmp_path / f"{participant}_p_ui_given_a", mapping=_mapping())
    with pytest.raises(DataError, match="several participants"):
        read_mapping_session(tmp_path)


def test_a_neutral_stream_during_the_prompts_is_on_their_clock() -> None:
    # a stream that is silent (neutral) during the prompts is on the prompts' clock: no error
    session = soft_sip_session()
    silent = DistortionSession(session.prompt_times, session.prompt_commands, session.stream_times,
                               np.full(len(session.stream_times), NO_INPUT), session.stream_pressure,
                               session.files)
    assert estimate_distortion(silent).rows_without_data


def test_an_event_driven_stream_may_end_a_quantisation_step_above_full_scale(tmp_path: Path) -> None:
    # the toolkit's simulated device tops out at 92 x 0.0109 = 1.0028 (logs already written read on)
    session = soft_sip_session(pressure=1.0028)
    codes = np.full(len(session.stream_times), HARD_SIP)
    codes[0] = NO_INPUT  # written as the sibling study's 'Zero Band': the event-driven variant
    event = DistortionSession(session.prompt_times, session.prompt_commands, session.stream_times, codes,
                              session.stream_pressure, variant="ciaa")
    write_sessions(tmp_path, distortion=event)
    assert read_distortion_session(tmp_path).stream_pressure.max() == pytest.approx(1.0028)
    write_sessions(tmp_path, distortion=soft_sip_session(pressure=1.0028))  # fixed-rate: refused
    with pytest.raises(DataError, match="is it in percent"):
        read_distortion_session(tmp_path)


def test_nudge_fit_warns_of_a_response_counted_twice(tmp_path: Path) -> None:
    write_sessions(tmp_path, mapping=one_showing_each([10.0 * k + 2.0 for k in range(11)]))
    warnings = fit_calibration_dir(tmp_path).warnings
    reused = "p(phi_i | a): 1 response(s) counted for more than one prompt"
    assert [w for w in warnings if w.startswith(reused)]
