"""The live person's input source and calibration recorders (no server, no browser)."""

from __future__ import annotations

import numpy as np
import pytest

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError
from nudgecli.live.calibration import DistortionRecorder, MappingRecorder
from nudgecli.live.input import KEY_LABELS, LiveInput, key_pressures
from nudgecli.live.session import participant_index
from nudgecli.model.interface import (
    HARD_PUFF,
    HARD_SIP,
    LABELS,
    NO_INPUT,
    SOFT_PUFF,
    SOFT_SIP,
    label_of_pressure,
)
from nudgecli.sim.calibration import estimate_distortion, estimate_mapping
from nudgecli.sim.calibration_io import write_sessions
from nudgecli.sim.calibration_readers import read_sessions


@pytest.fixture(scope="module")
def config():
    return load_experiment("paper", ("calibration.mapping_blocks=2", "calibration.prompts_per_label=2"))


def test_keys_are_the_study_answer_keys_and_their_pressures_fall_in_their_bands(config):
    assert KEY_LABELS == {"1": HARD_PUFF, "2": HARD_SIP, "3": SOFT_PUFF, "4": SOFT_SIP}
    i = config.interface
    pressures = key_pressures(i)
    # paper preset bands: soft up to 0.3, hard above 0.5 (DESIGN 2.2): 0.151 and 0.75, puffs negative
    assert np.allclose(pressures, [-0.75, 0.75, -0.151, 0.151])
    for label, p in enumerate(pressures):
        assert label_of_pressure(p, i.soft_threshold, i.hard_threshold, i.zero_threshold) == label


def test_held_keys_repeat_and_short_presses_give_one_sample(config):
    source = LiveInput.from_interface(config.interface)
    p = key_pressures(config.interface)
    source.key(SOFT_PUFF, True)
    assert [source.sample() for _ in range(3)] == [(SOFT_PUFF, p[SOFT_PUFF])] * 3  # holding keeps moving
    source.key(HARD_PUFF, True)  # pressed while the soft key is down: the last pressed counts
    assert source.sample() == (HARD_PUFF, p[HARD_PUFF])
    source.key(HARD_PUFF, False)
    assert source.sample() == (SOFT_PUFF, p[SOFT_PUFF])
    source.key(SOFT_PUFF, False)
    assert source.sample() == (NO_INPUT, 0.0)  # key-up ends the blow
    source.key(HARD_SIP, True)
    source.key(HARD_SIP, False)  # down and up between two samples
    assert source.sample() == (HARD_SIP, p[HARD_SIP])
    assert source.sample() == (NO_INPUT, 0.0)


def test_the_gamepad_axis_is_raw_pressure_without_an_intended_label(config):
    source = LiveInput.from_interface(config.interface)
    source.axis(-0.42)
    assert source.sample() == (NO_INPUT, -0.42)
    source.axis(3.0)
    assert source.sample() == (NO_INPUT, 1.0)
    source.axis(0.001)  # below the no-input threshold (0.002)
    assert source.sample() == (NO_INPUT, 0.0)
    source.axis(0.2)
    source.key(SOFT_SIP, True)  # a key down takes precedence
    assert source.sample()[0] == SOFT_SIP
    source.key(SOFT_SIP, False)
    assert source.sample() == (NO_INPUT, 0.2)


def test_participant_ids_give_their_number():
    assert participant_index("P01") == 1 and participant_index("7") == 7 and participant_index("p_12") == 12
    assert participant_index("P9999") == 9999 and participant_index("x" * 28 + "0001") == 1
    # IDs that would map to a surprising number are refused with the rule, in one line
    for odd in ("alice", "P00", "P-1", "1" * 20, "5" * 5000, "P10000", "P1a", "x" * 29 + "0001", "P 1"):
        rule = r"ending in the participant's number: ASCII letters .* 1 to 9999 in the digits 0-9"
        with pytest.raises(ConfigError, match=rule) as err:
            participant_index(odd)
        assert "\n" not in str(err.value) and len(str(err.value)) < 300


