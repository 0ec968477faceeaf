"""docs/people.md says what the person inside a blow does not reproduce yet: the pulse's ramps in
the hard band, the soft band's edge at exactly 0.300, the shared stall timer, the wide planning
and reaction ranges, merged pulses and the missing session trend (2026-11-29)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from nudgecli.config_people import BehaviourSection
from nudgecli.model.interface import HARD_PUFF
from nudgecli.sim.participants import Participant, mapping_with_error

ROOT = Path(__file__).resolve().parents[1]
HEADING = "#### Known limitations of the operating habits (2026-11-29)"


def _limitations() -> str:
    text = (ROOT / "docs" / "people.md").read_text(encoding="utf-8")
    assert HEADING in text
    section = text.split(HEADING, 1)[1]
    return re.split(r"\n#{2,4} ", section, maxsplit=1)[0]


def test_the_people_doc_no_longer_calls_the_peak_the_time_in_the_hard_band() -> None:
    text = (ROOT / "docs" / "people.md").read_text(encoding="utf-8")
    assert "`hard_peak_s` is the real time in the hard band alone" not in text
    assert "No data pin it" not in (BehaviourSection.__doc__ or "")


def test_each_limitation_is_stated_with_its_measured_numbers_and_command() -> None:
    section = _limitations()
    for measured in ("+0.090 s", "19 of the 50", "15.7 %", "10.6 %", "0.198", "0.112", "0.40 s [0.20, 0.70]",
                     "stall_s=0.5", "20 of the 50", "0.83-1.59", "9.1 %", "3.35 s", "0.078", "0.058",
                     "nudge simulate ciaa-teleop --participants 50 --seed 2020",
                     "nudge habits RUN --by trial --format csv"):
        assert measured in section, measured


def test_a_pulses_ramp_samples_read_hard_at_a_high_level() -> None:
    # why the hard band is longer than the peak: 2/3 of a level of 1.1 is past the hard threshold 0.5
    person = Participant(index=0, seed_key="t", pressure_level=np.array([-1.1, 1.1, -0.15, 0.15]),
                         pressure_spread=np.zeros(4), mapping=mapping_with_error(0.0), epsilon=0.0,
                         rest_s=0.0, operate_s=1.0, action_pause_s=0.0, hard_blow_s=0.5, reaction_s=0.5,
                         onset_ramp_samples=2, offset_ramp_samples=2)
    pulse = person.pulse_pressures(HARD_PUFF, np.zeros(2 + 2 + 2), peak_samples=2)
    assert int((np.abs(pulse) > 0.5).sum()) == 4  # the peak's 2 samples and one of each ramp
