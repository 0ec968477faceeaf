"""`nudge fit --out` over an existing profile is refused without `--force` (issue 38's leftovers);
a failed `nudge fit` or `fit-people` makes none of the folders of its `--out`."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import one_error_line
from click.testing import CliRunner
from run_builders import hard_puff_mapping

from nudgecli.cli import main

PILOT = Path(__file__).resolve().parents[1] / "experiments" / "pilots" / "pilot-1.csv"


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


@pytest.mark.parametrize("command", ["fit", "fit-people"])
def test_a_failed_fit_makes_no_folder_of_its_out(tmp_path: Path, command: str) -> None:
    # before: the folders of --out were made (to check that they are writable) before the sources were read
    refused = _invoke([command, str(tmp_path / "nothere"), "--out", str(tmp_path / "new" / "sub" / "p.out")])
    assert refused.exit_code == 1 and "no such" in one_error_line(refused.output), refused.output
    assert list(tmp_path.iterdir()) == []


def test_fit_and_fit_people_make_the_folders_of_their_out_when_they_write(tmp_path: Path,
                                                                          calibration_dir: Path) -> None:
    for args, out in ((["fit", str(calibration_dir)], tmp_path / "a" / "b" / "p.json"),
                      (["fit-people", str(PILOT)], tmp_path / "c" / "d" / "people.csv")):
        result = _invoke([*args, "--out", str(out)])
        assert result.exit_code == 0 and out.is_file(), result.output
