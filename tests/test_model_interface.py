"""Probability-table validation: bad tables are rejected naming the table and the row."""

from __future__ import annotations

import numpy as np
import pytest

from nudgecli.errors import NudgeError, ProbabilityTableError
from nudgecli.model import interface


def test_default_tables_are_valid() -> None:
    mapping = interface.validate_mapping_table(interface.default_mapping_table())
    distortion = interface.validate_distortion_table(interface.default_distortion_table())
    assert mapping[0, interface.MOVE_P, interface.SOFT_PUFF] == pytest.approx(0.85)
    assert distortion[interface.HARD_SIP, interface.SOFT_SIP] == pytest.approx(0.05)


def test_negative_mapping_row_is_named() -> None:
    table = interface.default_mapping_table()
    table[2, interface.TO_MODE_R] = [1.1, -0.1, 0.0, 0.0]
    expected = r"my table: row \(mode theta, action to_mode_r\).*negative"
    with pytest.raises(ProbabilityTableError, match=expected):
        interface.validate_mapping_table(table, "my table")


def test_distortion_row_not_summing_to_one_is_named() -> None:
    table = interface.default_distortion_table()
    table[interface.SOFT_SIP, 0] += 0.1
    with pytest.raises(ProbabilityTableError, match=r"p\(phi_m \| phi_i\): row 'Soft Sip' sums to 1\.1"):
        interface.validate_distortion_table(table)


@pytest.mark.parametrize("shape", [(4, 4, 4), (3, 4), (3, 4, 5)])
def test_wrong_shape_is_rejected(shape: tuple[int, ...]) -> None:
    with pytest.raises(ProbabilityTableError, match=r"p\(phi_i \| a\): expected shape \(3, 4, 4\)"):
        interface.validate_mapping_table(np.full(shape, 0.25))


def test_non_finite_entry_and_error_hierarchy() -> None:
    table = interface.default_distortion_table()
    table[0, 0] = np.nan
    with pytest.raises(ProbabilityTableError, match="'Hard Puff' has a non-finite entry") as info:
        interface.validate_distortion_table(table)
    assert isinstance(info.value, NudgeError) and isinstance(info.value, ValueError)


def test_dict_readers_validate() -> None:
    data = interface.distortion_table_to_dict(interface.default_distortion_table())
    data["Hard Puff"]["Soft Puff"] = 0.5
    with pytest.raises(ProbabilityTableError, match="'Hard Puff'"):
        interface.distortion_table_from_dict(data)
    mapping = interface.mapping_table_to_dict(interface.default_mapping_table())
    np.testing.assert_array_equal(interface.mapping_table_from_dict(mapping),
                                  interface.default_mapping_table())
