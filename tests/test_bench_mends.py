"""``nudge bench`` and the size guard's estimate: the doc's targets, the bench's failing children,
its options and the estimate's arithmetic (nothing is timed here)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from nudgecli.bench import targets
from nudgecli.cli import main

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_performance_doc_gives_the_study_target_the_code_checks() -> None:
    text = (DOCS / "performance.md").read_text(encoding="utf-8")
    study = next(line for line in text.splitlines() if line.startswith("| paper-scale study, 432 trials"))
    target = study.split("|")[2]
    seconds = float(re.search(r"<= ([\d.]+) s", target).group(1))  # type: ignore[union-attr]
    assert seconds == targets.STUDY_WALL_TARGET_S  # it said 20 s


@pytest.mark.parametrize("option", [["--scale-participants", "64"], ["--scale-studies", "4"],
                                    ["--scale-workers", "1,2"]])
def test_bench_refuses_scale_options_without_only_scale(option: list[str]) -> None:
    result = CliRunner().invoke(main, ["bench", "--only", "model", *option])
    assert result.exit_code == 2  # was 0: --scale-participants and --scale-studies were ignored
    assert f"{option[0]} times the scale figures: add --only scale" in result.output
