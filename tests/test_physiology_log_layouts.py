"""A population.physiology_logs folder that is not there is refused in one line naming every layout
a folder may hold its p(phi_m | phi_i) session in (calibration_readers.DISTORTION_LAYOUTS)."""

from __future__ import annotations

from pathlib import Path

from cli_helpers import nudge, one_error_line


def test_a_missing_physiology_log_folder_names_every_layout_read(tmp_path: Path) -> None:
    result = nudge("simulate", "smoke", "--set", f'population.physiology_logs=["{tmp_path / "nope"}"]',
                   "--out", tmp_path / "out")
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "population.physiology_logs[0]" in line and "does not exist" in line
    for layout in ("p_phm_given_phi/_command_prompt.csv + _joy_sip_puff.csv", "<id>_p_um_given_ui/",
                   "distortion_prompts.csv + distortion_stream.csv", "calibration/participant-NNNN"):
        assert layout in line, line
    assert not (tmp_path / "out").exists()
