"""Twins of real people (issue 37): the fit from habit medians (hand-solved and by scipy's log-normal),
the people file (round trip and a strict schema), the twin laid over a drawn participant, the
recovery bookkeeping, and a small parameter recovery end to end."""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from nudgecli.config import PopulationSection, load_experiment
from nudgecli.errors import DataError
from nudgecli.rng import generator
from nudgecli.sim.habit_ranges import DEADBAND_PARAMETERS
from nudgecli.sim.participants import Participant, draw_participant
from nudgecli.sim.people_file import People, check_same_people, people_csv, read_people
from nudgecli.sim.study import study_participant
from nudgecli.sim.twin_fit import (
    PARAMETER_HABITS,
    STOP_PARAMETERS,
    HabitFigures,
    Mechanics,
    fit_twin,
    fit_twin_with_notes,
    stops_per_trial,
)
from nudgecli.sim.twin_recovery import habit_agreement, habit_is_near, parameter_recovery
from nudgecli.sim.twins import TWIN_PARAMETERS, Twin, apply_twin, twin_at

#: One participant's habits, every figure chosen so the fit can be solved by hand.
HABITS = {
    "first_command_latency": HabitFigures(12, 2.3),
    "reaction_stop_to_switch": HabitFigures(8, 1.1, 0.7, 1.3),
    "reaction_switch_to_motion": HabitFigures(8, 1.3, 0.9, 1.5),
    "hold_on_per_trial": HabitFigures(12, 0.8),
    "hard_band_per_excursion": HabitFigures(20, 0.2),
    "hard_blow_whole": HabitFigures(20, 0.6),
    "deadband_share_soft_blows": HabitFigures(300, 0.08),
    "deadband_run_in_soft_blow": HabitFigures(30, 0.2),
}


#: What the default population's physiology does between a parameter and its habit (made once).
MECHANICS = Mechanics()


def test_the_fit_inverts_the_offsets_by_hand() -> None:
    fitted = fit_twin(HABITS, mechanics=MECHANICS)
    z = stats.norm.ppf(0.75)  # scipy's, not the module's NormalDist
    assert fitted["planning_s"] == pytest.approx(2.3)  # offset 0
    shape = round(fitted["hard_peak_s"] / 0.1), int(fitted["offset_ramp_samples"])
    offsets = MECHANICS.reaction_offsets(*shape)
    stop, motion = offsets["reaction_stop_to_switch"], offsets["reaction_switch_to_motion"]
    assert 0.1 < stop < 0.2 and 0.1 < motion < 0.2  # a cell and a fraction of one more (the module's rules)
    assert fitted["event_reaction_s"] == pytest.approx((1.1 - stop + 1.3 - motion) / 2, abs=1e-6)
    spread = math.log((1.5 - motion) / (0.9 - motion)) / (2 * z)  # the switch -> motion quartiles
    assert fitted["event_reaction_log_sd"] == pytest.approx(spread, abs=1e-6)
    assert fitted["hold_on_s"] == pytest.approx(0.8 / 4)  # four stops a CIAA trial
    # 0.2 s in the hard band, 0.4 s outside: a ramp sample or so reaches the band, the rest is ramps
    assert 0.1 <= fitted["hard_peak_s"] < 0.2 and fitted["offset_ramp_samples"] in (1, 2)
    assert fitted["deadband_share"] == pytest.approx(0.08)
    assert fitted["deadband_stray_s"] == pytest.approx(0.2)
    assert set(fitted) == set(TWIN_PARAMETERS)


@settings(max_examples=60, deadline=None)
@given(median=st.floats(0.3, 2.0), log_sd=st.floats(0.05, 1.0))
def test_the_reactions_log_sd_is_read_back_from_a_lognormals_quartiles(median: float, log_sd: float) -> None:
    # the quartiles of scipy's log-normal, measured each reaction's offset later (the offsets of the
    # pulse the hard blows give)
    pulse = {"hard_band_per_excursion": HabitFigures(20, 0.2), "hard_blow_whole": HabitFigures(20, 0.5)}
    shape = fit_twin(pulse, mechanics=MECHANICS)
    offsets = MECHANICS.reaction_offsets(round(shape["hard_peak_s"] / 0.1), int(shape["offset_ramp_samples"]))
    habits = {habit: HabitFigures(50, *(stats.lognorm(s=log_sd, scale=median).ppf([0.5, 0.25, 0.75])
                                         + offsets[habit]).tolist())
              for habit in ("reaction_stop_to_switch", "reaction_switch_to_motion")}
    fitted, notes = fit_twin_with_notes({**habits, **pulse}, mechanics=MECHANICS)
    assert fitted["event_reaction_s"] == pytest.approx(median, abs=1e-6)
    if stats.lognorm(s=log_sd, scale=median).ppf(0.25) >= 0.1:  # a reaction is at least a cell
        assert fitted["event_reaction_log_sd"] == pytest.approx(log_sd, abs=1e-6)  # rounded to 1e-6
    else:
        assert "event_reaction_log_sd" not in fitted and "within a cell" in notes["event_reaction_log_sd"]


