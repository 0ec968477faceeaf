"""`nudge plot-population` into its default `--out .` (or any folder) holding other files is refused
without `--force`, as every `--out` and `simulate`'s folder are (issue 38's leftovers)."""

from __future__ import annotations

from cli_helpers import one_error_line
from click.testing import CliRunner

from nudgecli.cli import main
from nudgecli.run_folder_names import LOCK


def _invoke(args: list[str]):
    return CliRunner().invoke(main, args)


def _never(*args, **kwargs):
    raise AssertionError("computed before the output folder was checked")


def test_plot_population_refuses_a_default_out_holding_other_files(tmp_path, monkeypatch):
    import nudgecli.sim.real_population as real_population

    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("the lab's notes")
    monkeypatch.setattr(real_population, "simulated_diagonals", _never)
    refused = _invoke(["plot-population", "smoke", "--participants", "1", "--formats", "png"])
    assert refused.exit_code == 1
    assert one_error_line(refused.output) == (
        "Error: .: exists and is not empty; choose another --out or use --force"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_plot_population_writes_into_a_folder_of_its_own_outputs_or_with_force(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    first = _invoke(["plot-population", "smoke", "--participants", "1", "--formats", "png"])
    assert first.exit_code == 0, first.output
    own = sorted(p.name for p in tmp_path.iterdir())
    assert own == ["coverage.txt", "population.csv", "population.png", "population_habits.csv"]
    (tmp_path / LOCK).write_text("")  # a lock left behind does not count either
    again = _invoke(["plot-population", "smoke", "--participants", "1", "--formats", "png"])
    assert again.exit_code == 0, again.output  # its own earlier outputs are replaced
    (tmp_path / "notes.txt").write_text("the lab's notes")
    assert _invoke(["plot-population", "smoke", "--participants", "1", "--formats", "png"]).exit_code == 1
    forced = _invoke(["plot-population", "smoke", "--participants", "1", "--formats", "png", "--force"])
    assert forced.exit_code == 0, forced.output
    assert (tmp_path / "notes.txt").read_text() == "the lab's notes"  # nothing else touched
