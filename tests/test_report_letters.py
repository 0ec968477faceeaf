"""The compact letter display (Piepho 2004) against letters worked by hand and against a brute
force of its guarantees; how four or more conditions are shown (letters, or a reference
condition's brackets) in summary.md and the box plots, whose boxes keep at least half of each
panel's height."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Annotation
from matplotlib.transforms import Bbox
from run_builders import synthetic_run

from nudgecli.cli import main
from nudgecli.errors import ConfigError
from nudgecli.report.figures.boxplots import metrics_figure
from nudgecli.report.letters import (
    compact_letter_display,
    different_pairs,
    entry_letters,
    insert_and_absorb,
    letter_columns,
)
from nudgecli.report.pair_display import check_reference, pair_display
from nudgecli.report.plans import AnalysisPlan
from nudgecli.report.stats import ComparisonOptions
from nudgecli.report.stats_document import compare_conditions, json_ready, stats_table
from nudgecli.report.summary import format_summary

ABCD = ("A", "B", "C", "D")


# --- letters worked by hand ------------------------------------------------------------------------


def test_four_conditions_with_a_known_pattern() -> None:
    # A differs from C and D, B from D. Insert and absorb, pairs in order:
    #   start {ABCD}
    #   A-C: {ABCD} holds both -> {BCD} (A deleted), {ABD} (C deleted)
    #   A-D: {ABD} -> {BD}, {AB}; {BD} is inside {BCD}: absorbed -> {BCD}, {AB}
    #   B-D: {BCD} -> {CD}, {BC}                                   -> {CD}, {BC}, {AB}
    # nothing to sweep (every letter joins a pair no other letter joins); named by their earliest
    # condition: {AB} = a, {BC} = b, {CD} = c
    assert compact_letter_display(ABCD, [("A", "C"), ("A", "D"), ("B", "D")]) == {
        "A": "a", "B": "ab", "C": "bc", "D": "c"}
    # the same pairs in any order and orientation
    assert compact_letter_display(ABCD, [("D", "B"), ("C", "A"), ("D", "A"), ("A", "C")]) == {
        "A": "a", "B": "ab", "C": "bc", "D": "c"}


def test_nothing_or_everything_different() -> None:
    assert compact_letter_display(ABCD, []) == {c: "a" for c in ABCD}
    # every pair different: one letter each (each column shrinks to a single condition)
    assert compact_letter_display(ABCD, itertools.combinations(ABCD, 2)) == {
        "A": "a", "B": "b", "C": "c", "D": "d"}
    assert compact_letter_display(["only"], []) == {"only": "a"}
    assert compact_letter_display([], []) == {}


def test_the_sweep_removes_a_letter_no_pair_needs() -> None:
    # five conditions, B-E, C-D and D-E differ. Insert and absorb:
    #   B-E: {ABCDE} -> {ACDE}, {ABCD}
    #   C-D: {ACDE} -> {ADE}, {ACE}; {ABCD} -> {ABD}, {ABC}
    #   D-E: {ADE} -> {AE} (inside {ACE}), {AD} (inside {ABD}): both absorbed
    #   -> {ACE}, {ABD}, {ABC}: the maximal sets of conditions that do not differ
    # the sweep, in the order ABC, ABD, ACE: A's letter in {ABC} joins A-B (also in {ABD}) and A-C
    # (also in {ACE}), and A keeps other letters: deleted -> {BC}; every other letter is the only one
    # joining some pair. Named by earliest condition: {ABD} = a, {ACE} = b, {BC} = c.
    different = [("B", "E"), ("C", "D"), ("D", "E")]
    names = ["A", "B", "C", "D", "E"]
    assert sorted(sorted(c) for c in insert_and_absorb(names, different)) == [[0, 1, 2], [0, 1, 3], [0, 2, 4]]
    assert letter_columns(names, different) == [frozenset({0, 1, 3}), frozenset({0, 2, 4}), frozenset({1, 2})]
    assert compact_letter_display(names, different) == {"A": "ab", "B": "ac", "C": "bc", "D": "a", "E": "b"}


def test_pairs_naming_unknown_conditions_are_refused() -> None:
    with pytest.raises(ValueError, match="not among"):
        compact_letter_display(ABCD, [("A", "Z")])
    with pytest.raises(ValueError, match="itself"):
        compact_letter_display(ABCD, [("A", "A")])
    with pytest.raises(ValueError, match="distinct"):
        compact_letter_display(["A", "A"], [])


# --- the algorithm's guarantees, by brute force ---------------------------------------------------


@st.composite
def displays(draw: st.DrawFn) -> tuple[list[str], list[tuple[str, str]]]:
    k = draw(st.integers(1, 8))
    names = [f"c{i}" for i in range(k)]
    pairs = list(itertools.combinations(names, 2))
    different = draw(st.lists(st.sampled_from(pairs), unique=True, max_size=len(pairs))) if pairs else []
    return names, different


def _share(letters: dict[str, str], a: str, b: str) -> bool:
    return bool(set(letters[a]) & set(letters[b]))


def _faithful(letters: dict[str, str], names: list[str], different: set[frozenset[str]]) -> bool:
    """Every condition has a letter; two share one exactly when their pair is not different."""
    return all(letters[c] for c in names) and all(
        _share(letters, a, b) == (frozenset((a, b)) not in different)
        for a, b in itertools.combinations(names, 2))


@settings(max_examples=200, deadline=None)
@given(displays())
def test_letters_are_shared_exactly_by_the_pairs_that_do_not_differ(case) -> None:
    names, different = case
    letters = compact_letter_display(names, different)
    assert _faithful(letters, names, {frozenset(p) for p in different})


@settings(max_examples=200, deadline=None)
@given(displays())
def test_insert_and_absorb_gives_the_maximal_sets_of_conditions_that_do_not_differ(case) -> None:
    names, different = case
    pairs = {frozenset((names.index(a), names.index(b))) for a, b in different}

    def together(members: tuple[int, ...]) -> bool:
        return all(frozenset(p) not in pairs for p in itertools.combinations(members, 2))

    positions = range(len(names))
    cliques = [frozenset(m) for r in range(1, len(names) + 1) for m in itertools.combinations(positions, r)
               if together(m)]
    maximal = {c for c in cliques if not any(c < other for other in cliques)}
    columns = insert_and_absorb(names, different)
    assert len(columns) == len(set(columns)) and set(columns) == maximal


@settings(max_examples=200, deadline=None)
@given(displays())
def test_the_display_is_minimal_as_absorb_and_sweep_guarantee(case) -> None:
    names, different = case
    letters = compact_letter_display(names, different)
    used = sorted({letter for text in letters.values() for letter in text})
    # letters named from "a" on, in the order of their earliest condition
    assert used == list("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"[:len(used)])
    firsts = [min(i for i, c in enumerate(names) if letter in letters[c]) for letter in used]
    assert firsts == sorted(firsts)
    columns = [{c for c in names if letter in letters[c]} for letter in used]
    # absorbed: no letter's conditions lie within another letter's
    assert not any(a <= b for a, b in itertools.permutations(columns, 2))
    # swept: no condition's letter can go without breaking the display
    gone = {frozenset(p) for p in different}
    for c in names:
        for letter in letters[c]:
            assert not _faithful({**letters, c: letters[c].replace(letter, "")}, names, gone), (c, letter)


# --- from stats.json ----------------------------------------------------------------------------


def _entry(conditions: list[str], significant: set[tuple[str, str]], kruskal_p: float = 1e-6) -> dict:
    return {"kruskal": {"p": kruskal_p},
            "conover": [{"a": a, "b": b, "p": 0.001 if (a, b) in significant else 0.4, "p_unadjusted": 0.0}
                        for a, b in itertools.combinations(conditions, 2)]}


def test_letters_of_a_stats_entry_follow_the_star_rule() -> None:
    conditions = list(ABCD)
    entry = _entry(conditions, {("A", "C"), ("A", "D"), ("B", "D")})
    assert different_pairs(entry) == [("A", "C"), ("A", "D"), ("B", "D")]
    assert entry_letters(entry, conditions) == {"A": "a", "B": "ab", "C": "bc", "D": "c"}
    # Kruskal-Wallis not significant: no pair differs (no stars, as no brackets)
    gated = _entry(conditions, {("A", "C")}, kruskal_p=0.2)
    assert entry_letters(gated, conditions) == {c: "a" for c in ABCD}
    # the plan's threshold decides: 0.001 does not meet p < 0.001
    strict = ComparisonOptions(star_thresholds=(0.001,))
    assert entry_letters(entry, conditions, strict) == {c: "a" for c in ABCD}
    # the stars stats.json holds win over its p-values
    entry["stars"] = [{"a": "A", "b": "B", "stars": "*"}]
    assert ("A", "B") in different_pairs(entry) and entry_letters(entry, ["A", "B"]) == {"A": "a", "B": "b"}


def test_which_display_and_an_unknown_reference() -> None:
    assert [pair_display(k) for k in (2, 3, 4, 6)] == ["pairs", "pairs", "letters", "letters"]
    assert pair_display(6, "control") == pair_display(3, "control") == "reference"
    check_reference(None, ABCD)
    check_reference("B", ABCD)
    with pytest.raises(ConfigError) as error:
        check_reference("contrl", ["disambiguation", "control", "teleoperation"])
    message = str(error.value)
    assert "\n" not in message and "did you mean 'control'?" in message
    assert message.endswith("the conditions: disambiguation, control, teleoperation")


# --- summary.md ---------------------------------------------------------------------------------


def four_conditions(seed: int = 3, participants: int = 8, trials: int = 4) -> pd.DataFrame:
    """Trials of four conditions: A and B alike, C a little and D far above, with a participant effect
    (Conover finds A-C, A-D, B-D and C-D different, A-B and B-C not)."""
    rng = np.random.default_rng(seed)
    rows = []
    for p in range(participants):
        person = rng.normal(0, 0.5)
        for condition, shift in zip(ABCD, (0.0, 0.0, 0.6, 3.0), strict=True):
            rows += [{"participant": p, "condition": condition, "trial": t,
                      "value": 10 + person + shift + rng.normal(0, 1.0)} for t in range(trials)]
    return pd.DataFrame(rows)


def _summary(data: pd.DataFrame, conditions: list[str], reference: str | None = None) -> tuple[dict, str]:
    options = ComparisonOptions(bootstrap_resamples=100)
    stats = json_ready(compare_conditions(data, ["value"], conditions, options))
    text = format_summary(stats_table(stats), conditions, AnalysisPlan(), Path("t.csv"), n_trials=len(data),
                          n_participants=8, reference=reference)
    return stats, text


def _markdown_rows(text: str, header_start: str) -> list[list[str]]:
    lines = text.splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[first + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return rows


def test_summary_of_four_conditions_gives_each_a_letter_instead_of_every_pair() -> None:
    data = four_conditions()
    stats, text = _summary(data, list(ABCD))
    entry = stats["metrics"][0]
    starred = {(s["a"], s["b"]) for s in entry["stars"] if s["stars"]}
    assert starred == {("A", "C"), ("A", "D"), ("B", "D"), ("C", "D")}
    rows = _markdown_rows(text, "| condition | n | median [q1, q3] | mean | letters |")
    # by hand: {ABCD} -A-C-> {BCD} {ABD} -A-D-> {BCD} {AB} ({BD} absorbed) -B-D-> {CD} {BC} {AB}
    #   -C-D-> {D} {C} ({C} absorbed into {BC}) -> {D} {BC} {AB}: AB = a, BC = b, D = c
    expected = compact_letter_display(ABCD, starred)
    assert {row[0]: row[-1] for row in rows} == expected == {"A": "a", "B": "ab", "C": "b", "D": "c"}
    for a, b in itertools.combinations(ABCD, 2):  # read back: a shared letter means "not different"
        assert _share(expected, a, b) == ((a, b) not in starred)
    assert "| comparison |" not in text and "compact letter display" in text


def test_summary_with_a_reference_lists_its_pairs_only() -> None:
    data = four_conditions()
    stats, text = _summary(data, list(ABCD), reference="C")
    rows = _markdown_rows(text, "| comparison |")
    assert [row[0] for row in rows] == ["A - C", "B - C", "C - D"]
    stars = {f"{s['a']} - {s['b']}": s["stars"] or "ns" for s in stats["metrics"][0]["stars"]}
    assert [row[3] for row in rows] == [stars[row[0]] for row in rows]
    assert "| letters |" not in text and "- pairs: those of C (--reference)" in text
    # three conditions keep every pair, and summary.md is the one it always was
    three = data[data["condition"] != "D"]
    _, every = _summary(three, ["A", "B", "C"])
    assert [row[0] for row in _markdown_rows(every, "| comparison |")] == ["A - B", "A - C", "B - C"]
    assert "- pairs:" not in every and "| letters |" not in every


# --- the figure: boxes keep at least half of the panel -------------------------------------------


SIX = ["disambiguation", "control", "teleoperation", "blending", "mode-switch", "hindsight"]


def _six_condition_figure_inputs() -> tuple[pd.DataFrame, dict]:
    rng = np.random.default_rng(2)
    metrics = pd.DataFrame([{"condition": c, "completion_time": 20 + 6 * i + rng.normal(0, 2)}
                            for i, c in enumerate(SIX) for _ in range(12)])
    every_pair = [{"a": a, "b": b, "p": 1e-5, "p_unadjusted": 1e-6}
                  for a, b in itertools.combinations(SIX, 2)]
    stats = {"conditions": SIX,
             "metrics": [{"metric": "completion_time", "kruskal": {"p": 1e-9}, "conover": every_pair}]}
    return metrics, stats


def _box_share(fig) -> float:
    """The share of the panel's height the boxes and trial dots span, from their drawn extents."""
    FigureCanvasAgg(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    (ax,) = fig.get_axes()
    extents = [p.get_window_extent(renderer) for p in ax.patches]
    extents += [Bbox.null().from_extents(*ax.transData.transform(c.get_offsets()).min(axis=0),
                                         *ax.transData.transform(c.get_offsets()).max(axis=0))
                for c in ax.collections]  # the trial dots, by their centres
    data = Bbox.union(extents)
    return data.height / ax.get_window_extent(renderer).height


def test_six_conditions_keep_the_boxes_at_least_half_of_the_panel() -> None:
    metrics, stats = _six_condition_figure_inputs()
    # every one of the 15 pairs significant: as brackets they leave the boxes the bottom of the panel
    crowded = _box_share(metrics_figure(metrics, stats, ["completion_time"], comparisons="brackets"))
    assert crowded < 0.5
    lettered = metrics_figure(metrics, stats, ["completion_time"])
    assert _box_share(lettered) >= 0.5
    (ax,) = lettered.get_axes()
    marks = [t for t in ax.texts if not isinstance(t, Annotation)]
    # one letter each (every pair differs), above the data, centred on the boxes
    assert [(t.get_position()[0], t.get_text()) for t in marks] == [(float(i), "abcdef"[i]) for i in range(6)]
    assert min(t.get_position()[1] for t in marks) > metrics["completion_time"].max()
    renderer = lettered.canvas.get_renderer()
    top = ax.get_window_extent(renderer).y1
    assert all(t.get_window_extent(renderer).y1 <= top for t in marks)  # room made inside the panel
    assert not ax.lines or all("*" not in t.get_text() for t in ax.texts)
    referenced = metrics_figure(metrics, stats, ["completion_time"], reference="blending")
    assert _box_share(referenced) >= 0.5
    (ax,) = referenced.get_axes()
    assert sorted(t.get_text() for t in ax.texts if "*" in t.get_text()) == ["***"] * 5


def test_an_unknown_reference_condition_is_one_error_line(tmp_path: Path) -> None:
    conditions = {"disambiguation": 0, "control": 15, "mode-switch": 8, "blending": 4}
    run = synthetic_run(tmp_path / "run", conditions, n_participants=4, trials_per_condition=3, seed=1,
                        max_steps=30, switch_probability=lambda extra: 0.05 + extra / 200)
    runner = CliRunner()
    result = runner.invoke(main, ["analyze", str(run), "--bootstrap", "100", "--reference", "contrl"])
    assert result.exit_code == 1
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: --reference 'contrl'")
    assert "did you mean 'control'?" in lines[0]
    assert lines[0].endswith("the conditions: disambiguation, control, blending, mode-switch")
    assert not (run / "stats.json").exists()  # refused before anything was written
    result = runner.invoke(main, ["analyze", str(run), "--bootstrap", "100", "--reference", "control"])
    assert result.exit_code == 0, result.output
    # the printed table too: control's three pairs per metric, not all six
    printed = [line for line in result.output.splitlines() if " vs " in line]
    assert all(" vs control" in line or "control vs " in line for line in printed)
    assert len(printed) == 3 * len(json.loads((run / "stats.json").read_text())["metrics"])
    summary = (run / "summary.md").read_text()
    pair_rows = [line for line in summary.splitlines() if line.startswith("| ") and " - " in line]
    assert pair_rows and all("control" in line.split("|")[1] for line in pair_rows)
    assert len(json.loads((run / "stats.json").read_text())["metrics"][0]["conover"]) == 6  # every pair kept
    result = runner.invoke(main, ["plot", str(run), "--formats", "png", "--reference", "nope"])
    assert result.exit_code == 1
    assert result.output.strip().splitlines() == [
        "Error: --reference 'nope' is not a condition of this analysis; the conditions: disambiguation, "
        "control, blending, mode-switch"]
    result = runner.invoke(main, ["plot", str(run), "--formats", "png", "--reference", "blending"])
    assert result.exit_code == 0, result.output
    assert (run / "figures" / "fig4.png").is_file()
