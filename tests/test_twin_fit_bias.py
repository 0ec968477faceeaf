"""Twins not slower than their sources: the fit's offsets are what the simulator does between a
parameter and its habit (``nudgecli.sim.twin_fit``), a pulse is measured from blows that are pulses,
and a fallback or a bounded fit says why. Hand-made habit figures -> fitted parameters (fast)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.config import PopulationSection
from nudgecli.sim.twin_fit import HabitFigures, Mechanics, fit_twin, fit_twin_with_notes

#: The default population's mechanics (drawn once for the module).
MECHANICS = Mechanics()


def test_the_stop_to_switch_offset_counts_the_onset_samples_below_the_hard_band() -> None:
    """The driver switches at a pulse's first sample above the hard threshold: an onset ramp of
    1-3 samples at a level of 0.55-1.2 puts about one and a half samples before it, not one."""
    length, first, _ = MECHANICS.pulse(2, 1)
    switches = first < length  # a few draws' pulses never reach the band (a level near it, noise)
    assert np.mean(first[switches] <= 3) > 0.95 and 1.2 < first[switches].mean() < 1.8
    offsets = MECHANICS.reaction_offsets(2, 1)
    assert offsets["reaction_stop_to_switch"] == pytest.approx(first[switches].mean() * 0.1)
    # seen the step after the switch, and some soft blows read no input for their first samples
    assert 0.1 < offsets["reaction_switch_to_motion"] < 0.2
    habits = {"reaction_stop_to_switch": HabitFigures(40, 1.2, 0.9, 1.5),
              "reaction_switch_to_motion": HabitFigures(40, 1.2, 0.9, 1.5),
              "hard_band_per_excursion": HabitFigures(40, 0.3), "hard_blow_whole": HabitFigures(40, 0.5)}
    # the old rule took 0.1 s off each reaction: 1.1 s, 0.04-0.09 s above the people it came from
    assert fit_twin(habits, mechanics=MECHANICS)["event_reaction_s"] < 1.2 - 0.1 - 0.02


def test_ramp_samples_in_the_hard_band_do_not_count_as_peak() -> None:
    """Time in the hard band is the peak and the ramp samples above the threshold: a band of 0.3 s
    is a peak of about 0.2 s (the old offset of 0 read 0.3 s, 0.08 s slow on average)."""
    inside = MECHANICS.pulse(2, 1)[2]
    assert inside.mean() > 2.5  # a 2-sample peak spends more than 2.5 samples in the band
    habits = {"hard_band_per_excursion": HabitFigures(40, 0.3), "hard_blow_whole": HabitFigures(40, 0.5)}
    assert 0.15 <= fit_twin(habits, mechanics=MECHANICS)["hard_peak_s"] <= 0.25


def test_soft_blows_with_a_stray_hard_cell_are_no_pulse() -> None:
    """Seed 5's person 10 (``ciaa-teleop``, 20 people): her soft level is near the threshold, and
    the soft blows with a stray Hard cell make the hard blows' median 2 s. Their lower quartile is
    the pulse; the old rule made an offset ramp of 15 samples (true 1, the population's 0-2)."""
    habits = {"hard_band_per_excursion": HabitFigures(177, 0.3, 0.2, 0.4),
              "hard_blow_whole": HabitFigures(121, 2.0, 0.7, 3.3)}
    fitted, notes = fit_twin_with_notes(habits, mechanics=MECHANICS)
    lo, hi = PopulationSection().offset_ramp_samples
    assert lo <= fitted["offset_ramp_samples"] <= hi
    assert "lower quartile (0.7 s)" in notes["offset_ramp_samples"]


def test_an_offset_ramp_outside_the_population_is_clamped_and_says_so() -> None:
    """Seed 11's persons 6 and 13 fitted above 20 samples and were silently the population's; a
    fit outside ``[population] offset_ramp_samples`` is clamped to it, with the reason."""
    habits = {"hard_band_per_excursion": HabitFigures(40, 0.3),
              "hard_blow_whole": HabitFigures(40, 1.5, 1.5, 1.5)}  # no shorter quartile to read
    fitted, notes = fit_twin_with_notes(habits, mechanics=MECHANICS)
    assert fitted["offset_ramp_samples"] == 2
    assert "outside [population] offset_ramp_samples 0-2: clamped to 2" in notes["offset_ramp_samples"]


def test_a_lower_quartile_within_a_cell_of_the_offset_gives_no_spread() -> None:
    """The pilot run's person 2 (``ciaa-teleop --participants 3 --seed 2020``): 0.1 s stop -> switch
    events that are no reactions put the lower quartile at 0.125 s, and the old rule read a log-sd
    of 1.52 (true 0.35). The spread is read from switch -> motion, and a lower quartile within a
    cell of its offset is no reaction's: the population's, with the reason."""
    pilot = {"reaction_stop_to_switch": HabitFigures(50, 0.65, 0.125, 0.975),
             "reaction_switch_to_motion": HabitFigures(119, 1.0, 0.8, 1.3),
             "hard_band_per_excursion": HabitFigures(40, 0.3), "hard_blow_whole": HabitFigures(40, 0.5)}
    lo, hi = PopulationSection().event_reaction_log_sd
    assert lo - 0.1 <= fit_twin(pilot, mechanics=MECHANICS)["event_reaction_log_sd"] <= hi + 0.1
    quick = {**pilot, "reaction_switch_to_motion": HabitFigures(119, 1.0, 0.2, 1.3)}
    fitted, notes = fit_twin_with_notes(quick, mechanics=MECHANICS)
    assert "event_reaction_log_sd" not in fitted
    assert "lower quartile (0.2 s) is within a cell of its offset" in notes["event_reaction_log_sd"]


def test_fit_people_says_why_a_parameter_is_the_populations(tmp_path: Path) -> None:
    table = tmp_path / "habits.csv"
    table.write_text("participant,habit,n,median,q25,q75\n"
                     "p1,first_command_latency,12,2.3,2.0,2.6\n"
                     "p1,hard_band_per_excursion,40,0.3,0.2,0.4\n"
                     "p1,hard_blow_whole,40,1.5,1.5,1.5\n")
    made = CliRunner().invoke(main, ["fit-people", str(table), "--out", str(tmp_path / "people.csv")])
    assert made.exit_code == 0, made.output
    lines = made.stderr.splitlines()
    person = "Note: person 0 (habits.csv participant p1): "
    assert f"{person}event_reaction_s: no reaction_stop_to_switch in the source (the rule is both " \
           "reactions' mean)" in lines
    assert any(line.startswith(f"{person}offset_ramp_samples: fitted ")
               and line.endswith("clamped to 2") for line in lines)
    assert "Note:" not in made.stdout  # the people's lines stay one a person
