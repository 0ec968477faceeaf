"""The batch functions' arguments: ``power``'s counts may be a NumPy array of integers (docs/api.md
says NumPy's integers are whole numbers), a refusal names the item at fault, and ``Batch.summary``
says what it is for every kind of sweep; ``replicate`` refuses a study of one participant, as
``power`` does."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from nudgecli.api import arguments
from nudgecli.api.batches import Batch
from nudgecli.errors import ConfigError


def test_a_one_dimensional_integer_array_is_a_list_of_whole_numbers() -> None:
    made = arguments.whole_numbers("participants", np.array([2, 3], dtype=np.int32))
    assert made == [2, 3] and all(type(n) is int for n in made)
    assert arguments.whole_numbers("participants", range(2, 5)) == [2, 3, 4]


@pytest.mark.parametrize(("value", "got"), [
    ([2, 3.0], "a list whose item 1 is 3.0 (a float)"),
    ((2, True), "a tuple whose item 1 is True (a bool)"),
    (np.array([2.0, 3.5]), "an array of float64"),
    (np.array([[2, 3]]), "an array of 2 dimensions"),
    ("2,3", "str")])
def test_a_refused_list_names_its_item_at_fault(value: object, got: str) -> None:
    # before: "..., not list" for a list (which is one) and "not ndarray" for an array of integers
    with pytest.raises(ConfigError) as raised:
        arguments.whole_numbers("participants", value)
    assert str(raised.value) == (f"participants={value!r}: participants= takes a list of whole numbers, "
                                 f"e.g. [6, 9, 12], not {got}")


def test_the_summary_of_a_sensitivity_sweep_is_said_to_be_its_indices() -> None:
    # a Sobol or Morris sweep's summary is its sensitivity table, not a table per design point
    assert "sensitivity" in (Batch.summary.__doc__ or "")


@pytest.mark.parametrize("kwargs", [{"participants": 1}, {"overrides": ["study.participants=1"]}])
def test_replicate_refuses_one_participant_as_power_does(tmp_path: Path, kwargs: dict[str, Any]) -> None:
    # it ran, and every participant-level column of its tables was NaN
    from nudgecli.runs.batch_kinds import power, replicate

    with pytest.raises(ConfigError) as refused:
        replicate("smoke", 1, tmp_path / "out", **kwargs)
    assert str(refused.value) == ("--participants: give a count of at least 2 (one participant has no "
                                  "participant-level test), e.g. --participants 12")
    assert not (tmp_path / "out").exists()
    with pytest.raises(ConfigError, match=r"^--participants: give counts of at least 2 \(one participant"):
        power("smoke", [1, 4], 1, tmp_path / "out")
