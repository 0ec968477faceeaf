"""Mends of the comparison tools (`nudge habits`, `compare`, `validate`, `fit-people`), each on the
smallest input that shows it: synthetic step tables, hand-made files, a few tiny runs."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nudgecli.report.habit_cells import _trial_cells, habit_rate_cells
from nudgecli.report.habits import measure_habits

# --- habits: an autonomy turn between two blows is not the person's ------------------------------

#: One grid-world trial at 10 Hz, a step per row: (turn, label, moves, event). The person blows a soft
#: puff (moving), pauses 0.5 s, blows again, switches mode with a hard sip, waits for the handover;
#: the autonomy moves the robot for 1 s; the person, back, waits 0.3 s and blows once more.
_TRIAL = ([("human", "", False, "")] * 5 + [("human", "Soft Puff", True, "")] * 3
          + [("human", "", False, "")] * 5 + [("human", "Soft Puff", True, "")] * 2
          + [("human", "Hard Sip", False, ""), ("human", "Hard Sip", False, "mode_switch_human")]
          + [("human", "", False, "")] * 3 + [("autonomy", "", True, "")] * 10
          + [("human", "", False, "")] * 3 + [("human", "Soft Puff", True, "")] * 3)


def _steps_of(trial: list[tuple[str, str, bool, str]]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A steps table of one trial (x grows by 1 across each moving step) and its trials row."""
    x = np.concatenate(([0.0], np.cumsum([1.0 if moves else 0.0 for _, _, moves, _ in trial])))
    switched = next(i for i, (_, _, _, event) in enumerate(trial) if event) + 1  # the mode after the switch
    mode = ["x"] * switched + ["y"] * (len(trial) - switched)
    steps = pd.DataFrame({"participant": 0, "trial": 0, "turn": [t for t, _, _, _ in trial], "x": x[:-1],
                          "y": 0.0, "theta": 0.0, "mode": mode, "phi_m": [label for _, label, _, _ in trial],
                          "event": [event for _, _, _, event in trial]})
    trials = pd.DataFrame({"participant": [0], "trial": [0], "layout": [0], "final_x": [x[-1]],
                           "final_y": [0.0], "final_theta": [0.0]})
    return steps, trials


def _values(events: pd.DataFrame, habit: str) -> list[float]:
    return sorted(events.loc[events["habit"] == habit, "value"].tolist())


def test_habits_cut_blows_pauses_and_reactions_at_an_autonomy_turn() -> None:
    steps, trials = _steps_of(_TRIAL)
    cells = _trial_cells(SimpleNamespace(path=Path("run")), steps, trials, None)  # type: ignore[arg-type]
    assert cells["person_turn"].tolist() == [turn == "human" for turn, _, _, _ in _TRIAL]
    events = measure_habits(cells)
    # the 0.5 s pause is the person's; the 1.6 s from the switch blow's end, across the autonomy's
    # turn, to the next blow is not (it was counted, and the autonomy's motion as their reaction)
    assert _values(events, "pause_between_blows") == [0.5]
    assert _values(events, "share_pauses_over_1s") == [0.0]
    assert _values(events, "reaction_switch_to_motion") == []
    assert _values(events, "first_command_latency") == [0.5]  # from the trial's start (HABITS.md)
    assert _values(events, "soft_blow") == [0.3, 0.3]
    assert _values(events, "hard_blow_whole") == [0.4]


def test_habits_of_an_unassisted_trial_are_those_without_the_turn() -> None:
    human = [("human", label, moves, event) for _, label, moves, event in _TRIAL]
    steps, trials = _steps_of(human)
    cells = _trial_cells(SimpleNamespace(path=Path("run")), steps, trials, None)  # type: ignore[arg-type]
    with_turn = measure_habits(cells)
    without = measure_habits(cells.drop(columns="person_turn"))
    pd.testing.assert_frame_equal(with_turn, without)
    # the same cells the person's own: the gap is their pause, the motion their reaction
    assert _values(with_turn, "pause_between_blows") == [0.5, 1.6]
    assert _values(with_turn, "reaction_switch_to_motion") == [0.4]


