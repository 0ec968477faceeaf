"""A live (``nudge study``) folder is read as far as its manifest says: ``analyze``, ``plot`` and
``plot --trial`` use exactly the trials each participant's ``completed_trials`` lists, a resume
writes again a part holding a trial the manifest does not list, and ``plot`` draws no analysis
older than the trials recorded."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

pytest.importorskip("aiohttp", reason="the live server needs aiohttp: pip install '.[study]'")

import pandas as pd
from cli_helpers import nudge as _nudge
from live_helpers import DEFAULT_TABLES, TWO_TRIALS, play_session, played_folder

from nudgecli.errors import ConfigError
from nudgecli.live.app import build_session
from nudgecli.report.plotting import check_trial
from nudgecli.run_folder_record import file_sha256

OVERRIDES = TWO_TRIALS + DEFAULT_TABLES


@pytest.fixture(scope="module")
def one_trial(tmp_path_factory) -> Path:
    """A live folder whose study is under way: P01's first trial recorded."""
    out = tmp_path_factory.mktemp("live") / "study"
    played_folder(out, lambda s: len(s.entry["completed_trials"]) >= 1)
    return out


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A live folder: P01 finished (two trials, their questionnaires)."""
    out = tmp_path_factory.mktemp("live") / "study"
    played_folder(out, lambda s: False)
    return out


def _copy(folder: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "study"
    shutil.copytree(folder, copy)
    return copy


def _one_error(result) -> str:
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 1 and len(errors) == 1, result.output
    return errors[0]


def _edit_manifest(folder: Path, edit) -> None:
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text(encoding="utf-8"))
    edit(manifest)
    path.write_text(json.dumps(manifest, indent=2), encoding="utf-8")


def _stopped_before_listing_the_first_trial(folder: Path) -> None:
    """The state a session killed on its first trial leaves when the parts were renamed into place
    and the manifest did not list the trial yet: the parts noted as being written, no trial listed,
    no SHA-256 of the parts recorded."""
    def edit(manifest: dict) -> None:
        entry = manifest["live"]["1"]
        entry["completed_trials"] = []
        entry["writing_parts"] = {"trial": 0, **{kind: file_sha256(folder / kind / "part-0001.parquet")
                                                 for kind in ("trials", "steps")}}
        manifest.pop("checksums")

    _edit_manifest(folder, edit)


def test_a_first_trial_the_manifest_does_not_list_is_refused_with_the_resume(one_trial, tmp_path):
    live = _copy(one_trial, tmp_path)
    _stopped_before_listing_the_first_trial(live)
    for args in (("analyze", str(live)), ("plot", str(live), "--trial", "1:0")):
        line = _one_error(_nudge(*args))  # was: analysed with n=1 beside "0 trial(s) recorded"; drawn
        assert "part-0001.parquet holds trial(s) 0 of participant P01, which the manifest does not list" \
            in line, line
        assert "the session stopped while recording a trial; continue the participant's session with " \
               "`nudge study" in line and "--resume" in line, line


def test_the_resume_writes_the_first_trials_part_again_without_the_unlisted_trial(one_trial, tmp_path):
    live = _copy(one_trial, tmp_path)
    _stopped_before_listing_the_first_trial(live)
    session = build_session("paper", "P01", live, resume=True, overrides=OVERRIDES)
    session.folder.release()
    for kind in ("trials", "steps"):  # was: kept as it was, the discarded trial analysed
        part = live / kind / "part-0001.parquet"
        assert pd.read_parquet(part).empty
        assert json.loads((live / "manifest.json").read_text())["checksums"]["1"][kind] == file_sha256(part)
    line = _one_error(_nudge("analyze", str(live)))
    assert "holds live sessions with no trials recorded yet; continue the participant's session" in line


def test_a_trial_dropped_from_the_manifest_by_hand_is_refused_not_analysed(finished, tmp_path):
    live = _copy(finished, tmp_path)
    _edit_manifest(live, lambda manifest: manifest["live"]["1"].update(completed_trials=[0]))
    line = _one_error(_nudge("analyze", str(live)))  # was: the Note said 1 trial, metrics.csv had 2 rows
    assert "trials/part-0001.parquet holds trial(s) 1 of participant P01, which the manifest does not list" \
        in line and "restore manifest.json from a backup" in line, line


def test_plot_of_a_folder_stopped_while_recording_names_the_resume_not_analyze(one_trial, tmp_path):
    live = _copy(one_trial, tmp_path)
    part = live / "trials" / "part-0001.parquet"
    pd.concat([pd.read_parquet(part)] * 2).to_parquet(part, index=False)  # bytes the manifest does not record
    _edit_manifest(live, lambda manifest: manifest["live"]["1"].update(
        writing_parts={"trial": 1, "trials": file_sha256(part)}))
    line = _one_error(_nudge("plot", str(live)))  # was: "no metrics yet; run `nudge analyze ...` first"
    assert "the session stopped while recording a trial; continue the participant's session" in line, line


def test_plot_refuses_an_analysis_the_study_has_outgrown(one_trial, tmp_path):
    live = _copy(one_trial, tmp_path)
    assert _nudge("analyze", str(live)).exit_code == 0
    stats = json.loads((live / "stats.json").read_text())
    assert stats["live_completed_trials"] == {"1": [0]}
    session = build_session("paper", "P01", live, resume=True, overrides=OVERRIDES)
    play_session(session, lambda s: len(s.entry["completed_trials"]) >= 2)
    session.folder.release()
    for args in ((), ("--trial", "1:1")):  # was: Fig. 3/4 of trial 0 beside Fig. 5 of the trials now
        line = _one_error(_nudge("plot", str(live), *args))
        assert line == f"Error: {live / 'stats.json'}: the study has recorded more trials since it was " \
                       f"analysed; run `nudge analyze {live}` again", line
    assert _nudge("analyze", str(live)).exit_code == 0
    assert json.loads((live / "stats.json").read_text())["live_completed_trials"] == {"1": [0, 1]}


def test_plot_trial_names_the_live_participants_that_exist(one_trial, tmp_path):
    live = _copy(one_trial, tmp_path)
    assert _nudge("analyze", str(live)).exit_code == 0
    line = _one_error(_nudge("plot", str(live), "--trial", "5:0"))  # was: "(participants 0-1, trials 0-0)"
    assert line.endswith(f"--trial 5:0: no such trial in {live} (participants 1, trials 0)"), line


def test_a_missing_trial_names_the_participants_as_they_are_numbered():
    trials = pd.DataFrame({"participant": [1, 1, 2, 7, 12], "trial": [0, 1, 0, 0, 3]})
    with pytest.raises(ConfigError, match=r"\(participants 1-2, 7, 12, trials 0-1, 3\)$"):
        check_trial("R", trials, (5, 0))
    with pytest.raises(ConfigError, match=r"\(participant 1's trials 0-1\)$"):
        check_trial("R", trials, (1, 4))
