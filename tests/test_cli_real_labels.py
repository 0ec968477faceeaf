"""A real table's labels kept as written: ``07``, ``08``, ``10`` come out of ``nudge analyze`` and
``nudge compare`` as ``07``, ``08``, ``10``, while a table whose labels are all canonical integers
gives, byte for byte, the outputs it gave before the rule existed (``tests/data/labels/before``,
made by that earlier reading from the canonical tables beside it)."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import shutil
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.cli import main
from nudgecli.report.plotting import read_inputs
from nudgecli.report.tables import is_canonical_integer, read_metrics_table

LABELS = Path(__file__).with_name("data") / "labels"
BEFORE = LABELS / "before"
#: The canonical tables' participants and blocks, relabelled as a lab might write them.
PADDED = {"2": "02", "7": "07", "8": "08", "10": "10", "12": "12"}
ANALYSIS_FILES = ("metrics.csv", "questionnaire_scores.csv", "stats.csv", "stats.json", "summary.md")
COMPARE_FILES = ("compare.csv", "participant_medians.csv", "compare.json")


def nudge(*args: str):
    return CliRunner().invoke(main, [*args])


def cells(path: Path) -> pd.DataFrame:
    """A CSV's cells as written (no number parsing)."""
    return pd.read_csv(path, dtype=str, keep_default_na=False)


