"""`nudge fit-people`'s inputs at their edges: a time in the hard band longer than the pulses the fit
draws is fitted and said to be outside what the simulation accepts (it crashed), and a habits
table's rows whose scope is not `participant` or `pooled`, or whose participant label is empty, are
one `Error:` line naming the file and the line (they were dropped unsaid, or made a person '')."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line

import nudgecli.sim.twin_fit as twin_fit
from nudgecli.sim.twin_fit import HabitFigures, Mechanics, fit_twin_with_notes

#: Samples drawn of a pulse for these tests: the default population's pulses then hold peaks up to
#: 7 samples (30 less an onset of 3 and an offset of 20), so a 6 s band is past them as a 6 s band
#: is past the shipped 80 samples' 57, at a few hundredths of the cost.
FEW_SAMPLES = 30


def _pulse_habits(band_s: float, whole_s: float) -> dict[str, HabitFigures]:
    return {"hard_band_per_excursion": HabitFigures(14, band_s, band_s, band_s),
            "hard_blow_whole": HabitFigures(14, whole_s, whole_s, whole_s),
            "reaction_stop_to_switch": HabitFigures(12, 0.9, 0.7, 1.1),
            "reaction_switch_to_motion": HabitFigures(12, 1.0, 0.8, 1.3)}


@pytest.mark.parametrize("band_s", [6.0, 60.0])
def test_a_band_longer_than_the_pulses_drawn_is_fitted_and_said_outside_the_simulations_range(
        monkeypatch: pytest.MonkeyPatch, band_s: float) -> None:
    # before: ValueError, operands could not be broadcast ((1, 81) and (136, 80) for a 6 s band)
    monkeypatch.setattr(twin_fit, "PULSE_SAMPLES", FEW_SAMPLES)
    mechanics = Mechanics()
    kept, notes = fit_twin_with_notes(_pulse_habits(band_s, band_s + 0.3), mechanics=mechanics)
    # the peak is the band less its ramps' samples in it, as for any band; past 5 s: the population's
    assert "hard_peak_s" not in kept
    fitted = float(notes["hard_peak_s"].split()[1].rstrip(","))
    assert band_s - 0.3 < fitted < band_s + 0.1
    assert notes["hard_peak_s"].endswith("needs a value with 0.0 <= hard_peak_s <= 5.0, as [population] "
                                         "hard_peak_s accepts")
    # the samples outside the band are a long pulse's ramps': the offset ramp and reactions are fitted
    assert kept["offset_ramp_samples"] in (0, 1, 2) and 0.5 < kept["event_reaction_s"] < 1.0
    assert mechanics.longest_peak() == 7  # a longer pulse is no silent broadcast error
    with pytest.raises(ValueError, match="longer than the 30 samples drawn"):
        mechanics.pulse(8, 20)


def test_fit_people_writes_a_person_whose_band_is_past_the_pulses_drawn(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(twin_fit, "PULSE_SAMPLES", FEW_SAMPLES)
    table = tmp_path / "habits.csv"
    table.write_text("scope,participant,habit,n,median,q25,q75\n"
                     "participant,0,first_command_latency,8,2.65,2.6,2.9\n"
                     "participant,0,hard_blow_whole,14,6.3,6.3,6.3\n"
                     "participant,0,hard_band_per_excursion,14,6,6,6\n")
    made = nudge("fit-people", str(table), "--out", str(tmp_path / "people.csv"))
    assert made.exit_code == 0, made.output
    assert "Note: person 0 (habits.csv participant 0): hard_peak_s: fitted " in made.stderr
    assert (tmp_path / "people.csv").read_text().splitlines()[1].startswith("0,habits.csv,0,2.65,")


@pytest.mark.parametrize(("rows", "words"), [
    # a capital P dropped the row unsaid, and the fit said "no first_command_latency in the source"
    (["pooled,,first_command_latency,16,2.3,1.8,2.6", "Participant,P1,first_command_latency,8,2.6,2.6,2.9",
      "participant,P1,soft_blow,58,0.8,0.3,1.8"],
     ["line 3: scope 'Participant' is neither 'participant' nor 'pooled'", "did you mean 'participant'?"]),
    (["participant,P1,first_command_latency,8,2.6,2.6,2.9", ",P1,soft_blow,58,0.8,0.3,1.8"],
     ["line 3: scope '' is neither"]),
    (["participant,P1,first_command_latency,8,2.6,2.6,2.9", "participant, ,soft_blow,58,0.8,0.3,1.8"],
     ["line 3: a participant row with no participant label", "give the participant's label"]),
])
def test_fit_people_refuses_a_row_of_no_participant(tmp_path: Path, rows: list[str],
                                                    words: list[str]) -> None:
    table = tmp_path / "habits.csv"
    table.write_text("\n".join(["scope,participant,habit,n,median,q25,q75", *rows]) + "\n")
    _refused_with(tmp_path, table, words)


def test_fit_people_refuses_pooled_rows_in_a_table_without_its_scope_column(tmp_path: Path) -> None:
    # before: the pooled rows made a person '' (the table's own participants after it)
    table = tmp_path / "habits.csv"
    table.write_text("participant,habit,n,median,q25,q75\n"
                     ",first_command_latency,16,2.3,1.8,2.6\n"
                     "P1,first_command_latency,8,2.6,2.6,2.9\n")
    _refused_with(tmp_path, table, ["line 2: no participant label, and no scope column", "scope column"])


def _refused_with(tmp_path: Path, table: Path, words: list[str]) -> None:
    """`nudge fit-people TABLE` exits 1 with one error line naming the table and ``words``, and
    writes nothing."""
    result = nudge("fit-people", str(table), "--out", str(tmp_path / "people.csv"))
    assert result.exit_code == 1 and result.stdout == "", result.output
    assert not (tmp_path / "people.csv").exists()
    line = one_error_line(result.stderr)
    assert line.startswith(f"Error: {table}: "), line
    for word in words:
        assert word in line, line


def test_the_default_mechanics_are_of_the_samples_drawn_when_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    shipped = twin_fit.PULSE_SAMPLES
    with monkeypatch.context() as patched:
        patched.setattr(twin_fit, "PULSE_SAMPLES", 30)
        assert twin_fit.default_mechanics().draws.normals.shape[1] == 30
    # was: the draws cached first (30 samples here) handed to every later caller
    assert twin_fit.default_mechanics().draws.normals.shape[1] == shipped
