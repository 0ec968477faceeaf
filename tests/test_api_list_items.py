"""A list argument of the Python API whose list is right but an item is not names that item and
its type (docs/api.md), as ``power(participants=[2, "3"])`` does; bytes are refused as a text is
(``overrides=b"x"`` was iterated as the numbers 120 and read as the override '120')."""

from __future__ import annotations

import pytest

import nudgecli
from nudgecli.api import arguments
from nudgecli.api.run import override_texts
from nudgecli.errors import ConfigError


@pytest.mark.parametrize(("keyword", "value", "message"), [
    ("metrics", [5], "metrics=[5]: metrics= takes a list of texts, e.g. ['a', 'b'] or None, not a list "
                     "whose item 0 is 5 (an int)"),
    ("match", ["participant", 5.0], "match=['participant', 5.0]: match= takes a list of texts, e.g. "
                                    "['a', 'b'] or None, not a list whose item 1 is 5.0 (a float)"),
])
def test_compare_names_the_first_item_that_is_no_text(keyword: str, value: object, message: str) -> None:
    with pytest.raises(ConfigError) as caught:
        nudgecli.compare("no-such-run", "real.csv", **{keyword: value})
    assert str(caught.value) == message


def test_bytes_are_no_list_of_texts() -> None:
    with pytest.raises(ConfigError) as caught:
        arguments.texts("metrics", b"success", optional=True)
    assert str(caught.value) == ("metrics=b'success': metrics= takes a list of texts, e.g. ['a', 'b'] "
                                 "or None, not bytes")


def test_overrides_given_as_bytes_are_refused_as_a_text_is() -> None:
    refusal = ("overrides={!r}: give a list of KEY=VALUE texts or a mapping, "
               "e.g. {{'disambiguation.window': 5}}")
    for overrides in ("x", b"x"):
        with pytest.raises(ConfigError) as caught:
            override_texts(overrides)  # type: ignore[arg-type]
        assert str(caught.value) == refusal.format(overrides)
    with pytest.raises(ConfigError) as caught:  # before any work
        nudgecli.simulate("smoke", participants=2, overrides=b"x")  # type: ignore[arg-type]
    assert str(caught.value) == refusal.format(b"x")
