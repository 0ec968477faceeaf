"""A TOML value has one rendering, :func:`nudgecli.config_files.toml_value`: a ``--set`` text built
from a notebook's value (``nudgecli.api.run.toml_literal``, NumPy's values converted first) and a
refused policy parameter's message (its table keys quoted where TOML needs it) use it."""

from __future__ import annotations

import datetime

import numpy as np
import pytest

from nudgecli.api.run import toml_literal
from nudgecli.config_files import toml_value
from nudgecli.config_policies import _toml_text


@pytest.mark.parametrize("value", ["tab\there", "new\nline", 'say "hi"', {"a b": 1, "c": [1.5, "x"]},
                                   {"": True}, [float("inf"), -0.0]])
def test_a_set_text_is_the_one_rendering_of_its_value(value: object) -> None:
    assert toml_literal(value) == toml_value(value)


def test_numpy_values_are_rendered_as_pythons() -> None:
    assert toml_literal({"w": np.float64(0.5), "n": np.array([np.int32(1), 2])}) == "{w = 0.5, n = [1, 2]}"


def test_a_policy_parameters_table_keys_are_quoted_where_toml_needs_it() -> None:
    value = {"since when": datetime.date(2026, 1, 31), "ok": ["x"]}
    assert _toml_text(value) == '{"since when" = 2026-01-31, ok = ["x"]}'
    assert _toml_text(value, dates_quoted=True) == '{"since when" = "2026-01-31", ok = ["x"]}'
