"""The delimiter the row check counts with is the one pandas read with: a comma when the caller
passes no ``sep`` (pandas' default), the sniffed one only for ``sep=None``.

A header whose first field is quoted and followed by a space (``"t" ,"command"``, a column-aligned
file) is the case where they differ: ``csv.Sniffer`` takes the space for the delimiter, pandas
reads the file with a comma.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from nudgecli.config import CalibrationSection
from nudgecli.csv_rows import read_csv_whole_rows
from nudgecli.errors import DataError
from nudgecli.rng import generator
from nudgecli.sim.calibration_io import write_sessions
from nudgecli.sim.calibration_readers import read_mapping_session
from nudgecli.sim.calibration_sessions import simulate_mapping_session
from nudgecli.sim.participants import Participant, mapping_with_error

ALIGNED_HEADER = '"t" ,"command"'


def test_the_sniffer_and_pandas_disagree_on_the_aligned_header() -> None:
    # the premise of the tests below, from the standard library itself
    assert csv.Sniffer().sniff(ALIGNED_HEADER + "\n").delimiter == " "


def test_a_complete_file_read_without_sep_is_counted_by_commas(tmp_path: Path) -> None:
    source = tmp_path / "prompts.csv"
    source.write_text(f"{ALIGNED_HEADER}\n1.0,left\n5.0,\n", encoding="utf-8")  # the cleared row: empty
    table = read_csv_whole_rows(source, dtype=str, keep_default_na=False)
    assert [c.strip() for c in table.columns] == ["t", "command"]
    assert table.to_numpy().tolist() == [["1.0", "left"], ["5.0", ""]]


def test_a_cut_file_read_without_sep_is_refused_at_its_line(tmp_path: Path) -> None:
    source = tmp_path / "prompts.csv"
    source.write_text(f"{ALIGNED_HEADER}\n1.0,left\n5.0,\n6.0\n", encoding="utf-8")
    with pytest.raises(DataError, match="line 4 has 1 of 2 fields; the file looks cut off"):
        read_csv_whole_rows(source, dtype=str, keep_default_na=False)


def test_sep_none_still_counts_with_the_sniffed_delimiter(tmp_path: Path) -> None:
    source = tmp_path / "answers.csv"
    source.write_text("a;b\n1;2\n3\n", encoding="utf-8")
    with pytest.raises(DataError, match="line 3 has 1 of 2 fields"):
        read_csv_whole_rows(source, sep=None, engine="python", dtype=str, keep_default_na=False)


def test_a_tidy_calibration_log_with_an_aligned_header_is_read(tmp_path: Path) -> None:
    participant = Participant(
        index=0, seed_key="test/aligned", pressure_level=np.array([-0.6, 0.9, -0.12, 0.25]),
        pressure_spread=np.array([0.12, 0.1, 0.06, 0.08]), mapping=mapping_with_error(0.2),
        epsilon=0.1, rest_s=0.5, operate_s=3.0, action_pause_s=0.2, hard_blow_s=0.5, reaction_s=1.0,
        reaction_log_sd=0.0, onset_ramp_samples=0, mapping_error=0.2)
    session = simulate_mapping_session(participant, CalibrationSection(), generator(2, "m"))
    write_sessions(tmp_path, session)
    prompts = tmp_path / "mapping_prompts.csv"
    lines = prompts.read_text(encoding="utf-8").splitlines()
    assert lines[0] == "t,command"
    prompts.write_text("\n".join([ALIGNED_HEADER, *lines[1:]]) + "\n", encoding="utf-8")
    read = read_mapping_session(tmp_path)
    assert read is not None and read.prompt_commands == session.prompt_commands