def test_every_parameter_a_twin_sets_has_its_habits_and_the_deadband_ones_are_the_populations() -> None:
    assert tuple(PARAMETER_HABITS) == TWIN_PARAMETERS
    assert set(DEADBAND_PARAMETERS) <= set(TWIN_PARAMETERS)
    assert all(dataclasses.is_dataclass(Participant) and name in Participant.__dataclass_fields__
               for name in TWIN_PARAMETERS)


def test_what_a_source_lacks_or_the_simulation_refuses_is_left_to_the_population() -> None:
    habits = dict(HABITS)
    del habits["hold_on_per_trial"]
    habits["first_command_latency"] = HabitFigures(12, 75.0)  # [population] planning_s accepts up to 60 s
    habits["reaction_switch_to_motion"] = HabitFigures(3, 1.3, 0.9, 1.5)  # too few events for quartiles
    fitted, notes = fit_twin_with_notes(habits, mechanics=MECHANICS)
    assert "hold_on_s" not in fitted and "planning_s" not in fitted
    assert "event_reaction_log_sd" not in fitted and "event_reaction_s" in fitted
    twin = Twin("p1", "log.csv", fitted, notes)
    assert twin.from_population == ("planning_s", "event_reaction_log_sd", "hold_on_s")
    # each with its reason
    assert "fitted 75" in notes["planning_s"] and "planning_s <= 60" in notes["planning_s"]
    assert "3 event(s)" in notes["event_reaction_log_sd"]
    assert notes["hold_on_s"] == "no hold_on_per_stop in the source"


def test_the_reaction_needs_both_reactions_and_its_spread_the_switch_to_motion() -> None:
    """The reaction is the mean of the two reactions' medians less their offsets: with one of them
    missing (a log without its layout has no stop -> switch) it is the population's, not one
    reaction's. The spread is read from switch -> motion alone (module docstring)."""
    habits = {name: figures for name, figures in HABITS.items() if name != "reaction_stop_to_switch"}
    fitted, notes = fit_twin_with_notes(habits, mechanics=MECHANICS)
    assert Twin("p1", "log.csv", fitted).from_population == ("event_reaction_s",)
    assert "no reaction_stop_to_switch" in notes["event_reaction_s"]
    habits = {name: figures for name, figures in HABITS.items() if name != "reaction_switch_to_motion"}
    assert Twin("p1", "log.csv", fit_twin(habits)).from_population == ("event_reaction_s",
                                                                       "event_reaction_log_sd")


def test_a_grid_world_source_leaves_the_parameters_read_from_stops_to_the_population() -> None:
    habits = {**HABITS, "hold_on_per_stop": HabitFigures(40, 0.3)}
    fitted, notes = fit_twin_with_notes(habits, mechanics=MECHANICS, waypoints=False)
    assert Twin("p1", "run", fitted).from_population == STOP_PARAMETERS
    assert all("grid-world" in notes[name] for name in STOP_PARAMETERS)
    assert fitted == {name: value for name, value in fit_twin(habits, mechanics=MECHANICS).items()
                      if name not in STOP_PARAMETERS}


def test_the_hold_on_per_stop_is_read_one_for_one_before_the_per_trial_sum() -> None:
    """A log measured by nudge habits has the hold-on per stop: the parameter is its median; a
    table of HABITS.md's rows only falls back to the per-trial sum over the four stops."""
    per_stop = {**HABITS, "hold_on_per_stop": HabitFigures(40, 0.3)}
    assert fit_twin(per_stop, mechanics=MECHANICS)["hold_on_s"] == pytest.approx(0.3)
    assert fit_twin(HABITS, mechanics=MECHANICS)["hold_on_s"] == pytest.approx(0.8 / 4)


