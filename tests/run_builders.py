"""Synthetic run folders shared by the analysis tests (imported as ``from run_builders import ...``;
pytest puts this folder on the path, as for ``cli_helpers``)."""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd


def synthetic_run(folder: Path, conditions: Mapping[str, int], *, n_participants: int,
                  trials_per_condition: int, seed: int, max_steps: int,
                  switch_probability: Callable[[int], float]) -> Path:
    """A small run folder in the DESIGN section 4 layout: one trials/steps part per participant.

    ``conditions`` maps each condition to the steps it adds to every trial (a trial has
    ``20..max_steps - 1`` steps plus those); a step holds a human mode switch with
    ``switch_probability(extra steps)``. Turns alternate every 8 steps, half the human steps blend.
    """
    rng = np.random.default_rng(seed)
    (folder / "trials").mkdir(parents=True)
    (folder / "steps").mkdir()
    for participant in range(n_participants):
        trial_rows, step_frames = [], []
        for condition, extra in conditions.items():
            for k in range(trials_per_condition):
                trial = len(trial_rows)
                n = int(rng.integers(20, max_steps)) + extra
                turn = np.where((np.arange(n) // 8) % 2 == 0, "human", "autonomy")
                human = turn == "human"
                alpha = np.where(human & (rng.random(n) < 0.5), 0.8, 0.0)
                event = np.where(rng.random(n) < switch_probability(extra), "mode_switch_human", "")
                human_turns = int((human & np.r_[True, turn[1:] != turn[:-1]]).sum())
                trial_rows.append({
                    "participant": participant, "condition": condition, "block": k // 2, "trial": trial,
                    "layout": trial, "n_goals": 3, "true_goal": 0, "reached_goal": 0, "success": True,
                    "timed_out": False, "duration_s": n * 0.1, "human_turns": human_turns,
                    "autonomy_turns": human_turns - 1})
                step_frames.append(pd.DataFrame({
                    "participant": participant, "trial": trial, "step": np.arange(n), "t": np.arange(n) * 0.1,
                    "turn": turn, "x": 10.0, "y": 10.0, "theta": 0.0, "mode": "x", "cell_x": 1, "cell_y": 2,
                    "heading": 0, "phi_m": "", "u_h_x": 0.0, "u_h_y": 0.0, "u_h_theta": 0.0, "u_a_x": 0.0,
                    "u_a_y": 0.0, "u_a_theta": 0.0, "alpha": alpha,
                    "inferred_goal": rng.integers(-1, 3, n), "belief": [[1 / 3] * 3] * n, "entropy": 1.0,
                    "event": event}))
        pd.DataFrame(trial_rows).to_parquet(folder / "trials" / f"part-{participant:05d}.parquet")
        pd.concat(step_frames).to_parquet(folder / "steps" / f"part-{participant:05d}.parquet")
    return folder


def hard_puff_mapping(folder: Path) -> Path:
    """One participant's calibration folder, as ``nudge fit`` reads it: the smoke preset's mapping
    session with every prompt answered Hard Puff (label 0) a tick after it shows."""
    from nudgecli.config import load_experiment
    from nudgecli.live.calibration import MappingRecorder
    from nudgecli.sim.calibration_io import write_sessions

    recorder = MappingRecorder.create(load_experiment("smoke").calibration, np.random.default_rng(2), "test")
    now = 0.0
    while not recorder.done:
        now = round(now + 0.1, 9)
        if recorder.prompt is not None and recorder.answered_at is None:
            recorder.answer(0, now)
        recorder.tick(now)
    write_sessions(folder, mapping=recorder.session())
    return folder


def with_seeds(run: Path, seed: int | None = None, experiment_seed: int | None = None) -> Path:
    """``run`` with its manifest's seed and its experiment's seed (manifest and config.toml) set."""
    manifest = json.loads((run / "manifest.json").read_text())
    if seed is not None:
        manifest["seed"] = seed
    if experiment_seed is not None:
        manifest["config"]["experiment"]["seed"] = experiment_seed
        config = (run / "config.toml").read_text()
        (run / "config.toml").write_text(config.replace(f"seed = {manifest['seed']}\n",
                                                        f"seed = {experiment_seed}\n", 1))
    (run / "manifest.json").write_text(json.dumps(manifest))
    return run
