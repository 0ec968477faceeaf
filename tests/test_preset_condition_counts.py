"""A preset's words for how many conditions it holds (``nudge presets``' description, a plan's
header comment) match its ``conditions``: the baselines plan said "Six conditions (the paper's two
and four baselines)" over its seven, turn-taking included."""

from __future__ import annotations

import re
import tomllib

import pytest

from nudgecli.config_files import list_presets

NUMBERS = {"two": 2, "three": 3, "four": 4, "five": 5, "six": 6, "seven": 7, "eight": 8, "nine": 9,
           "ten": 10}
#: "<number> conditions" and "<number> baselines", in words or digits (not "the paper's two
#: conditions", which are the paper's).
COUNTED = re.compile(r"(?<!paper's )\b(\w+) (conditions|baselines)\b", re.IGNORECASE)


def _conditions(kind: str, path) -> list[str]:
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    return list((data.get("study", {}) if kind == "experiments" else data).get("conditions", []))


def _counts(text: str) -> list[tuple[int, str]]:
    found = []
    for word, noun in COUNTED.findall(text):
        number = NUMBERS.get(word.lower()) or (int(word) if word.isdigit() else None)
        if number is not None:
            found.append((number, noun.lower()))
    return found


def _described() -> list[tuple[str, str]]:
    return [(kind, name) for kind in ("experiments", "analysis") for name in list_presets(kind)]


@pytest.mark.parametrize(("kind", "name"), _described())
def test_the_number_of_conditions_a_preset_states_is_its_number(kind: str, name: str) -> None:
    path = list_presets(kind)[name]
    conditions = _conditions(kind, path)
    paper = [c for c in conditions if c in ("disambiguation", "control")]
    for number, noun in _counts(path.read_text(encoding="utf-8")):
        # "the paper's two and N baselines": the baselines are the conditions beside the paper's
        expected = len(conditions) - len(paper) if noun == "baselines" else len(conditions)
        assert number == expected, f"{path.name}: {number} {noun}, but conditions lists {conditions}"


def test_the_baselines_plan_and_experiment_count_seven_conditions() -> None:
    for kind in ("experiments", "analysis"):
        path = list_presets(kind)["baselines"]
        assert len(_conditions(kind, path)) == 7
        assert (7, "conditions") in _counts(path.read_text(encoding="utf-8")), path
