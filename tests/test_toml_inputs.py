"""TOML inputs read by nudgecli.config_files: a leading UTF-8 byte order mark is skipped, as the
CSV readers skip it (was: "invalid TOML: Invalid statement (at line 1, column 1)"), and a folder
named ``x.toml`` given as an experiment or a plan is named a folder (was: "no such file")."""

from __future__ import annotations

from pathlib import Path

import pytest

from nudgecli.config import load_experiment
from nudgecli.config_files import preset_dir, read_toml, resolve_preset
from nudgecli.errors import ConfigError
from nudgecli.runs.sweep import load_sweep


def test_a_byte_order_mark_is_skipped(tmp_path: Path) -> None:
    smoke = (preset_dir("experiments") / "smoke.toml").read_bytes()
    path = tmp_path / "smoke.toml"
    path.write_bytes(b"\xef\xbb\xbf" + smoke)
    assert read_toml(path) == read_toml(preset_dir("experiments") / "smoke.toml")
    assert load_experiment(str(path)) == load_experiment("smoke")
    sweep = tmp_path / "s.toml"  # a sweep file is read by the same reader
    sweep.write_bytes(b"\xef\xbb\xbfexperiment = \"smoke\"\n[parameters]\n\"inference.kappa\" = [0.5, 0.6]\n")
    assert len(load_sweep(str(sweep)).points) == 2


@pytest.mark.parametrize("kind", ["experiments", "analysis"])
def test_a_folder_named_like_a_toml_file_is_named_a_folder(tmp_path: Path, kind: str) -> None:
    folder = tmp_path / "x.toml"
    folder.mkdir()
    with pytest.raises(ConfigError, match=r"x\.toml: a folder, not a \.toml file; give a preset name or a "
                                          r"path to a \.toml file$"):
        resolve_preset(str(folder), kind)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"no such file"):
        resolve_preset(str(tmp_path / "y.toml"), kind)  # type: ignore[arg-type]


def test_a_batch_experiment_with_a_byte_order_mark_resumes_after_a_comment_changed(tmp_path: Path) -> None:
    # the kept copy's comments edited: resumed where both read as the same TOML (was: tomllib
    # refused the mark, so the batch's own experiment read as "changed since the batch wrote it")
    import hashlib

    from nudgecli.runs.batch_folder import check_kept_inputs

    typed = "\ufeff[study]\nparticipants = 2\n".encode()
    (tmp_path / "experiment.toml").write_bytes(typed + b"# a note of the person's own\n")
    recorded = {"experiment.toml": hashlib.sha256(typed).hexdigest()}
    check_kept_inputs(tmp_path, recorded, {"experiment.toml": typed})
