"""Every command's ``--seed`` refuses a negative seed the same way: one ``Error:`` line naming
``--seed``, exit 1, nothing written (as a user's mistake in the value of an option, README's
convention), never click's usage error (exit 2) for some commands and this line for the others."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli import api
from nudgecli.cli import main
from nudgecli.errors import ConfigError
from nudgecli.rng import check_seed

TABLE = str(Path(__file__).parent / "data" / "metrics_two_conditions.csv")
REFUSAL = "Error: --seed must be a non-negative integer, got -1"

COMMANDS = {
    "analyze": ["analyze", TABLE, "--out", "{out}"],
    "compare": ["compare", TABLE, TABLE, "--out", "{out}"],
    "plot-population": ["plot-population", "smoke", "--participants", "2", "--out", "{out}"],
    "simulate": ["simulate", "smoke", "--participants", "1", "--out", "{out}"],
    "replicate": ["replicate", "smoke", "-R", "1", "--out", "{out}"],
    "validate": ["validate", "--simulations", "1", "--out", "{out}"],
}


@pytest.mark.parametrize("command", COMMANDS.values(), ids=COMMANDS.keys())
def test_a_negative_seed_is_one_error_line_and_exit_1_for_every_command(tmp_path: Path,
                                                                          command: list[str]) -> None:
    out = tmp_path / "out"
    args = [word.format(out=out) for word in command]
    result = CliRunner().invoke(main, [*args, "--seed", "-1"])
    assert result.exit_code == 1, result.output
    assert result.stderr == REFUSAL + "\n"
    assert not out.exists()


@pytest.mark.parametrize("option_type", ["analyze", "compare", "plot-population"])
def test_the_seed_options_are_plain_integers_not_click_ranges(option_type: str) -> None:
    # a range would be click's usage error (exit 2) again; the help shows no range either
    result = CliRunner().invoke(main, [option_type, "--help"])
    seed_help = next(line for line in result.output.splitlines() if "--seed" in line)
    assert "INTEGER" in seed_help and ">=" not in seed_help


def test_the_seed_rule() -> None:
    check_seed(0)
    check_seed(None)  # the plan's or the experiment's seed
    check_seed(2**63)
    with pytest.raises(ConfigError, match=r"^--seed must be a non-negative integer, got -1$"):
        check_seed(-1)


def test_the_api_refuses_a_negative_seed_with_the_same_line(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"^--seed must be a non-negative integer, got -3$"):
        api.analyze(TABLE, seed=-3, out=tmp_path / "a")
    with pytest.raises(ConfigError, match=r"^--seed must be a non-negative integer, got -3$"):
        api.compare(TABLE, TABLE, seed=-3)
    assert not (tmp_path / "a").exists()