def relabel(source: Path, target: Path, columns: dict[str, dict[str, str]]) -> None:
    """``source`` with the cells of ``columns`` replaced through their maps, written by the csv
    module (not pandas, whose reading is under test)."""
    with open(source, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    with open(target, "w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: columns.get(k, {}).get(v, v) for k, v in row.items()})


@pytest.fixture
def tables(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The canonical tables copied into a fresh folder that is also the working folder (the
    outputs name their sources relative to it, as when the expected files were made)."""
    for name in ("real.csv", "simulated.csv", "questionnaires.csv"):
        shutil.copy(LABELS / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def analyze_real() -> None:
    result = nudge("analyze", "real.csv", "--bootstrap", "200", "--drop-duplicates",
                   "--questionnaires", "questionnaires.csv")
    assert result.exit_code == 0, result.output


def compare_real() -> str:
    result = nudge("compare", "simulated.csv", "real.csv", "--resamples", "100", "--out", "cmp",
                   "--formats", "svg", "--format", "json", "--drop-duplicates")
    assert result.exit_code == 0, result.output
    return result.stdout


def test_canonical_integer_labels_give_the_outputs_they_gave_before(tables: Path) -> None:
    analyze_real()
    compare_real()
    outputs = (("real-analysis", "analysis", ANALYSIS_FILES), ("cmp", "compare", COMPARE_FILES))
    for folder, before, names in outputs:
        for name in names:
            assert without_table_read(tables / folder / name) == (BEFORE / before / name).read_bytes(), name


def without_table_read(path: Path) -> bytes:
    """A file's bytes; ``stats.json``'s as written without its records of the table read and of
    the scores file, and without each metric's mean ranks and star rule (which came after the
    expected files: report/table_read.py, report/questionnaires.py, report/stats_document.py),
    the comparison's without the names of each condition in either source and ``compare.json``'s
    record of ``--match``, the plan and ``--drop-duplicates`` (which came after them too), every
    other byte as it is."""
    if path.name in ("compare.csv", "participant_medians.csv", "compare.json"):
        return without_condition_names(path)
    if path.name != "stats.json":
        return path.read_bytes()
    stats = json.loads(path.read_text(encoding="utf-8"))
    for entry in stats["metrics"]:
        assert set(entry.pop("mean_rank")) == set(entry["n"])  # one per condition
        assert set(entry.pop("star_rule")) == {"kruskal_alpha", "thresholds", "comparison"}
    assert set(stats.pop("table_read")) == {"sha256", "rows", "drop_duplicates", "duplicates_dropped",
                                            "table", "plan", "questionnaires"}
    scores = (path.parent / "questionnaire_scores.csv").read_bytes()
    assert stats.pop("questionnaire_scores_checksum")["digest"] == hashlib.sha256(scores).hexdigest()
    return (json.dumps(stats, indent=2, allow_nan=False) + "\n").encode("utf-8")


def without_condition_names(path: Path) -> bytes:
    """``compare.csv``, ``participant_medians.csv`` or ``compare.json`` without the columns
    ``simulated_condition`` and ``real_condition`` and the document's ``match``, ``plan`` and
    ``drop_duplicates``."""
    names = ["simulated_condition", "real_condition"]
    if path.suffix == ".csv":
        return cells(path).drop(columns=names).to_csv(index=False).encode("utf-8")
    document = json.loads(path.read_text(encoding="utf-8"))
    assert document.pop("drop_duplicates") is True and document.pop("match") == {}
    assert document.pop("plan") == {"name": "paper", "source": "paper"}
    for row in document["comparison"] + document["participant_medians"]:
        assert row.pop("real_condition") == row["condition"] == row.pop("simulated_condition")
    return (json.dumps(document, indent=2, allow_nan=False) + "\n").encode("utf-8")


def test_analyze_keeps_zero_padded_labels_as_written(tables: Path) -> None:
    blocks = {"1": "01", "2": "02"}
    relabel(LABELS / "real.csv", tables / "real.csv", {"participant": PADDED, "block": blocks})
    relabel(LABELS / "questionnaires.csv", tables / "questionnaires.csv", {"participant": PADDED})
    analyze_real()
    out = tables / "real-analysis"
    metrics = cells(out / "metrics.csv")
    assert set(metrics["participant"]) == set(PADDED.values())
    assert set(metrics["block"]) == {"01", "02"}
    assert set(metrics["trial"]) == {str(t) for t in range(1, 9)}  # a canonical column stays integers
    assert set(cells(out / "questionnaire_scores.csv")["participant"]) == {"02", "07", "08", "10"}
    stats = json.loads((out / "stats.json").read_text())
    trial_metrics = [m for m in stats["metrics"] if m["metric"] != "likert_ease"]
    # 12 has no control trials; its label is text, as the rest of its column ("12", not 12)
    assert all(m["participant_level"]["dropped_participants"] == ["12"] for m in trial_metrics)
    # nudge plot reads metrics.csv back: the same labels, and the checksum still agrees
    assert set(read_inputs(out).metrics["participant"]) == set(PADDED.values())


def test_compare_keeps_zero_padded_labels_as_written(tables: Path) -> None:
    relabel(LABELS / "real.csv", tables / "real.csv", {"participant": PADDED})
    printed = json.loads(compare_real())["participant_medians"]
    medians = cells(tables / "cmp" / "participant_medians.csv")
    expected = {"simulated": {"1", "3", "9", "11"}, "real": set(PADDED.values())}
    for source, labels in expected.items():
        assert set(medians.loc[medians["source"] == source, "participant"]) == labels
        assert {row["participant"] for row in printed if row["source"] == source} == labels


# --- the rule itself ------------------------------------------------------------------------------

INT64 = st.integers(min_value=-(2**63), max_value=2**63 - 1)


@given(INT64)
def test_the_text_python_writes_for_an_int64_is_canonical(number: int) -> None:
    assert is_canonical_integer(str(number))


@given(INT64, st.sampled_from(["0{}", "+{}", "{}.0", " {}", "{} ", "{}e0"]))
def test_other_spellings_of_an_integer_are_not_canonical(number: int, spelling: str) -> None:
    text = spelling.format(number)
    assert text != str(number) and not is_canonical_integer(text)


@pytest.mark.parametrize("text", ["-0", "1_000", "٣", "", "P7", "7a", str(2**63), str(-(2**63) - 1)])
def test_edge_spellings_are_not_canonical(text: str) -> None:
    assert not is_canonical_integer(text)


def _table_text(labels: Sequence[object]) -> str:
    rows = "".join(f"{'' if p is None else p},c{i % 2},{i}.5\n" for i, p in enumerate(labels))
    return "participant,condition,completion_time\n" + rows


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(INT64, st.none()), min_size=1, max_size=8))
def test_a_column_of_canonical_integers_is_read_as_pandas_always_read_it(
        tmp_path_factory: pytest.TempPathFactory, labels: list[int | None]) -> None:
    path = tmp_path_factory.mktemp("canonical") / "t.csv"
    path.write_text(_table_text(labels))
    # the reading before the rule: pandas' own inference (int64, float64 with blanks)
    before = pd.read_csv(path, dtype={"condition": "category"})
    pd.testing.assert_frame_equal(read_metrics_table(path), before)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 30), min_size=1, max_size=8), st.integers(0, 7))
def test_one_padded_label_makes_the_whole_column_text_as_written(
        tmp_path_factory: pytest.TempPathFactory, labels: list[int], which: int) -> None:
    written = [str(p) for p in labels]
    written[which % len(written)] = f"0{labels[which % len(labels)]}"
    path = tmp_path_factory.mktemp("padded") / "t.csv"
    path.write_text(_table_text(written))
    expected = list(csv.DictReader(io.StringIO(path.read_text())))
    assert read_metrics_table(path)["participant"].tolist() == [row["participant"] for row in expected]
