"""``study.goal_counts`` below 2 is refused for what it is (one goal fits the goal regions: the agent
has nothing to infer), above 8 because the goals do not fit."""

from __future__ import annotations

import pytest

from nudgecli.config import load_experiment
from nudgecli.errors import ConfigError


def test_one_goal_is_refused_as_nothing_to_infer_not_as_not_fitting():
    with pytest.raises(ConfigError) as error:
        load_experiment("smoke", ["study.goal_counts=[1]"])
    message = str(error.value)
    assert "do not fit" not in message
    assert "1 goal leaves the agent nothing to infer" in message and "use 2 to 8" in message
    assert "\n" not in message


def test_no_goals_and_too_many_goals_say_their_own_reasons():
    with pytest.raises(ConfigError, match=r"0 goals make no layout.*use 2 to 8"):
        load_experiment("smoke", ["study.goal_counts=[0, 3]"])
    with pytest.raises(ConfigError, match="9 goals do not fit the goal regions; use 2 to 8"):
        load_experiment("smoke", ["study.goal_counts=[3, 9]"])
