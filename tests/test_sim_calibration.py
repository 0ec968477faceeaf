"""Calibration: the study's estimators on real logs, simulated sessions, convergence, bad logs, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import CalibrationSection, InterfaceSection
from nudgecli.errors import DataError
from nudgecli.model.interface import (
    LABELS,
    default_distortion_table,
    distortion_table_from_dict,
    mapping_table_from_dict,
)
from nudgecli.model.world import MODE_NAMES
from nudgecli.rng import generator
from nudgecli.sim.calibration import (
    DISTORTION_SMOOTHING,
    MAX_REPEAT_ROUNDS,
    estimate_distortion,
    estimate_mapping,
    smooth_true_distortion,
    smooth_true_mapping,
)
from nudgecli.sim.calibration_io import (
    ACTION_IMAGES,
    MappingSession,
    distortion_session_frames,
    mapping_session_frames,
    write_sessions,
)
from nudgecli.sim.calibration_profile import fit_calibration_dir
from nudgecli.sim.calibration_readers import read_sessions
from nudgecli.sim.calibration_sessions import (
    fit_participant_tables,
    simulate_distortion_session,
    simulate_mapping_session,
)
from nudgecli.sim.participants import Participant, mapping_with_error

SHARED_CALIBRATION = Path(__file__).resolve().parents[2] / "shared" / "data" / "calibration"
needs_shared = pytest.mark.skipif(
    not SHARED_CALIBRATION.is_dir(),
    reason=f"the real pilot logs are not checked out beside the repository ({SHARED_CALIBRATION})")
BAD = Path(__file__).resolve().parent / "data" / "calibration_bad"
REFERENCE_MODES = {"1": "x", "2": "y", "3": "theta"}
INTERFACE = InterfaceSection(soft_threshold=0.3, hard_threshold=0.5)


def known_participant(error_rate: float = 0.2, ramp: int = 0) -> Participant:
    """Known physiology with visible confusions: Hard Puff at 0.6 +- 0.12 dips into the deadband,
    Soft Sip at 0.25 +- 0.08 crosses 0.3 a quarter of the time."""
    return Participant(
        index=0, seed_key="test/known", pressure_level=np.array([-0.6, 0.9, -0.12, 0.25]),
        pressure_spread=np.array([0.12, 0.1, 0.06, 0.08]), mapping=mapping_with_error(error_rate),
        epsilon=0.1, rest_s=0.5, operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0,
        reaction_log_sd=0.0, onset_ramp_samples=ramp, mapping_error=error_rate)


# --- the study's tables from its raw logs -------------------------------------------------------

def reference_cases() -> list[tuple[str, str]]:
    if not SHARED_CALIBRATION.is_dir():
        return [("missing", "missing")]
    names = sorted(p.name.removesuffix(".json") for p in (SHARED_CALIBRATION / "reference").glob("*.json"))
    return [(name.split(".", 1)[0], name.split(".", 1)[1]) for name in names]


@needs_shared
@pytest.mark.parametrize(("pilot", "table"), reference_cases())
def test_fitting_each_pilot_reproduces_the_reference_tables(pilot: str, table: str) -> None:
    reference = json.loads((SHARED_CALIBRATION / "reference" / f"{pilot}.{table}.json").read_text())["table"]
    profile = fit_calibration_dir(SHARED_CALIBRATION / pilot).profile
    if table == "p_phi_given_a":
        expected = mapping_table_from_dict({REFERENCE_MODES[k]: v for k, v in reference.items()})
        got = mapping_table_from_dict(profile["p_phi_given_a"])
    else:
        expected = distortion_table_from_dict(reference)
        got = distortion_table_from_dict(profile["p_phm_given_phi"])
    np.testing.assert_allclose(got, expected, atol=1e-6, rtol=0)


@needs_shared
def test_every_pilot_folder_has_a_reference_for_each_session_it_holds() -> None:
    references = {p.name.removesuffix(".json") for p in (SHARED_CALIBRATION / "reference").glob("*.json")}
    assert {"andrewtest.p_phi_given_a", "andrewtest.p_phm_given_phi", "deepak.p_phi_given_a",
            "deepaktest.p_phm_given_phi"} <= references


@needs_shared
def test_real_session_provenance_and_physiology() -> None:
    provenance = fit_calibration_dir(SHARED_CALIBRATION / "andrewtest").profile["provenance"]
    assert provenance["p_phi_given_a"]["prompts"] == 72
    assert provenance["p_phi_given_a"]["answers_missed"] == 0
    assert sum(provenance["p_phm_given_phi"]["prompts"].values()) == 60
    assert provenance["p_phm_given_phi"]["prompts_used"]["Soft Puff"] == 14  # one prompt had no input
    physiology = provenance["pressure_physiology"]
    assert physiology["level"]["Soft Sip"] == pytest.approx(0.22, abs=0.03)
    assert physiology["level"]["Hard Puff"] < -0.9
    assert provenance["needs_more_training"]["p_phm_given_phi"].keys() == {"Soft Sip"}


# --- the pairing rule of the mapping estimator ---------------------------------------------------

def mapping_session(prompts: list[tuple[float, str]], responses: list[tuple[float, int]]) -> MappingSession:
    return MappingSession(np.array([t for t, _ in prompts]), tuple(c for _, c in prompts),
                          np.array([t for t, _ in responses], dtype=float),
                          np.array([k - 1 for _, k in responses], dtype=int))


def test_mapping_pairing_rule_counts_and_misses() -> None:
    # 12 (shown, cleared) pairs = 24 rows -> 1 showing per action.
    cases = [
        (0.0, 10.0, "left"),    # response 8.0 nearest both moments -> the same response, counted
        (20.0, 30.0, "up"),     # nearest to shown 19.5 (before), to cleared 28.0 (before) -> 28.0 counted
        (40.0, 41.0, "right"),  # nearest to shown 40.2 (after), to cleared 41.1 (after) -> 40.2 counted
        (60.0, 70.0, "down"),   # nearest to shown 59.0 (before), to cleared 71.0 (after) -> no answer
    ]
    fill = [(100.0 + 2 * i, 101.0 + 2 * i, "clockwise") for i in range(8)]
    prompts = [(t, c) for shown, cleared, image in cases + fill for t, c in ((shown, image), (cleared, ""))]
    responses = [(8.0, 4), (19.5, 1), (28.0, 3), (40.2, 2), (41.1, 1), (59.0, 1), (71.0, 1)]
    estimate = estimate_mapping(mapping_session(prompts, responses))
    left, up, right, down = (ACTION_IMAGES.index(name) for name in ("left", "up", "right", "down"))
    assert estimate.counts[left].tolist() == [0, 0, 0, 1]
    assert estimate.counts[up].tolist() == [0, 0, 1, 0]
    assert estimate.counts[right].tolist() == [0, 1, 0, 0]
    assert estimate.counts[down].sum() == 0 and estimate.missed[down] == 1 and estimate.showings[down] == 0
    # "left" is x/move_n: count / 1 showing + 1e-4, renormalised
    assert estimate.table[0, 1, 3] == pytest.approx((1 + 1e-4) / (1 + 4e-4))
    # "down" (y/move_n) had no answer: its row keeps the default table
    assert "down" in estimate.unanswered
    np.testing.assert_allclose(estimate.table[1, 1], [0.05, 0.05, 0.05, 0.85])


# --- simulated sessions -----------------------------------------------------------------------------

def test_simulated_sessions_follow_the_protocol() -> None:
    participant = known_participant()
    calibration = CalibrationSection()
    mapping = simulate_mapping_session(participant, calibration, generator(1, "m"))
    assert len(mapping.prompt_commands) == 2 * 12 * calibration.mapping_blocks
    assert mapping.prompt_commands[1::2].count("hard_puff_training") == calibration.mapping_blocks - 1
    for block in range(calibration.mapping_blocks):
        assert len(set(mapping.prompt_commands[24 * block:24 * (block + 1):2])) == 12
    assert np.all(np.diff(mapping.prompt_times) >= 0) and np.all(np.diff(mapping.response_times) >= 0)
    distortion = simulate_distortion_session(participant, calibration, INTERFACE, generator(1, "d"))
    labels = distortion.prompt_labels
    assert len(labels) == 4 * calibration.prompts_per_label
    assert all(sorted(labels[4 * r:4 * r + 4]) == [0, 1, 2, 3] for r in range(calibration.prompts_per_label))
    np.testing.assert_allclose(np.diff(distortion.stream_times), 0.1)
    durations = np.diff(distortion.prompt_times)
    np.testing.assert_allclose(durations[0::2], calibration.prompt_s)
    np.testing.assert_allclose(durations[1::2], calibration.blank_s)
    # nothing is blown in the blanks or before the reaction delay
    in_blank = np.zeros(len(distortion.stream_times), dtype=bool)
    for start, end in zip(distortion.prompt_times[1::2], distortion.prompt_times[1::2] + calibration.blank_s,
                          strict=True):
        in_blank |= (distortion.stream_times >= start + 1e-9) & (distortion.stream_times < end - 1e-9)
    assert np.all(distortion.stream_pressure[in_blank] == 0)


def test_same_seed_same_logs_different_seed_different() -> None:
    participant = known_participant(ramp=2)
    calibration = CalibrationSection()

    def logs(seed: int) -> dict:
        fitted = fit_participant_tables(participant, calibration, INTERFACE, generator(seed, "calibration"))
        assert fitted.sessions is not None
        mapping, distortion = fitted.sessions
        return {**mapping_session_frames(mapping), **distortion_session_frames(distortion)}

    first, again, other = logs(3), logs(3), logs(4)
    for name, frame in first.items():
        assert frame.equals(again[name]), name
    assert not first["distortion_stream"].equals(other["distortion_stream"])
    assert not first["mapping_prompts"].equals(other["mapping_prompts"])


def test_tidy_logs_round_trip_and_fit_like_the_in_memory_sessions(tmp_path: Path) -> None:
    participant = known_participant(ramp=2)
    fitted = fit_participant_tables(participant, CalibrationSection(), INTERFACE, generator(5, "calibration"))
    assert fitted.sessions is not None
    written = write_sessions(tmp_path / "p07", *fitted.sessions)
    assert sorted(p.name for p in written) == ["distortion_prompts.csv", "distortion_stream.csv",
                                               "mapping_prompts.csv", "mapping_responses.csv"]
    mapping, distortion = read_sessions(tmp_path / "p07")
    assert mapping is not None and distortion is not None
    np.testing.assert_array_equal(distortion.stream_codes, fitted.sessions[1].stream_codes)
    np.testing.assert_allclose(estimate_mapping(mapping).table, fitted.mapping, atol=1e-12)
    np.testing.assert_allclose(estimate_distortion(distortion).table, fitted.distortion, atol=1e-12)
    profile = fit_calibration_dir(tmp_path / "p07").profile
    np.testing.assert_allclose(distortion_table_from_dict(profile["p_phm_given_phi"]), fitted.distortion,
                               atol=1e-12)


# --- convergence to the tables the physiology implies --------------------------------------------

@pytest.mark.parametrize("prompts_per_label", [12, 48, 192])
def test_fitted_distortion_converges_to_the_physiology(prompts_per_label: int) -> None:
    participant = known_participant()
    calibration = CalibrationSection(prompts_per_label=prompts_per_label)
    fitted = fit_participant_tables(participant, calibration, INTERFACE, generator(17, "calibration"))
    truth = smooth_true_distortion(participant.true_distortion(INTERFACE))
    # Each prompt blows ~(prompt_s - reaction_s) * 10 = 50 iid samples, so a row's mean of per-prompt
    # fractions is a binomial proportion over N_eff = prompts_per_label * 50 samples with standard error
    # sqrt(p (1 - p) / N_eff); smoothing divides it by (1 + 4 * 0.01). Allow 5 standard errors (p(1-p)
    # floored at 1/N_eff, so an entry that is 0 in truth may still see a sample) plus 1e-3 for the
    # ratio bias of the few no-input samples.
    n_eff = prompts_per_label * (calibration.prompt_s - participant.reaction_s) * calibration.rate_hz
    variance = np.maximum(truth * (1 - truth), 1 / n_eff)
    bound = 5 * np.sqrt(variance / n_eff) / (1 + 4 * DISTORTION_SMOOTHING) + 1e-3
    assert np.all(np.abs(fitted.distortion - truth) <= bound), (fitted.distortion - truth, bound)


def test_fitted_distortion_error_shrinks_with_more_prompts() -> None:
    participant = known_participant()
    truth = smooth_true_distortion(participant.true_distortion(INTERFACE))
    errors = []
    for prompts in (6, 200):
        fits = [fit_participant_tables(participant, CalibrationSection(prompts_per_label=prompts), INTERFACE,
                                       generator(seed, "calibration")).distortion for seed in range(4)]
        errors.append(np.mean([np.abs(f - truth).max() for f in fits]))
    # sqrt(200 / 6) = 5.8 times smaller in expectation; ask for 3
    assert errors[1] < errors[0] / 3


@pytest.mark.parametrize("blocks", [6, 60, 400])
def test_fitted_mapping_diagonal_converges_to_one_minus_error_rate(blocks: int) -> None:
    error_rate = 0.2
    participant = known_participant(error_rate=error_rate)
    calibration = CalibrationSection(mapping_blocks=blocks, prompts_per_label=1)
    fitted = fit_participant_tables(participant, calibration, INTERFACE, generator(23, "calibration"))
    truth = smooth_true_mapping(participant.mapping)
    # Each (mode, action) row is shown `blocks` times: a binomial proportion with standard error
    # sqrt(r (1 - r) / blocks) on its diagonal (0.163 / sqrt(blocks)), off-diagonals
    # sqrt(q (1 - q) / blocks) with q = r / 3. The mean diagonal pools 12 rows: sqrt(r (1 - r) / (12 blocks)).
    # Allow 5 standard errors (entries floored at 1/blocks so a 0 may see one answer).
    variance = np.maximum(truth * (1 - truth), 1 / blocks)
    assert np.all(np.abs(fitted.mapping - truth) <= 5 * np.sqrt(variance / blocks) + 1e-4)
    diagonal = fitted.mapping[:, np.arange(4), [2, 3, 0, 1]]
    pooled_se = np.sqrt(error_rate * (1 - error_rate) / (12 * blocks))
    assert abs(diagonal.mean() - (1 - error_rate)) <= 5 * pooled_se + 1e-3


def test_fit_participant_tables_reports_provenance() -> None:
    fitted = fit_participant_tables(known_participant(ramp=2), CalibrationSection(), INTERFACE,
                                    generator(1, "calibration"))
    assert fitted.mapping.shape == (3, 4, 4) and fitted.distortion.shape == (4, 4)
    np.testing.assert_allclose(fitted.mapping.sum(axis=-1), 1.0)
    np.testing.assert_allclose(fitted.distortion.sum(axis=-1), 1.0)
    provenance = fitted.provenance
    assert provenance["p_phi_given_a"]["prompts"] == 72
    assert sum(provenance["p_phm_given_phi"]["prompts"].values()) >= 48
    json.dumps(provenance)


# --- bad logs ---------------------------------------------------------------------------------------

BAD_CASES = {
    "missing_column": ("_action_prompt.csv", "missing column"),
    "unknown_label": ("_joy_sip_puff.csv: line 4", "unknown label 'Medium Sip'"),
    "time_backwards": ("_user_response.csv: line 3", "time runs backwards"),
    "no_prompts": ("_command_prompt.csv", "no prompts"),
    "empty_file": ("_user_response.csv", "empty"),
    "unknown_key": ("_user_response.csv: line 3", "unknown key '7'"),
    "missing_partner": ("_command_prompt.csv", "stream file is missing"),
    "no_session": ("no_session", "no calibration session found"),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_logs_fail_with_one_line_naming_file_and_row(case: str) -> None:
    where, what = BAD_CASES[case]
    with pytest.raises(DataError) as info:
        fit_calibration_dir(BAD / case)
    message = str(info.value)
    assert where in message and what in message
    assert "\n" not in message


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_cli_fit_bad_logs_exit_1_with_one_error_line(case: str, tmp_path: Path) -> None:
    result = CliRunner().invoke(main, ["fit", str(BAD / case), "--out", str(tmp_path / "p.json")])
    assert result.exit_code == 1
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: ") and BAD_CASES[case][1] in lines[0]
    assert not (tmp_path / "p.json").exists()


def test_cli_fit_missing_folder_is_an_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # without --out, fit checks it can write its working folder
    result = CliRunner().invoke(main, ["fit", str(tmp_path / "nobody")])
    assert result.exit_code == 1
    assert result.stderr.startswith("Error: ") and "no such folder" in result.stderr


def test_time_running_backwards_in_a_tidy_stream(tmp_path: Path) -> None:
    fitted = fit_participant_tables(known_participant(), CalibrationSection(prompts_per_label=1), INTERFACE,
                                    generator(1, "calibration"))
    assert fitted.sessions is not None
    write_sessions(tmp_path, None, fitted.sessions[1])
    stream = tmp_path / "distortion_stream.csv"
    lines = stream.read_text().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    stream.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"distortion_stream\.csv: line 7: time runs backwards"):
        fit_calibration_dir(tmp_path)


# --- `nudge fit` ------------------------------------------------------------------------------------

@needs_shared
def test_cli_fit_writes_the_profile_beside_the_caller(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, ["fit", str(SHARED_CALIBRATION / "andrewtest")])
    assert result.exit_code == 0, result.output
    target = tmp_path / "andrewtest.profile.json"
    assert result.stderr.strip().splitlines()[-1] == str(target)
    assert "Soft Sip -> Hard Sip 0.282" in result.stdout
    assert "Needs more training" in result.stdout
    profile = json.loads(target.read_text())
    assert list(profile["p_phi_given_a"]) == list(MODE_NAMES)
    assert list(profile["p_phi_given_a"]["x"]) == ["move_p", "move_n", "to_mode_r", "to_mode_l"]
    assert list(profile["p_phm_given_phi"]) == list(LABELS)
    assert list(profile["p_phm_given_phi"]["Soft Sip"]) == list(LABELS)
    mapping_table_from_dict(profile["p_phi_given_a"])
    distortion_table_from_dict(profile["p_phm_given_phi"])
    assert profile["provenance"]["pressure_physiology"]["level"]["Soft Sip"] > 0
    assert [p.name for p in tmp_path.iterdir()] == ["andrewtest.profile.json"]  # no temporary files left
    assert not (SHARED_CALIBRATION / "andrewtest" / "profile.json").exists()


@needs_shared
def test_cli_fit_missing_session_falls_back_with_a_warning(tmp_path: Path) -> None:
    out = tmp_path / "deepak.json"
    result = CliRunner().invoke(main, ["fit", str(SHARED_CALIBRATION / "deepak"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "Warning:" in result.stderr and "no p(phi_m | phi_i) session" in result.stderr
    profile = json.loads(out.read_text())
    np.testing.assert_allclose(distortion_table_from_dict(profile["p_phm_given_phi"]),
                               default_distortion_table())
    assert profile["provenance"]["p_phm_given_phi"]["source"].startswith("default")


def test_fitting_a_folder_of_participants_names_them(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    participants = tmp_path / "logs"
    for name in ("p01", "p02"):
        (participants / name / "p_phi_given_a").mkdir(parents=True)
    monkeypatch.chdir(tmp_path)  # without --out, fit checks it can write its working folder
    result = CliRunner().invoke(main, ["fit", str(participants)])
    assert result.exit_code == 1
    assert result.output.count("Error:") == 1 and "p01, p02" in result.output
    assert f"nudge fit {participants / 'p01'}" in result.output


def test_fitting_a_run_folder_names_its_participants_calibration_folders(tmp_path: Path) -> None:
    # before: the files a session needs, without a word of RUN/calibration/participant-NNNN, which holds them
    run = tmp_path / "run"
    (run / "trials").mkdir(parents=True)
    (run / "manifest.json").write_text("{}")

    def refused(folder: Path) -> str:
        result = CliRunner().invoke(main, ["fit", str(folder), "--out", str(tmp_path / "p.json")])
        assert result.exit_code == 1 and result.stderr.count("Error:") == 1, result.output
        return result.stderr.strip()

    assert "a run folder without calibration logs" in refused(run)
    for index in (0, 1):
        (run / "calibration" / f"participant-000{index}").mkdir(parents=True)
        (run / "calibration" / f"participant-000{index}" / "mapping_prompts.csv").write_text("t,action\n")
    calibration = run / "calibration"
    assert refused(run) == (
        f"Error: {run}: a run folder; its 2 participants' simulated calibration logs are in {calibration}/ "
        f"(participant-0000 to participant-0001); fit one at a time, e.g. "
        f"`nudge fit {calibration / 'participant-0000'}`")
    assert refused(calibration) == (
        f"Error: {calibration}: holds the calibration folders of several participants (participant-0000, "
        f"participant-0001); fit one at a time, e.g. `nudge fit {calibration / 'participant-0000'}`")
    assert not (tmp_path / "p.json").exists()


def test_a_distortion_blow_rises_through_the_participants_onset_ramp() -> None:
    # the ramp counts samples from each blow's start: (j + 1) / (k + 1) of the level for j < k
    steady = Participant(
        index=0, seed_key="test/steady", pressure_level=np.array([-0.6, 0.9, -0.12, 0.25]),
        pressure_spread=np.full(4, 1e-4), mapping=mapping_with_error(0.0), epsilon=0.0, rest_s=0.5,
        operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0, reaction_log_sd=0.0,
        onset_ramp_samples=3)
    session = simulate_distortion_session(steady, CalibrationSection(prompts_per_label=2), INTERFACE,
                                          generator(2, "ramp"))
    shown, cleared = session.prompt_times[0::2], session.prompt_times[1::2]
    for start, end, label in zip(shown, cleared, session.prompt_labels, strict=True):
        inside = (session.stream_times >= start) & (session.stream_times < end)
        blow = np.abs(session.stream_pressure[inside])
        blow = blow[blow > 0]
        level = abs(steady.pressure_level[label])
        assert len(blow) > 10
        np.testing.assert_allclose(blow[:5], level * np.array([0.25, 0.5, 0.75, 1.0, 1.0]), atol=1e-3)


def test_a_prompt_whose_blow_gets_no_sample_is_asked_again() -> None:
    # a reaction just short of the prompt's end leaves no sample in it: no input, so it is re-queued
    # (every round, up to MAX_REPEAT_ROUNDS); a prompt-long 1 s reaction is never repeated
    calibration = CalibrationSection(prompts_per_label=1)

    def late(reaction_s: float) -> Participant:
        return Participant(
            index=0, seed_key="test/late", pressure_level=np.array([-0.6, 0.9, -0.12, 0.25]),
            pressure_spread=np.full(4, 0.05), mapping=mapping_with_error(0.0), epsilon=0.0, rest_s=0.5,
            operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=reaction_s, reaction_log_sd=0.0)

    on_time = simulate_distortion_session(late(1.0), calibration, INTERFACE, generator(3, "late"))
    assert len(on_time.prompt_labels) == 4
    too_late = simulate_distortion_session(late(calibration.prompt_s - 1e-6), calibration, INTERFACE,
                                           generator(3, "late"))
    assert len(too_late.prompt_labels) == 4 * (1 + MAX_REPEAT_ROUNDS)
    assert not np.any(too_late.stream_pressure)
