"""The documents say what is true: the counts they quote are the data's, the rules they state are
the code's, one measurement has one range everywhere, and a measured time carries its date."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from nudgecli.sim import policy_registry

ROOT = Path(__file__).resolve().parents[1]
NUMBER_WORDS = {9: "nine", 10: "ten", 11: "eleven", 12: "twelve", 13: "thirteen"}
DATE = r"20\d\d-\d\d-\d\d"


def page(name: str) -> str:
    """A document's text, white space collapsed (a sentence may wrap anywhere)."""
    return " ".join((ROOT / name).read_text(encoding="utf-8").split())


def real_calibration_count() -> int:
    """The real people the population's coverage table compares with, summed over its
    ``real_source`` column (``2 pilots (andrewtest, deepaktest)``, ``9 sibling-study participants``)."""
    table = (ROOT / "results" / "population" / "coverage.txt").read_text(encoding="utf-8")
    sources = set(re.findall(r"(\d+) (?:pilots \([^)]*\)|sibling-study participants)", table))
    return sum(int(n) for n in sources)


def test_the_real_calibrations_counted_are_the_coverage_tables() -> None:
    word = NUMBER_WORDS[real_calibration_count()]
    quoted = re.findall(r"(\w+) real people's (?:prompt-and-produce )?calibrations"
                        r"|calibrations beside (\w+) real", page("README.md") + " " + page("docs/people.md"))
    quoted = ["".join(groups) for groups in quoted]
    counts = [q.lower() for q in quoted if q.isdigit() or q.lower() in NUMBER_WORDS.values()]
    assert len(counts) >= 3
    assert set(counts) == {word}


def test_the_constant_metrics_rule_names_its_owner_and_the_gated_blend() -> None:
    text = page("docs/baselines.md")
    rule = text[text.index("**Metrics a policy makes constant**"):]
    rule = rule[:rule.index("**Reading the results")]
    owner = re.search(r"`nudgecli\.sim\.policy_registry\.(\w+)`", rule)
    assert owner is not None and callable(getattr(policy_registry, owner.group(1), None))
    assert owner.group(1) == policy_registry.constant_metrics_of.__name__
    for part in ('`gate = "gap"`', "distance weighting", "rho2_factor <= gap (G - 1) + 1", "0 or `rho3`",
                 '`trigger = "request"`', "`constant_metrics`"):
        assert part in rule, part


def test_one_start_up_measurement_has_one_range_everywhere() -> None:
    readme, performance = page("README.md"), page("docs/performance.md")
    row = re.search(r"a fresh process \(dask, spawn\) \| <= 0\.5 s \| ([\d.]+-[\d.]+ ms) / ([\d.]+-[\d.]+ s) "
                    r"\(([\d.]+-[\d.]+ s) with scipy", readme)
    assert row is not None
    pool, fresh, with_scipy = row.groups()
    assert f"| a worker of the local pool ready (forked) | <= 0.5 s | {pool} | met |" in performance
    status = re.search(r"\| a fresh worker's imports \(dask, spawn\) \| <= 0\.5 s \| ([^|]*)\|", performance)
    assert status is not None
    assert status.group(1).startswith(fresh) and f"({with_scipy} from" in status.group(1)


@pytest.mark.parametrize("name", ["README.md", "docs/reliability.md"])
def test_the_broken_pipe_example_allows_an_output_that_was_all_written(name: str) -> None:
    # `nudge presets | head -1` exits 0 where the whole output fits the pipe before head leaves
    text = page(name)
    for hit in re.finditer(r"quietly with 141", text):
        around = text[max(0, hit.start() - 200):hit.end() + 300]
        assert "before" in around and ("exit 0" in around or "was written" in around), around


@pytest.mark.parametrize(("name", "figure"), [
    ("README.md", "on one core"),
    ("README.md", "7.5 min on 2 cores"),
    ("docs/development.md", "7.5 min on 2 cores"),
    ("docs/people.md", "# simulate, analyse and plot"),
    ("docs/api.md", "three participants took"),
    ("docs/findings.md", "`--all-readings --seed 0` took"),
])
def test_a_measured_time_carries_its_date(name: str, figure: str) -> None:
    text = page(name)
    at = text.index(figure)
    assert re.search(DATE, text[at:at + 120]), text[at:at + 120]


def test_every_figure_of_the_performance_lead_table_is_dated() -> None:
    text = (ROOT / "docs" / "performance.md").read_text(encoding="utf-8")
    table = text[text.index("| what | target | measured on this 2-core machine |"):]
    rows = table[:table.index("\n\n")].splitlines()[2:]
    assert len(rows) == 6
    for row in rows:
        for figure in top_level_items(row.split("|")[3]):
            assert re.search(DATE, figure), (figure, row)


def top_level_items(text: str) -> list[str]:
    """The ``;``-separated items of a table cell, a ``;`` inside parentheses kept in its item."""
    items, depth, start = [], 0, 0
    for at, char in enumerate(text):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if char == ";" and depth == 0:
            items.append(text[start:at])
            start = at + 1
    return [item for item in [*items, text[start:]] if item.strip()]
