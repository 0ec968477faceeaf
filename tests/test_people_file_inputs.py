"""A people file (``--people``) given as a researcher may have it: a value out of range names the
range ``[population]`` checks, a folder is said to be one (with the file to give instead), a
spreadsheet's semicolons and decimal commas are read or named as such, and a file with more people
than the study simulates names those left out."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.errors import DataError
from nudgecli.sim.people_file import read_people

HEADER = "person,source,participant,deadband_share,offset_ramp_samples,from_population\n"


@pytest.mark.parametrize(("row", "words"), [
    ("0,x,A,0.99,1,\n", ["deadband_share: 0.99 is out of its valid range", "0.0 <= deadband_share <= 0.9"]),
    ("0,x,A,0.1,21,\n", ["offset_ramp_samples: 21", "whole number of samples",
                         "0 <= offset_ramp_samples <= 20"]),
])
def test_a_value_out_of_range_names_the_range_population_accepts(tmp_path: Path, row: str,
                                                                 words: list[str]) -> None:
    path = tmp_path / "people.csv"
    path.write_text(HEADER + row)
    with pytest.raises(DataError) as caught:
        read_people(path)
    for word in words:
        assert word in str(caught.value), caught.value
