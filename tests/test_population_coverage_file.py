"""``nudge plot-population`` writes the coverage table it prints into ``--out`` as
``coverage.txt`` (the bytes of its table output), one of its own outputs: docs/people.md's
command for results/population made no coverage.txt, the page's "table", and was refused there
("exists and is not empty") because of the coverage.txt kept beside the figure."""

from __future__ import annotations

import re
from pathlib import Path

from cli_helpers import nudge

import nudgecli
from nudgecli.api.population import is_population_file

ROOT = Path(__file__).resolve().parents[1]
SMALL = ["plot-population", "smoke", "--participants", "2", "--seed", "4", "--formats", "png"]


def test_the_coverage_file_holds_the_table_the_command_prints(tmp_path: Path) -> None:
    printed = nudge(*SMALL, "--out", tmp_path / "cli")
    assert printed.exit_code == 0, printed.output
    assert (tmp_path / "cli" / "coverage.txt").read_text(encoding="utf-8") == printed.stdout
    # --format chooses what is printed; the file is the table either way
    as_csv = nudge(*SMALL, "--format", "csv", "--out", tmp_path / "csv")
    assert as_csv.exit_code == 0 and as_csv.stdout.startswith("stream,label,")
    table = (tmp_path / "cli" / "coverage.txt").read_bytes()
    assert (tmp_path / "csv" / "coverage.txt").read_bytes() == table
    made = nudgecli.plot_population("smoke", participants=2, seed=4, out=tmp_path / "api", formats="png")
    assert (tmp_path / "api" / "coverage.txt").read_bytes() == table
    assert made.coverage_text() == printed.stdout
    assert tmp_path / "api" / "coverage.txt" in made.files


def test_a_folder_with_an_earlier_coverage_file_is_written_again_without_force(tmp_path: Path) -> None:
    out = tmp_path / "population"
    out.mkdir()
    (out / "coverage.txt").write_text("an earlier call's table\n")
    again = nudge(*SMALL, "--out", out)
    assert again.exit_code == 0, again.output
    assert (out / "coverage.txt").read_text(encoding="utf-8") == again.stdout


def test_the_documented_command_makes_the_tracked_folder() -> None:
    page = (ROOT / "docs" / "people.md").read_text(encoding="utf-8")
    commands = re.findall(r"^nudge plot-population .*--out results/population$", page, re.MULTILINE)
    assert commands == ["nudge plot-population paper --participants 100 --out results/population"]
    tracked = sorted(path.name for path in (ROOT / "results" / "population").iterdir())
    assert "coverage.txt" in tracked
    assert all(is_population_file(name) for name in tracked), tracked  # rerun there, no --force needed