def test_habits_at_20_hz_do_not_count_the_autonomys_first_motion_as_the_persons() -> None:
    # the trial at 20 Hz, each step twice (its switch in the second), after one step of no input: the
    # person's last step begins a 10 Hz cell whose second half is the autonomy's first (moving) step
    doubled = [("human", "", False, "")] + [(turn, label, moves, event if half else "")
                                            for turn, label, moves, event in _TRIAL for half in (0, 1)]
    steps, trials = _steps_of(doubled)
    cells = _trial_cells(SimpleNamespace(path=Path("run")), steps, trials, None)  # type: ignore[arg-type]
    handover = doubled.index(("autonomy", "", True, ""))
    assert handover % 2 == 1  # the autonomy's first step is the second half of a 10 Hz cell
    tenth = habit_rate_cells(cells, 20.0)
    last_persons = handover // 2
    assert tenth["person_turn"].tolist()[last_persons - 1:last_persons + 2] == [True, True, False]
    assert not tenth["moving"].iloc[last_persons]  # the person does not move in it; the autonomy does
    assert tenth["moving"].iloc[last_persons + 1]
    # as at 10 Hz: the autonomy's motion is no reaction of the person's to their switch
    assert _values(measure_habits(tenth), "reaction_switch_to_motion") == []


# --- compare: a --match pair is named by both its names, and compare.json records the settings ----


def _compare_tables(folder: Path) -> tuple[Path, Path]:
    """A simulated table of two conditions and a real one of a third name."""
    rng = np.random.default_rng(0)
    simulated = pd.DataFrame([{"participant": f"p{p}", "condition": c, "trial": t,
                               "completion_time": 20 + rng.normal()}
                              for p in range(3) for c in ("disambiguation", "control") for t in range(3)])
    real = pd.DataFrame([{"participant": f"r{p}", "condition": "assisted", "trial": t,
                          "completion_time": 21 + rng.normal()} for p in range(3) for t in range(3)])
    simulated.to_csv(folder / "sim.csv", index=False)
    real.to_csv(folder / "real.csv", index=False)
    return folder / "sim.csv", folder / "real.csv"


def test_compare_names_a_matched_condition_by_both_names_and_records_its_settings(tmp_path: Path) -> None:
    from nudgecli.report.compare import CompareOptions, compare_sources
    from nudgecli.report.compare_figure import build_compare_figure
    from nudgecli.report.compare_text import format_comparison

    simulated, real = _compare_tables(tmp_path)
    result = compare_sources(simulated, real, condition_map={"disambiguation": "assisted"},
                             options=CompareOptions(resamples=0), drop_duplicates=True)
    (row,) = result.table.to_dict("records")
    assert (row["condition"], row["simulated_condition"], row["real_condition"]) == \
        ("assisted", "disambiguation", "assisted")
    document = result.to_json()
    assert document["match"] == {"disambiguation": "assisted"}
    assert document["plan"] == {"name": "paper", "source": "paper"}
    assert document["drop_duplicates"] is True
    assert "disambiguation as assisted" in format_comparison(result)
    figure = build_compare_figure(result.trials, result.table, result.medians)
    assert figure.axes[0].get_title(loc="left").startswith("disambiguation as assisted")


# --- a run still being written: wait for it, never the --resume its lock would refuse ------------


@pytest.mark.parametrize("parts_missing", [True, False])
def test_a_reader_of_a_run_being_written_is_told_to_wait(analysed_smoke_run: Path, tmp_path: Path,
                                                         parts_missing: bool) -> None:
    import fcntl
    import json
    import shutil

    from nudgecli.errors import RunFolderError
    from nudgecli.report.habit_cells import run_folder_cells
    from nudgecli.run_folder_names import LOCK, MANIFEST

    run = tmp_path / "run"
    shutil.copytree(analysed_smoke_run, run)
    manifest = json.loads((run / MANIFEST).read_text(encoding="utf-8"))
    (run / MANIFEST).write_text(json.dumps({**manifest, "status": "running"}), encoding="utf-8")
    if parts_missing:
        (run / "steps" / "part-0001.parquet").unlink()
    holder = {"pid": 1, "host": "here", "command": "nudge simulate smoke", "since": "now"}
    (run / LOCK).write_text(json.dumps(holder), encoding="utf-8")
    with open(run / LOCK, "rb") as lock:  # held as the simulating process holds it
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(RunFolderError) as raised:
            run_folder_cells(run)
    message = str(raised.value)
    # before: "is incomplete ... restore with `nudge simulate ... --resume`" (refused: in use by)
    assert "the run is running, in use by `nudge simulate smoke`" in message
    assert message.endswith("wait for it to finish") and "--resume" not in message


# --- a --force that fails while writing changes no table ---------------------------------------