def test_participant_ids_are_ascii_and_have_no_spaces_around_them():
    """Python's ``int`` and ``\\d`` read Arabic-Indic and fullwidth digits (and other scripts'
    letters pass ``isalpha``): such IDs are refused, as are spaces around an ID, never stripped."""
    for odd in ("P\u0661", "P\u0660\u0661", "\u0661\u0662", "P\uff11", "\uff10\uff11", "P\u09e7",
                "\u00c9\u00c901", "\u0410\u041101", " P01", "P01 ", "\tP01", "P01\n", "P01\u00a0"):
        with pytest.raises(ConfigError, match="ASCII letters"):
            participant_index(odd)
    assert participant_index("P01") == 1  # the same ID without them


def _run_mapping(recorder: MappingRecorder, answer, delay: float = 0.35) -> None:
    now, due = 0.0, None
    while not recorder.done:
        now = round(now + 0.1, 9)
        if due is not None and now >= due:
            recorder.answer(answer(recorder.prompt), now)
            due = None
        recorder.tick(now)
        if recorder.prompt is not None and due is None and recorder.answered_at is None:
            due = now + delay


def test_mapping_recorder_logs_what_the_estimator_of_nudge_fit_reads(config, tmp_path):
    recorder = MappingRecorder.create(config.calibration, np.random.default_rng(1), "test")
    truth = {
        "up": SOFT_PUFF,
        "right": SOFT_PUFF,
        "clockwise": SOFT_PUFF,
        "down": SOFT_SIP,
        "left": SOFT_SIP,
        "counterclockwise": SOFT_SIP,
    }

    def answer(image):
        if image.startswith("mode_switch_right"):
            return HARD_PUFF
        if image.startswith("mode_switch_left"):
            return HARD_SIP if image != "mode_switch_left_2" else SOFT_SIP  # one habitual confusion
        return truth[image]

    _run_mapping(recorder, answer)
    session = recorder.session()
    assert len(session.prompt_commands) == 2 * 2 * 12 and session.prompt_commands[23] == "hard_puff_training"
    write_sessions(tmp_path, mapping=session)
    read, _ = read_sessions(tmp_path)
    table = estimate_mapping(read).table
    # every answer counted: rows are one-hot + 1e-4, renormalised (DESIGN 2.9): 1.0001 / 1.0004
    assert table[1, 3, SOFT_SIP] == pytest.approx(1.0001 / 1.0004)  # mode y, to_mode_l answered Soft Sip
    assert table[0, 0, SOFT_PUFF] == pytest.approx(1.0001 / 1.0004)
    assert table[2, 2, HARD_PUFF] == pytest.approx(1.0001 / 1.0004)


def test_unanswered_prompts_time_out_and_count_as_missed(config):
    recorder = MappingRecorder.create(config.calibration, np.random.default_rng(2), "test")
    now = 0.0
    while not recorder.done:
        now = round(now + 0.1, 9)
        recorder.tick(now)
    shown = np.array(recorder.prompt_times[0::2])
    cleared = np.array(recorder.prompt_times[1::2])
    assert np.allclose(cleared - shown, config.calibration.answer_timeout_s, atol=0.11)
    assert recorder.response_times == []


def test_distortion_recorder_repeats_a_prompt_without_input_and_fits_the_study_table(config, tmp_path):
    recorder = DistortionRecorder.create(
        config.calibration, config.interface, np.random.default_rng(3), "test"
    )
    pressures = key_pressures(config.interface)
    first = recorder.labels[0]
    now, skipped = 0.0, False
    while not recorder.done:
        now = round(now + 0.1, 9)
        prompt = recorder.prompt
        if prompt is not None and recorder.index == 0 and not skipped:
            pressure = 0.0  # the person misses the first prompt
        else:
            pressure = float(pressures[LABELS.index(prompt)]) if prompt else 0.0
        recorder.sample(now, pressure)
        skipped = skipped or recorder.index > 0
    assert len(recorder.labels) == 4 * 2 + 1 and recorder.labels[-1] == first
    write_sessions(tmp_path, distortion=recorder.session())
    _, read = read_sessions(tmp_path)
    table = estimate_distortion(read).table
    # each counted prompt is all its own label: (1 + 0.01) / (1 + 4 x 0.01) on the diagonal (DESIGN 2.9)
    assert np.allclose(table, (np.eye(4) + 0.01) / 1.04)


