"""docs/batches.md describes the batch size estimate by the constants ``nudgecli.runs.size`` uses,
so the page cannot go stale when they are measured again (it once gave 3.5 ms a trial and 0.2 s an
analysis, which the code no longer used)."""

from __future__ import annotations

from pathlib import Path

from nudgecli.runs import size

DOC = Path(__file__).resolve().parents[1] / "docs" / "batches.md"


def test_the_doc_names_every_constant_the_estimate_reads() -> None:
    read = {name for name in size.size_estimate.__code__.co_names if name.isupper()}
    assert read >= {"SECONDS_FIXED", "SECONDS_PER_TRIAL", "SECONDS_PER_ANALYSIS", "BYTES_PER_TASK"}
    text = DOC.read_text(encoding="utf-8")
    assert {name for name in read if f"`{name}`" not in text} == set()
    assert "`MAX_TRIALS_WITHOUT_YES` (200,000)" in text and size.MAX_TRIALS_WITHOUT_YES == 200_000


def test_the_doc_gives_no_number_of_its_own_for_the_estimate() -> None:
    text = DOC.read_text(encoding="utf-8")
    for stale in ("3.5 ms per trial", "0.2 s per analysis"):
        assert stale not in text
