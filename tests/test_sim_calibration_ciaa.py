"""`nudge fit` on the sibling study's prompt-and-produce logs (issue 14, part 4).

The logs are written by the tests in the study's export format (quoted labels, ``rosbagTimestamp``):
an event-driven stream whose neutral label is "Zero Band", "input stopped" once per blow, silence
while the pressure is steady, prompts 4 s + 1 s blank, and a prompt that got no message shown
again at the end. Every expected number below is counted by hand from the stream listed in
``STREAM`` (the window rule of DESIGN.md section 2.9: from the message nearest the prompt to the
one nearest its blank, excluded).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.errors import DataError
from nudgecli.model.interface import LABELS
from nudgecli.sim.calibration import estimate_distortion
from nudgecli.sim.calibration_io import requeue_consistent, silent_prompts
from nudgecli.sim.calibration_profile import fit_calibration_dir
from nudgecli.sim.calibration_readers import detect_variant, read_distortion_session

# (shown, label); each prompt is shown 4 s then blank 1 s. Prompt 2 gets no message at all, so the
# protocol shows it again at the end (prompt 4).
PROMPTS = [(0.0, "Soft Puff"), (5.0, "Hard Sip"), (10.0, "Soft Sip"), (15.0, "Hard Puff"), (20.0, "Soft Sip")]
PROMPT_S = 4.0

# (time, label, pressure): the event-driven stream (messages only while the pressure changes).
STREAM = [
    # prompt 0, Soft Puff: three soft messages, steady (silent) until 3.0, a slip into the deadband
    (1.000, "Soft Puff", -0.011), (1.004, "Soft Puff", -0.022), (1.008, "Soft Puff", -0.033),
    (3.000, "Soft-Hard Puff Deadband", -0.35), (3.004, "Soft Puff", -0.10),
    (3.500, "Zero Band", 0.0), (3.5001, "input stopped", 0.0),
    # prompt 1, Hard Sip: ramp up through soft and deadband, saturated (silent), ramp down
    (6.000, "Soft Sip", 0.2), (6.004, "Soft-Hard Sip Deadband", 0.4), (6.008, "Hard Sip", 0.7),
    (6.012, "Hard Sip", 1.0), (8.000, "Hard Sip", 0.8), (8.004, "Soft-Hard Sip Deadband", 0.4),
    (8.008, "Soft Sip", 0.1), (8.012, "Zero Band", 0.0), (8.0121, "input stopped", 0.0),
    # prompt 2, Soft Sip: nothing at all (silent, re-queued)
    # prompt 3, Hard Puff
    (16.000, "Soft Puff", -0.2), (16.004, "Soft-Hard Puff Deadband", -0.4), (16.008, "Hard Puff", -0.9),
    (16.012, "Hard Puff", -1.0), (17.500, "Hard Puff", -0.95), (17.504, "Soft-Hard Puff Deadband", -0.45),
    (17.508, "Soft Puff", -0.2), (17.512, "Zero Band", 0.0), (17.5121, "input stopped", 0.0),
    # prompt 4, Soft Sip (the repeat of prompt 2)
    (21.000, "Soft Sip", 0.05), (21.004, "Soft Sip", 0.1), (21.008, "Soft Sip", 0.15),
    (22.000, "Soft-Hard Sip Deadband", 0.32), (22.004, "Soft Sip", 0.2),
    (23.000, "Zero Band", 0.0), (23.0001, "input stopped", 0.0),
]

# Hand counts per prompt window, codes [Hard Puff, Hard Sip, Soft Puff, Soft Sip, puff dead, sip dead]:
#   prompt 0: window = messages 0..5 (nearest to 0.0 is 1.000; nearest to 4.0 is 3.5001, excluded):
#             Soft Puff x4, puff deadband x1 (Zero Band ignored)            -> 5 counted
#   prompt 1: nearest to 5.0 is 6.000 (1.0 away, 3.5001 is 1.4999); nearest to 9.0 is 8.0121:
#             Soft Sip x2, sip deadband x2, Hard Sip x3                     -> 7 counted
#   prompt 2: nearest to 10.0 is 8.0121, nearest to 14.0 is 16.000: window = "input stopped" only
#                                                                           -> 0 counted (unused)
#   prompt 3: nearest to 15.0 is 16.000; nearest to 19.0 is 17.5121 (1.4879 vs 21.0's 2.0):
#             Soft Puff x2, puff deadband x2, Hard Puff x3                  -> 7 counted
#   prompt 4: nearest to 20.0 is 21.000; nearest to 24.0 is 23.0001 (the last message):
#             Soft Sip x4, sip deadband x1                                  -> 5 counted
# Rows (deadbands into hard, +0.01, /1.04), columns Hard Puff, Hard Sip, Soft Puff, Soft Sip:
EXPECTED = np.array([
    [5 / 7 + 0.01, 0.01, 2 / 7 + 0.01, 0.01],   # Hard Puff: (3 + 2 deadband) / 7, soft 2 / 7
    [0.01, 5 / 7 + 0.01, 0.01, 2 / 7 + 0.01],   # Hard Sip:  (3 + 2 deadband) / 7, soft 2 / 7
    [0.2 + 0.01, 0.01, 0.8 + 0.01, 0.01],       # Soft Puff: deadband 1 / 5 -> Hard Puff, 4 / 5
    [0.01, 0.2 + 0.01, 0.01, 0.8 + 0.01],       # Soft Sip (prompt 4 only): 1 / 5, 4 / 5
]) / 1.04


def _q(text: str) -> str:
    """A label quoted the way the study's export wrote it (``\"\"\"Soft Sip\"\"\"``)."""
    return f'"""{text}"""' if text else "''"


