"""A failed ``nudgecli.analyze(DataFrame, out=EXISTING, force=True)`` leaves the folder as it was."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

import nudgecli

OLD = pd.DataFrame({"participant": [0, 0, 1, 1, 2, 2], "condition": ["a", "b"] * 3,
                    "completion_time": [4.0, 1, 2, 3, 5, 1]})
NEW = pd.DataFrame({"participant": [7, 7, 8, 8], "condition": ["x", "y"] * 2,
                    "completion_time": [100.0, 200, 1, 2]})
INF = OLD.assign(completion_time=[4.0, float("inf"), 2, 3, 5, 1])


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize(("frame", "options"), [
    (NEW, {"reference": "X"}),
    (NEW, {"metrics": ["nope"]}),
    (NEW, {"bootstrap": 5}),
    (INF, {}),
], ids=["reference", "metric", "bootstrap", "inf"])
def test_failed_frame_analysis_leaves_the_previous_one(tmp_path: Path, frame: pd.DataFrame,
                                                       options: dict[str, object]) -> None:
    out = tmp_path / "an"
    nudgecli.analyze(OLD, out=out)
    before = _snapshot(out)
    with pytest.raises(nudgecli.NudgeError):
        nudgecli.analyze(frame, out=out, force=True, **options)
    assert _snapshot(out) == before
    assert pd.read_parquet(out / "metrics.parquet").participant.tolist() == [0, 0, 1, 1, 2, 2]
    nudgecli.plot(out, "completion_time")


def test_failed_frame_analysis_of_a_new_folder_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "an"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    with pytest.raises(nudgecli.NudgeError):
        nudgecli.analyze(NEW, out=out, force=True, reference="X")
    assert _snapshot(out) == {"notes.txt": b"mine\n"}
