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


def test_a_row_sum_is_checked_to_one_millionth() -> None:
    # within 1e-6 of 1 a row passes; 2e-6 off it is named (the row loop has the fast check's tolerance)
    table = interface.default_distortion_table()
    table[interface.SOFT_SIP, 0] += 5e-7
    interface.validate_distortion_table(table)
    table[interface.SOFT_SIP, 0] += 1.5e-6
    with pytest.raises(ProbabilityTableError, match=r"row 'Soft Sip' sums to 1\.000002, not 1"):
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


# Pressure -> label at the edges of the bands (DESIGN 2.2): |p| < 0.002 no input, soft up to and
# including 0.3, hard strictly above 0.5, deadband in between; sip positive, puff negative.
_SIP_EDGES = [
    (0.0, interface.NO_INPUT), (0.0019, interface.NO_INPUT), (0.002, interface.SOFT_SIP),
    (0.3, interface.SOFT_SIP), (0.3000001, interface.SIP_DEADBAND), (0.5, interface.SIP_DEADBAND),
    (0.5000001, interface.HARD_SIP), (1.0, interface.HARD_SIP),
]
_PUFF_OF = {interface.NO_INPUT: interface.NO_INPUT, interface.SOFT_SIP: interface.SOFT_PUFF,
            interface.SIP_DEADBAND: interface.PUFF_DEADBAND, interface.HARD_SIP: interface.HARD_PUFF}


@pytest.mark.parametrize(("pressure", "sip_label"), _SIP_EDGES)
def test_pressure_bands_at_their_edges(pressure: float, sip_label: int) -> None:
    for value, expected in ((pressure, sip_label), (-pressure, _PUFF_OF[sip_label])):
        assert interface.label_of_pressure(value) == expected
        assert int(interface.label_pressure(value)) == expected
    both = interface.label_pressure(np.array([pressure, -pressure]))
    assert both.tolist() == [sip_label, _PUFF_OF[sip_label]]


def test_study_thresholds_move_the_band_edges() -> None:
    study = {"soft_threshold": interface.SOFT_THRESHOLD_STUDY,
             "hard_threshold": interface.HARD_THRESHOLD_STUDY}
    pressures = [0.4, 0.4000001, 0.6, 0.6000001]
    expected = [interface.SOFT_SIP, interface.SIP_DEADBAND, interface.SIP_DEADBAND, interface.HARD_SIP]
    assert [interface.label_of_pressure(p, **study) for p in pressures] == expected
    assert interface.label_pressure(np.array(pressures), **study).tolist() == expected


def test_hard_puff_cycles_forward_and_hard_sip_back() -> None:
    # x -> y -> theta -> x on Hard Puff, the reverse on Hard Sip; other labels keep the mode
    assert [interface.switch_mode(m, interface.HARD_PUFF) for m in range(3)] == [1, 2, 0]
    assert [interface.switch_mode(m, interface.HARD_SIP) for m in range(3)] == [2, 0, 1]
    for label in (interface.SOFT_PUFF, interface.SOFT_SIP, interface.NO_INPUT, interface.PUFF_DEADBAND):
        assert [interface.switch_mode(m, label) for m in range(3)] == [0, 1, 2]
