"""Seeding: one master seed -> a ``SeedSequence`` tree -> ``np.random.Generator`` objects.

A run is a pure function of (config, seed). Every stochastic component gets its own branch
of the tree, addressed by a stable path of names and integers, so the numbers a participant
sees do not depend on how many workers ran, in which order, or on which machine.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np

from nudgecli.errors import ConfigError


@functools.lru_cache(maxsize=256)  # a few names, hashed for every trial's stream
def _word_key(name: str) -> int:
    """A stable 32-bit integer for a branch name (independent of Python's hash seed)."""
    digest = hashlib.sha256(name.encode("utf-8")).digest()
    return int.from_bytes(digest[:4], "little")


def check_seed(seed: int | None) -> None:
    """Refuse a negative master seed (a ``SeedSequence`` takes none): the one rule and wording of
    ``--seed`` for every command and API function that takes a seed.

    Parameters
    ----------
    seed
        The seed given, or ``None`` for the experiment's or the plan's (checked where it is read).

    Raises
    ------
    ConfigError
        ``seed`` below 0.
    """
    if seed is not None and seed < 0:
        raise ConfigError(f"--seed must be a non-negative integer, got {seed}")


def seed_sequence(master_seed: int, *path: str | int) -> np.random.SeedSequence:
    """The ``SeedSequence`` at ``path`` below ``master_seed``.

    Parameters
    ----------
    master_seed
        The run's seed (a non-negative integer).
    *path
        Branch names (hashed to stable integers) or integers, e.g.
        ``("participant", 3, "calibration")``.

    Returns
    -------
    np.random.SeedSequence
        Equal paths give equal sequences; different paths give independent streams.
    """
    if master_seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {master_seed}")
    key = tuple(_word_key(p) if isinstance(p, str) else int(p) for p in path)
    return np.random.SeedSequence(entropy=master_seed, spawn_key=key)


def generator(master_seed: int, *path: str | int) -> np.random.Generator:
    """A fresh ``np.random.Generator`` (PCG64) for the branch ``path`` of ``master_seed``."""
    return np.random.Generator(np.random.PCG64(seed_sequence(master_seed, *path)))


def seed_key(*path: str | int) -> str:
    """A readable, stable label of a branch, stored in result tables (e.g. ``participant/3``)."""
    return "/".join(str(p) for p in path)