def write_ciaa_session(folder: Path, prompts=PROMPTS, stream=STREAM, extra_files: bool = True) -> Path:
    """Write a sibling-study session (``_command_prompt.csv``, ``_joy_sip_puff.csv``) into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = ["rosbagTimestamp,header,seq,stamp,secs,nsecs,frame_id,command"]
    for seq, (shown, label) in enumerate(prompts):
        rows.append(f"{shown!r},,{2 * seq + 1},,0,0,'',{_q(label)}")
        rows.append(f"{shown + PROMPT_S!r},,{2 * seq + 2},,0,0,'',''")
    (folder / "_command_prompt.csv").write_text("\n".join(rows) + "\n")
    rows = ["rosbagTimestamp,header,seq,stamp,secs,nsecs,frame_id,axes,buttons"]
    for seq, (t, label, pressure) in enumerate(stream):
        rows.append(f'{t!r},,{seq + 1},,0,0,{_q(label)},[{pressure!r}],"[0, 0, 0, 0]"')
    (folder / "_joy_sip_puff.csv").write_text("\n".join(rows) + "\n")
    if extra_files:  # present in the study's folders, never read: make them unreadable as logs
        (folder / "_keyboard_entry.csv").write_text("rosbagTimestamp,data\n0.5,'s'\nnot,a,log\n")
        (folder / "_mode_switches.csv").write_text("garbage\x00\n")
    return folder


def test_event_driven_log_fits_the_hand_counted_table(tmp_path: Path) -> None:
    folder = write_ciaa_session(tmp_path / "007_p_um_given_ui")
    session = read_distortion_session(folder)
    assert session is not None and session.variant == "ciaa" and session.event_driven
    estimate = estimate_distortion(session)
    np.testing.assert_allclose(estimate.table, EXPECTED, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(estimate.prompts, [1, 1, 1, 2])
    np.testing.assert_array_equal(estimate.prompts_used, [1, 1, 1, 1])
    np.testing.assert_array_equal(estimate.counted_samples, [7, 7, 5, 5])


def test_the_silent_prompt_is_found_and_its_repeat_checked(tmp_path: Path) -> None:
    session = read_distortion_session(write_ciaa_session(tmp_path / "s"))
    assert session is not None
    np.testing.assert_array_equal(silent_prompts(session), [False, False, True, False, False])
    assert requeue_consistent(session)
    # the session cut short before the repeat: the rule is broken, and Soft Sip has no data
    cut = read_distortion_session(write_ciaa_session(tmp_path / "cut", PROMPTS[:4], STREAM[:25]))
    assert cut is not None
    assert not requeue_consistent(cut)
    profile = fit_calibration_dir(tmp_path / "cut")
    assert any("not end with their repeats" in w for w in profile.warnings)
    assert any("no counted input for Soft Sip" in w for w in profile.warnings)
    # a repeat of the wrong label does not satisfy the rule
    wrong = [*PROMPTS[:4], (20.0, "Soft Puff")]
    relabelled = read_distortion_session(write_ciaa_session(tmp_path / "wrong", wrong))
    assert relabelled is not None and not requeue_consistent(relabelled)


def test_a_prompt_with_only_a_zero_band_message_is_not_silent(tmp_path: Path) -> None:
    # the study re-queued on "no stream message at all": a lone Zero Band message counts as one
    stream = [*STREAM[:16], (11.0, "Zero Band", 0.0), *STREAM[16:]]
    session = read_distortion_session(write_ciaa_session(tmp_path / "z", stream=stream))
    assert session is not None
    np.testing.assert_array_equal(silent_prompts(session), [False] * 5)
    assert not requeue_consistent(session)  # 5 prompts, none silent: Soft Sip shown twice unexplained


def test_fit_of_a_participant_folder_in_the_study_layout(tmp_path: Path) -> None:
    write_ciaa_session(tmp_path / "007" / "007_p_um_given_ui")
    profile = fit_calibration_dir(tmp_path / "007")
    table = profile.profile["p_phm_given_phi"]
    got = np.array([[table[i][m] for m in LABELS] for i in LABELS])
    np.testing.assert_allclose(got, EXPECTED, atol=1e-12)
    info = profile.profile["provenance"]["p_phm_given_phi"]
    assert info["variant"] == "ciaa" and info["prompts_without_input"] == 1 and info["requeue_consistent"]
    assert profile.profile["provenance"]["pressure_physiology"] is None
    assert "counted messages" in profile.summary and "event-driven" in profile.summary
    assert not any("repeats" in w for w in profile.warnings)


def test_variant_detection_and_its_errors(tmp_path: Path) -> None:
    labels = [label for _, label, _ in STREAM]
    times = np.array([t for t, _, _ in STREAM])
    assert detect_variant(labels, times, "s") == "ciaa"
    assert detect_variant(labels, times, "s", requested="ciaa") == "ciaa"
    with pytest.raises(DataError, match=r"line 7: label 'Zero Band' belongs to the 'ciaa'.*--variant ciaa"):
        detect_variant(labels, times, "s", requested="pilot")
    pilot = ["None" if label == "Zero Band" else label for label in labels]
    assert detect_variant(pilot, times, "s") == "pilot"
    with pytest.raises(DataError, match="use --variant pilot"):
        detect_variant(pilot, times, "s", requested="ciaa")
    mixed = [*labels[:6], "None", *labels[7:]]  # "input stopped" at line 8 replaced
    with pytest.raises(DataError, match=r"mixes .*'None' \(line 8\).*'Zero Band' \(line 7\)"):
        detect_variant(mixed, times, "s")
    # without a neutral label, the timing decides: messages 4 ms apart vs a 10 Hz stream
    blows = [label for label in labels if label not in ("Zero Band", "input stopped")]
    assert detect_variant(blows, np.arange(len(blows)) * 0.004, "s") == "ciaa"
    assert detect_variant(blows, np.arange(len(blows)) * 0.1, "s") == "pilot"
    with pytest.raises(DataError, match="unknown log variant 'ros'"):
        detect_variant(labels, times, "s", requested="ros")


def test_an_unknown_label_in_a_ciaa_stream_lists_the_ciaa_labels(tmp_path: Path) -> None:
    stream = [*STREAM[:3], (1.01, "Medium Puff", -0.4), *STREAM[3:]]
    expected = r"line 5: unknown label 'Medium Puff'; stream labels are .*Zero Band"
    with pytest.raises(DataError, match=expected) as err:
        read_distortion_session(write_ciaa_session(tmp_path / "u", stream=stream))
    assert "None" not in str(err.value).split("stream labels are")[1]


def test_cli_fit_variant_option(tmp_path: Path) -> None:
    folder = write_ciaa_session(tmp_path / "007_p_um_given_ui")
    runner = CliRunner()
    result = runner.invoke(main, ["fit", str(folder), "--out", str(tmp_path / "p.json")])
    assert result.exit_code == 0, result.output
    assert "counted messages" in result.stdout and (tmp_path / "p.json").is_file()
    result = runner.invoke(main, ["fit", str(folder), "--variant", "pilot",
                                  "--out", str(tmp_path / "q.json")])
    assert result.exit_code == 1
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("Error: ")
    assert "--variant ciaa" in result.stderr and not (tmp_path / "q.json").exists()
    result = runner.invoke(main, ["fit", str(folder), "--variant", "rosbag"])
    assert result.exit_code == 2


def test_a_folder_of_several_sibling_participants_is_refused(tmp_path: Path) -> None:
    for participant in ("001", "002"):
        write_ciaa_session(tmp_path / f"{participant}_p_um_given_ui")
    with pytest.raises(DataError, match=r"several participants \(001_p_um_given_ui, 002_p_um_given_ui\)"):
        fit_calibration_dir(tmp_path)