def test_compare_force_whose_figure_cannot_be_written_keeps_the_earlier_tables(tmp_path: Path) -> None:
    from nudgecli.api.tables import compare
    from nudgecli.errors import WriteError

    simulated, real = _compare_tables(tmp_path)
    out = tmp_path / "cmp"
    out.mkdir()
    names = ("compare.csv", "participant_medians.csv", "compare.json")
    before = {name: f"earlier {name}\n" for name in names}
    for name, text in before.items():
        (out / name).write_text(text, encoding="utf-8")
    (out / "compare.png").mkdir()  # the figure cannot be written
    with pytest.raises(WriteError, match=r"compare\.png"):
        compare(simulated, real, match={"disambiguation": "assisted"}, resamples=0, out=out, formats=["png"],
                force=True)
    # before: the new tables were written first, beside the earlier figure
    assert {name: (out / name).read_text(encoding="utf-8") for name in before} == before
    assert sorted(p.name for p in out.iterdir()) == sorted([*before, "compare.png"])  # no temporary


def test_validate_force_whose_figure_cannot_be_written_keeps_the_earlier_tables(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nudgecli.api.validation import validate
    from nudgecli.errors import WriteError

    def unwritable(summary: object, out: Path) -> list[Path]:
        raise WriteError(f"cannot write {out / 'validation.png'}: Is a directory")

    monkeypatch.setattr("nudgecli.report.validation_figure.plot_validation", unwritable)
    out = tmp_path / "val"
    out.mkdir()
    before = {name: f"earlier {name}\n" for name in ("validation.json", "validation.csv")}
    for name, text in before.items():
        (out / name).write_text(text, encoding="utf-8")
    with pytest.raises(WriteError, match=r"validation\.png"):
        validate(simulations=1, min_goals=3, max_goals=3, states=40, mc_queries=0, out=out, force=True)
    assert {name: (out / name).read_text(encoding="utf-8") for name in before} == before
    assert sorted(p.name for p in out.iterdir()) == sorted(before)


def test_compare_force_with_a_table_path_that_is_a_folder_changes_no_file(tmp_path: Path) -> None:
    from nudgecli.api.tables import compare
    from nudgecli.errors import WriteError

    simulated, real = _compare_tables(tmp_path)
    out = tmp_path / "cmp"
    out.mkdir()
    (out / "compare.csv").mkdir()  # the first table cannot be written
    before = {name: f"earlier {name}\n".encode() for name in ("participant_medians.csv", "compare.json",
                                                              "compare.png")}
    for name, content in before.items():
        (out / name).write_bytes(content)
    with pytest.raises(WriteError, match=r"compare\.csv"):
        compare(simulated, real, match={"disambiguation": "assisted"}, resamples=0, out=out, formats=["png"],
                force=True)
    # without the folder check: the figure and the other two tables were replaced, then compare.csv failed
    assert {name: (out / name).read_bytes() for name in before} == before
    assert sorted(p.name for p in out.iterdir()) == sorted([*before, "compare.csv"])


def test_validate_force_with_a_table_path_that_is_a_folder_changes_no_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from nudgecli.api.validation import validate
    from nudgecli.errors import WriteError

    def figure(summary: object, out: Path) -> list[Path]:  # as the figure's writer replaces its file
        (out / "validation.png").write_text("new figure\n", encoding="utf-8")
        return [out / "validation.png"]

    monkeypatch.setattr("nudgecli.report.validation_figure.plot_validation", figure)
    out = tmp_path / "val"
    out.mkdir()
    (out / "validation.json").mkdir()  # the table renamed last cannot be written
    before = {name: f"earlier {name}\n" for name in ("validation.csv", "validation.png")}
    for name, text in before.items():
        (out / name).write_text(text, encoding="utf-8")
    with pytest.raises(WriteError, match=r"validation\.json"):
        validate(simulations=1, min_goals=3, max_goals=3, states=40, mc_queries=0, out=out, force=True)
    assert {name: (out / name).read_text(encoding="utf-8") for name in before} == before
    assert sorted(p.name for p in out.iterdir()) == sorted([*before, "validation.json"])


# --- docs/people.md: a log without its layout leaves one reaction parameter to the population -----


def test_people_md_says_a_log_without_its_layout_still_fits_the_reaction_spread() -> None:
    # the rule itself: tests/test_sim_twins.py::test_the_reaction_needs_both_reactions_and_its_spread_...
    people = Path(__file__).resolve().parents[1] / "docs" / "people.md"
    text = " ".join(people.read_text(encoding="utf-8").split())
    assert "both reaction parameters" not in text  # before: both, though the spread is fitted
    assert ("no stop -> switch in a log without its `layout` column: `event_reaction_s` then, whose rule "
            "is both reactions' mean, while `event_reaction_log_sd` is still fitted from switch -> motion "
            "alone") in text


# --- validate: --mc-queries unused or capped is said in a note ----------------------------------


def test_validate_notes_mc_queries_beside_all_readings(monkeypatch: pytest.MonkeyPatch) -> None:
    from nudgecli.api.validation import validate

    # the notes are on the options; the validation itself is not what is checked here
    monkeypatch.setattr("nudgecli.sim.validation.run_all_readings", lambda settings, names, progress: [])
    checked = validate(simulations=2, min_goals=3, max_goals=3, states=72, mc_queries=50, all_readings=True)
    assert any(note.startswith("--mc-queries 50 is not used with --all-readings") for note in checked.notes)
    quiet = validate(simulations=2, min_goals=3, max_goals=3, states=72, mc_queries=0, all_readings=True)
    assert not any("--mc-queries" in note for note in quiet.notes)  # 0 (or the default): nothing to say


def test_validate_notes_mc_queries_capped_at_the_worlds_queries() -> None:
    from nudgecli.api.validation import validate

    capped = validate(simulations=1, min_goals=2, max_goals=2, states=18, mc_queries=20)
    ran = capped.results[0].mc_queries_run
    assert ran < 20 and any(note.startswith(f"--mc-queries 20: the Monte-Carlo convergence study ran {ran}:")
                            for note in capped.notes), capped.notes
    exact = validate(simulations=1, min_goals=2, max_goals=2, states=18, mc_queries=ran)
    assert not any("--mc-queries" in note for note in exact.notes)


# --- habits of a Parquet part or a JSON --compare does not read: the right advice ------------------


def test_habits_of_a_run_part_names_the_run_folder(analysed_smoke_run: Path, tmp_path: Path) -> None:
    from nudgecli.errors import DataError
    from nudgecli.report.habits import source_cells

    part = analysed_smoke_run / "steps" / "part-0000.parquet"
    with pytest.raises(DataError) as raised:
        source_cells(part)
    message = str(raised.value)
    # before: "not UTF-8 text (byte 0xe4 on line 1; ...); save it as UTF-8"
    assert "a Parquet file" in message and "UTF-8" not in message
    assert message.endswith(f"give the run folder {analysed_smoke_run}")
    loose = tmp_path / "table.csv"  # a Parquet file of no run, named as a CSV
    loose.write_bytes(part.read_bytes())
    with pytest.raises(DataError, match=r"a Parquet file .* not CSV text; give the CSV file"):
        source_cells(loose)


@pytest.mark.parametrize("text", ['{"participant": "p1", "p_phi_given_a": {}, "p_phm_given_phi": {}}',
                                  '{"habits": []}', '[{"a": 1}]', "\ufeff{}"])
def test_habits_of_a_json_compare_does_not_read_does_not_advise_compare(tmp_path: Path, text: str) -> None:
    from nudgecli.errors import DataError
    from nudgecli.report.habits import source_cells

    source = tmp_path / "p1.profile.json"
    source.write_text(text, encoding="utf-8")
    with pytest.raises(DataError) as raised:
        source_cells(source)
    message = str(raised.value)
    # before: "... nudge habits SOURCE --compare p1.profile.json", which then failed "no 'habits' object"
    assert "SOURCE --compare" not in message and "is no reference for --compare either" in message
    assert ("a `nudge fit` profile" in message) == ("p_phm_given_phi" in text)


@pytest.mark.parametrize(("reader", "part"), [("questionnaires", "trials"), ("people", "participants")])
def test_a_reader_of_csv_files_only_given_a_run_part_is_told_to_give_the_csv(
        analysed_smoke_run: Path, reader: str, part: str) -> None:
    from nudgecli.errors import DataError
    from nudgecli.report.questionnaires import read_questionnaires
    from nudgecli.sim.people_file import read_people

    read = read_questionnaires if reader == "questionnaires" else read_people
    path = analysed_smoke_run / part / "part-0000.parquet"
    with pytest.raises(DataError) as raised:
        read(path)
    # before: "... give the run folder RUN", which these readers then refused as a folder
    said = f"{path}: a Parquet file (it starts with PAR1), not CSV text; give the CSV file"
    if reader == "people":  # a people file is never Parquet: it is made of the run (fit-people)
        said = (f"{path}: a Parquet file (it starts with PAR1), a part of the run folder "
                f"{analysed_smoke_run}, not a people file (CSV text that fit-people writes); make one with "
                f"`nudge fit-people {analysed_smoke_run} --out people.csv`, then give --people people.csv")
    assert str(raised.value) == said
