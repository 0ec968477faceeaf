"""A sweep file's numbers are read as written, as an experiment file's are (the one rule:
nudgecli.config_base.Section): true/false, text or a whole number with a decimal point where a
number goes is refused naming the key (was: ``replications = true`` ran 1 replication, ``seed =
11.0`` seed 11, ``{ low = "0.5", high = true }`` the range 0.5-1.0)."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.errors import ConfigError
from nudgecli.runs.sweep import load_sweep

SWEEP = """\
experiment = "smoke"
replications = {replications}
seed = {seed}

[design]
method = "sobol"
samples = {samples}

[parameters]
"inference.kappa" = {kappa}
"""
WRITTEN = {"replications": "1", "seed": "11", "samples": "2", "kappa": "{ low = 0.5, high = 0.8 }"}


@pytest.mark.parametrize(("key", "value", "message"), [
    ("replications", "true", "replications = true: give a number, not true/false"),
    ("seed", "11.0", "seed: give a whole number, no decimal point (got 11.0)"),
    ("samples", '"2"', 'design.samples: give a number, not text: no quotes (got "2")'),
    ("kappa", '{ low = "0.5", high = 0.8 }', 'parameters.inference.kappa: low: give a number, not text'),
    ("kappa", "{ low = 0.5, high = true }", "parameters.inference.kappa: high = true: give a number, not "
                                            "true/false"),
])
def test_a_number_written_as_true_text_or_a_decimal_is_refused(tmp_path: Path, key: str, value: str,
                                                               message: str) -> None:
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.format(**{**WRITTEN, key: value}))
    with pytest.raises(ConfigError) as refused:
        load_sweep(str(path))
    assert str(refused.value).startswith(f"{path}: {message}")


def test_numbers_as_written_still_load(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text(SWEEP.format(**{**WRITTEN, "kappa": "{ low = 0.5, high = 1 }"}))  # an integer end
    sweep = load_sweep(str(path))
    assert (sweep.spec.replications, sweep.spec.seed, sweep.spec.design.samples) == (1, 11, 2)
    assert len(sweep.points) == 2 * (1 + 2)  # Saltelli: N (D + 2)