def test_a_hard_blow_with_few_samples_outside_the_band_has_no_offset_ramp() -> None:
    """A pulse of 0.4 s, 0.3 s of it in the hard band: one sample outside, less than the onset
    ramps alone leave there on average, so no offset ramp; and the peak is the band less the ramp
    samples that reach it, at least one sample."""
    habits = {"hard_band_per_excursion": HabitFigures(20, 0.3), "hard_blow_whole": HabitFigures(20, 0.4)}
    fitted = fit_twin(habits, mechanics=MECHANICS)
    assert fitted["offset_ramp_samples"] == 0 and 0.1 <= fitted["hard_peak_s"] < 0.3
    one = {"hard_band_per_excursion": HabitFigures(20, 0.1), "hard_blow_whole": HabitFigures(20, 0.2)}
    assert fit_twin(one, mechanics=MECHANICS)["hard_peak_s"] == pytest.approx(0.1)


def test_the_stops_come_from_the_task() -> None:
    from nudgecli.sim.ciaa import packaged_task, task_layouts

    counts = {len(layout.waypoints) for layout in task_layouts(packaged_task()).values()}
    assert counts == {5} and stops_per_trial(5) == 4


def test_a_twin_sets_its_parameters_and_keeps_the_drawn_physiology() -> None:
    drawn = draw_participant(PopulationSection(), 3, generator(7, "participant", 3, "physiology"))
    twin = Twin("p1", "log.csv", {"planning_s": 2.5, "offset_ramp_samples": 2, "deadband_share": 0.1})
    person = apply_twin(drawn, twin)
    assert (person.planning_s, person.offset_ramp_samples, person.deadband_share) == (2.5, 2, 0.1)
    assert isinstance(person.offset_ramp_samples, int)
    kept = [f.name for f in dataclasses.fields(drawn) if f.compare and f.name not in twin.parameters]
    assert all(np.array_equal(getattr(person, name), getattr(drawn, name)) for name in kept)
    people = [Twin("a", "s", {}), Twin("b", "s", {}), Twin("c", "s", {})]
    assert [twin_at(people, i).participant for i in range(7)] == list("abcabca")


def test_a_study_participant_is_the_twin_of_person_i_mod_p() -> None:
    config = load_experiment("ciaa-teleop")
    people = (Twin("a", "s", {"planning_s": 1.5}), Twin("b", "s", {"planning_s": 2.5}))
    for index, planning in [(0, 1.5), (1, 2.5), (2, 1.5)]:
        drawn = study_participant(config, 5, index)
        person = study_participant(config, 5, index, people)
        assert person.planning_s == planning
        assert person.pressure_level.tolist() == drawn.pressure_level.tolist()
        assert person.event_reaction_s == drawn.event_reaction_s


# --- the people file ---------------------------------------------------------------------------


def _twins() -> list[Twin]:
    return [Twin("p1", "a.csv", fit_twin(HABITS, mechanics=MECHANICS)),
            Twin("p 2", "b,c.csv", {"planning_s": 1.75, "offset_ramp_samples": 0})]


def test_the_people_file_reads_back_what_was_written(tmp_path: Path) -> None:
    path = tmp_path / "people.csv"
    path.write_text(people_csv(_twins()))
    people = read_people(path)
    assert people.twins == tuple(_twins())
    assert people.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert people.record() == {"file": "people.csv", "sha256": people.sha256, "people": 2}
    lines = path.read_text().splitlines()
    assert lines[0].split(",")[0] == "person" and lines[0].endswith(",from_population")
    assert lines[2].endswith("event_reaction_log_sd;hold_on_s;hard_peak_s;deadband_share;deadband_stray_s")


def _written(tmp_path: Path, edit: str, new: str) -> Path:
    path = tmp_path / "people.csv"
    text = people_csv(_twins())
    assert edit in text
    path.write_text(text.replace(edit, new, 1))
    return path


