"""A manifest copied in from another run (``cp run2/manifest.json run1/``) is named as the suspect:
neither a part blamed nor a resume advised that would simulate every part again as the other run's."""

from __future__ import annotations

import shutil

from click.testing import CliRunner

from nudgecli.cli import main

SMALL = ("--participants", "2", "--set", "study.blocks_per_condition=1")


def test_a_manifest_of_another_run_is_named_and_no_resume_is_advised_or_run(tmp_path):
    runner = CliRunner()
    for name, seed in (("run1", "5"), ("run2", "6")):
        out = str(tmp_path / name)
        result = runner.invoke(main, ["simulate", "paper", "--seed", seed, "--out", out, *SMALL])
        assert result.exit_code == 0, result.output
    run = tmp_path / "run1"
    kept = (run / "manifest.json").read_bytes()
    parts = {p: p.read_bytes() for p in sorted(run.glob("*/part-*.parquet"))}
    shutil.copy(tmp_path / "run2" / "manifest.json", run / "manifest.json")
    resume = ["simulate", str(run / "config.toml"), "--out", str(run), "--seed", "6", "--resume", *SMALL]
    for args in (["analyze", str(run)], resume):
        result = runner.invoke(main, args)
        errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
        assert result.exit_code == 1 and len(errors) == 1, result.output
        assert errors[0].startswith(f"Error: {run / 'manifest.json'} is not this run's: config.toml "
                                    "differs from the experiment it records (experiment.seed: 6 in the "
                                    "manifest, 5 in config.toml)"), errors[0]
        assert "put back the run's own manifest.json from a copy" in errors[0], errors[0]
        assert "changed since it was written" not in errors[0] and "--resume`" not in errors[0], errors[0]
        assert "Warning" not in result.output, result.output
        assert {p: p.read_bytes() for p in parts} == parts
    (run / "manifest.json").write_bytes(kept)
    assert runner.invoke(main, ["analyze", str(run)]).exit_code == 0
