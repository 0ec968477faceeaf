"""`nudge fit --out` over an existing profile is refused without `--force` (issue 38's leftovers)."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner
from run_builders import hard_puff_mapping

from nudgecli.cli import main


def _invoke(args: list[str]):
    return CliRunner().invoke(main, args)


@pytest.fixture(scope="module")
def calibration_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One participant's mapping session (every prompt answered Hard Puff), as `nudge fit` reads it."""
    return hard_puff_mapping(tmp_path_factory.mktemp("calibration"))


def test_fit_refuses_to_replace_a_profile_without_force(tmp_path, calibration_dir, monkeypatch):
    target = tmp_path / "p.json"
    target.write_text("a profile fitted before\n")
    refused = _invoke(["fit", str(calibration_dir), "--out", str(target)])
    assert refused.exit_code == 1
    assert one_error_line(refused.output) == (
        f"Error: {target}: exists; choose another --out or use --force to replace it"
    )
    assert target.read_text() == "a profile fitted before\n"
    # the default target, ./<folder>.profile.json, alike
    monkeypatch.chdir(tmp_path)
    default = tmp_path / f"{calibration_dir.name}.profile.json"
    default.write_text("{}")
    assert _invoke(["fit", str(calibration_dir)]).exit_code == 1 and default.read_text() == "{}"
    # --force replaces it; a new name needs nothing
    forced = _invoke(["fit", str(calibration_dir), "--out", str(target), "--force"])
    assert forced.exit_code == 0, forced.output
    assert '"p_phi_given_a"' in target.read_text()
    fresh = _invoke(["fit", str(calibration_dir), "--out", str(tmp_path / "new.json")])
    assert fresh.exit_code == 0 and (tmp_path / "new.json").is_file()
