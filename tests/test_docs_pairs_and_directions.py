"""Two statements of the docs against the code they describe: how the figures show the pairs
(README; :mod:`nudgecli.report.pair_display`) and which of the paper's results the power curves
take a direction from (docs/batches.md; :data:`nudgecli.report.replication.PAPER_DIRECTIONS`)."""

from __future__ import annotations

import re
from pathlib import Path

from nudgecli.report.pair_display import LETTERS_FROM_CONDITIONS, pair_display
from nudgecli.report.replication import PAPER_DIRECTIONS

ROOT = Path(__file__).resolve().parents[1]


def unwrapped(text: str) -> str:
    """Markdown text with its line breaks and indentation as single spaces."""
    return " ".join(text.split())


def figure_sentence(readme: str) -> str:
    """The README's sentence on how the figures show the pairs of conditions."""
    (sentence,) = re.findall(r"Figures [^.]*bracket[^.]*\.", unwrapped(readme))
    return sentence


def check_figure_sentence(readme: str) -> None:
    sentence = figure_sentence(readme)
    # brackets up to three conditions, letters from four, brackets again with --reference
    assert pair_display(LETTERS_FROM_CONDITIONS - 1) == "pairs"
    assert pair_display(LETTERS_FROM_CONDITIONS) == "letters"
    assert pair_display(LETTERS_FROM_CONDITIONS, "control") == "reference"
    assert "bracket significant pairs" in sentence
    assert f"{LETTERS_FROM_CONDITIONS}+ conditions get letters unless `--reference`" in sentence


def check_power_directions(doc: str) -> None:
    text = unwrapped(doc)
    # the metrics' names in the doc's list of the paper's directions
    named = {"strength": "assistance_strength", "mode switches": "mode_switches", "effort": "human_effort",
             "completion time": "completion_time", "turns": "human_turns"}
    listed = re.search(r"The paper's directions: ([^;]+) higher; ([^.]+) lower\.", text)
    assert listed is not None
    higher = {named[n] for n in re.split(r", | and ", listed.group(1))}
    lower = {named[n] for n in re.split(r", | and ", listed.group(2))}
    assert higher == {m for m, s in PAPER_DIRECTIONS.items() if s == +1}
    assert lower == {m for m, s in PAPER_DIRECTIONS.items() if s == -1}
    # the rest count either way: engagement was tested (Sec. 6: "We do not observe any
    # statistically significant difference"), success only reported as two rates
    assert {m for m, s in PAPER_DIRECTIONS.items() if s is None} == {"assistance_engagement", "success"}
    assert ("For engagement the paper finds no significant difference and for success it gives only "
            "the rates (93.05 % and 90.2 %, no test), so for both either direction counts.") in text
    assert "reports no test" not in text


def test_readme_says_four_or_more_conditions_are_shown_by_letters() -> None:
    check_figure_sentence((ROOT / "README.md").read_text(encoding="utf-8"))


def test_batches_doc_states_the_paper_directions_the_power_curves_use() -> None:
    check_power_directions((ROOT / "docs" / "batches.md").read_text(encoding="utf-8"))