@pytest.mark.parametrize(("edit", "new", "words"), [
    ("hold_on_s,", "hold_on,", ["column 'hold_on'", "did you mean 'hold_on_s'"]),
    (",from_population", ",notes", ["column 'notes'"]),
    (",1.75,", ",75.0,", ["person 1 (participant 'p 2')", "planning_s", "out of its valid range"]),
    (",1.75,", ",soon,", ["person 1", "planning_s", "'soon' is not a number"]),
    (",0,", ",1.5,", ["person 1", "offset_ramp_samples", "whole number"]),
    ("\n1,", "\n2,", ["person 2", "expected 1"]),
    (";hold_on_s;", ";hold_on;", ["person 1", "from_population", "'hold_on'"]),
])
def test_a_bad_people_file_names_the_file_the_person_and_the_field(tmp_path: Path, edit: str, new: str,
                                                                   words: list[str]) -> None:
    path = _written(tmp_path, edit, new)
    with pytest.raises(DataError) as caught:
        read_people(path)
    message = str(caught.value)
    assert message.startswith(str(path)), message
    for word in words:
        assert word in message, message


def test_a_cell_must_be_empty_exactly_when_listed_from_the_population(tmp_path: Path) -> None:
    header, first, second = csv.reader(io.StringIO(people_csv(_twins())))
    path = tmp_path / "people.csv"

    def write(*rows: list[str]) -> Path:
        buffer = io.StringIO()
        csv.writer(buffer).writerows([header, *rows])
        path.write_text(buffer.getvalue())
        return path

    listed = list(second)
    listed[header.index("hold_on_s")] = "0.2"  # a value, but hold_on_s is listed
    assert "hold_on_s" in listed[-1].split(";")
    with pytest.raises(DataError, match=r"person 1 .*hold_on_s: has a value but is listed"):
        read_people(write(first, listed))
    empty = list(first)
    empty[header.index("hold_on_s")] = ""  # empty, not listed
    with pytest.raises(DataError, match=r"person 0 .*hold_on_s: empty but not listed"):
        read_people(write(empty))


def test_a_missing_or_empty_people_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="no such people file"):
        read_people(tmp_path / "nobody.csv")
    path = tmp_path / "people.csv"
    path.write_text(people_csv([]))
    with pytest.raises(DataError, match="holds no people"):
        read_people(path)
    path.write_text("person,participant\n0,p\n")
    with pytest.raises(DataError, match="no column 'source'"):
        read_people(path)


def test_a_resume_needs_the_same_people() -> None:
    people = People("people.csv", "ab" * 32, ())
    check_same_people(None, None, "run")
    check_same_people(people.record(), people, "run")
    with pytest.raises(DataError, match="the population's people"):
        check_same_people(people.record(), None, "run")
    with pytest.raises(DataError, match=r"--people other\.csv"):
        check_same_people(people.record(), People("other.csv", "ab" * 32, ()), "run")
    with pytest.raises(DataError, match="sha256 cdcdcdcdcdcd"):
        check_same_people(people.record(), People("people.csv", "cd" * 32, ()), "run")


# --- the recovery's bookkeeping ---------------------------------------------------------------


def test_recovery_counts_a_parameter_within_its_tolerance() -> None:
    drawn = draw_participant(PopulationSection(), 0, generator(1, "participant", 0, "physiology"))
    truth = [dataclasses.replace(drawn, planning_s=2.0), dataclasses.replace(drawn, planning_s=2.0)]
    twins = [Twin("a", "s", {"planning_s": 2.2}), Twin("b", "s", {"planning_s": 2.21})]
    rows = {row.parameter: row for row in parameter_recovery(truth, twins)}
    assert (rows["planning_s"].within, rows["planning_s"].fitted) == (1, 2)  # 0.2 is inside, 0.21 not
    assert rows["planning_s"].worst == pytest.approx(0.21)
    assert rows["hold_on_s"].fitted == 0 and rows["hold_on_s"].share == 0.0


def test_a_habit_is_near_within_a_tenth_of_a_second_or_a_fifth() -> None:
    assert habit_is_near(1.1, 1.0) and habit_is_near(2.4, 2.0) and not habit_is_near(2.45, 2.0)
    assert not habit_is_near(0.25, 0.1)
    sources = [{"soft_blow": HabitFigures(1, 1.0)}, {"soft_blow": HabitFigures(1, 1.0)}]
    twins = [{"soft_blow": HabitFigures(1, 1.5)}, {}]
    assert habit_agreement(sources, twins, ["soft_blow"]) == {"soft_blow": (0, 1)}
