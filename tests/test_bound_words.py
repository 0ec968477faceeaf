"""A bound of a configuration field (``Field(le=10_000)``) is said in the house's words, for --set
and for the option that sets the field (--participants) alike."""

from __future__ import annotations

from pathlib import Path

import pytest
from cli_helpers import nudge, one_error_line


@pytest.mark.parametrize(("args", "said"), [
    (("--participants", "10001"), "--participants 10001: study.participants: must be at most 10000 "),
    (("--set", "study.participants=10001"), "study.participants: must be at most 10000 (got 10001)"),
    (("--set", "study.participants=0"), "study.participants: must be at least 1 (got 0)"),
    (("--set", "assistance.rho3=2"), "assistance.rho3: must be at most 1.0 (got 2)"),
])
def test_a_bound_is_said_in_the_house_words(tmp_path: Path, args: tuple[str, ...], said: str) -> None:
    result = nudge("simulate", "smoke", *args, "--out", tmp_path / "out")
    line = one_error_line(result.output)
    assert result.exit_code == 1 and said in line, line
    assert "Input should" not in line and not (tmp_path / "out").exists()