def test_questionnaire_rows_are_checked_against_the_analysis_format():
    from live_helpers import ANSWERS

    from nudgecli.live.questionnaire import questionnaire_form, questionnaire_row
    from nudgecli.report.questionnaires import TLX_RATING_COLUMNS

    form = questionnaire_form()
    assert [item["name"] for item in form["tlx"]] == list(TLX_RATING_COLUMNS)
    assert [item["name"] for item in form["likert"]] == ["likert_q3", "likert_q4", "likert_q7", "likert_q10"]
    assert questionnaire_row(ANSWERS) == ANSWERS
    assert "performance" in questionnaire_row({**ANSWERS, "tlx_performance": 101})
    assert "every statement" in questionnaire_row({**ANSWERS, "likert_q7": None})
    assert "every statement" in questionnaire_row({**ANSWERS, "likert_q7": 4.5})


def test_a_session_refuses_an_incomplete_questionnaire_and_records_a_complete_one(tmp_path):
    from live_helpers import ANSWERS, DEFAULT_TABLES, TWO_TRIALS

    from nudgecli.live.app import build_session
    from nudgecli.report.questionnaires import questionnaire_scores, read_questionnaires

    session = build_session("paper", "P04", tmp_path, overrides=TWO_TRIALS + DEFAULT_TABLES)
    for message in ({"type": "start"}, {"type": "skip"}, {"type": "start"}):
        session.handle(message, 0.0)
    assert session.phase == "trial"
    while session.phase == "trial":
        session.tick(0.0)  # no input at all: the trial runs to its time limit
    assert session.phase == "questionnaire"
    reply = session.handle({"type": "questionnaire", "answers": {**ANSWERS, "likert_q3": None}}, 0.0)
    assert reply is not None and reply["type"] == "error" and not (tmp_path / "questionnaires.csv").exists()
    recorded = session.handle({"type": "questionnaire", "answers": ANSWERS}, 0.0)
    assert recorded == {"type": "answers_recorded", "block": 0}
    table = read_questionnaires(tmp_path / "questionnaires.csv")
    assert list(table["participant"]) == [4] and list(table["block"]) == [0]
    assert table["condition"].iloc[0] == session.schedule[0].condition
    scores = questionnaire_scores(table, str(tmp_path / "questionnaires.csv"))
    assert scores["tlx_raw"].iloc[0] == pytest.approx((35 + 10 + 40 + 20 + 45 + 30) / 6)
    assert session.phase == "ready"


def test_condition_order_sets_the_first_block_and_keeps_the_blocks():
    from nudgecli.sim.study import build_layouts, participant_schedule

    config = load_experiment("paper")
    layouts = build_layouts(config, 5)
    default = participant_schedule(config, 5, 0, layouts)
    flipped = participant_schedule(config, 5, 0, layouts, condition_order=["control", "disambiguation"])
    assert default[0].condition == "disambiguation" and flipped[0].condition == "control"
    blocks = {(s.condition, s.layout_index) for s in default}
    assert {(s.condition, s.layout_index) for s in flipped} == blocks
    own_order = ["disambiguation", "control"]
    assert participant_schedule(config, 5, 0, layouts, condition_order=own_order) == default


def test_study_command_mistakes_are_one_error_line(tmp_path):
    from click.testing import CliRunner
    from live_helpers import free_port

    from nudgecli.cli import main

    runner, port = CliRunner(), str(free_port())  # refused after binding it: a free one
    for args, words in (
        (["--participant", "alice"], "ending in the participant's number"),
        (["--participant", "5" * 5000], "at most 32 characters"),
        (["--participant", "P00"], "from 1 to 9999"),
        (["--participant", "P1", "--condition-order", "control"], "name each condition"),
        (["--participant", "P1", "--set", "calibration.rate_hz=20"], "must equal study.rate_hz"),
    ):
        result = runner.invoke(main, ["study", "paper", "--out", str(tmp_path / "run"), "--port", port,
                                      *args])
        assert result.exit_code == 1 and result.output.startswith("Error: ") and words in result.output
        assert result.output.count("\n") == 1
