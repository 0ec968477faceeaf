"""The seed tree's concrete values: a run folder made with one version of nudge is reproduced by
another only if a branch's name maps to the same key and the key to the same stream."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from nudgecli.rng import generator, seed_key, seed_sequence


def test_a_branch_name_is_the_first_four_bytes_of_its_sha256_little_endian() -> None:
    # sha256("participant") starts c0 cd e0 73: read little-endian, 0x73e0cdc0 = 1944112576
    assert hashlib.sha256(b"participant").digest()[:4] == bytes.fromhex("c0cde073")
    assert seed_sequence(2022, "participant", 3).spawn_key == (1944112576, 3)


def test_the_streams_of_fixed_branches_are_pinned() -> None:
    # values recorded on 2026-11-26 (numpy 2's PCG64 under SeedSequence); a change here changes
    # every table of every run folder with the same seed
    assert generator(2022, "participant", 3, "trial", 5).integers(2**32, size=3).tolist() == [
        1989622028, 2933527028, 4193084140]
    assert generator(0).integers(2**32, size=2).tolist() == [3653403231, 2735729615]


def test_branches_are_independent_of_each_other_and_of_names_versus_numbers() -> None:
    draws = {path: generator(7, *path).random() for path in
             [("participant", 1), ("participant", 2), ("trial", 1), ("1",), (1,)]}
    assert len(set(draws.values())) == len(draws)
    assert generator(7, "participant", 1).random() == draws[("participant", 1)]


def test_a_negative_seed_is_refused_and_a_branch_has_a_readable_label() -> None:
    with pytest.raises(ValueError, match="non-negative"):
        seed_sequence(-1, "participant")
    assert seed_key("participant", 3, "trial") == "participant/3/trial"
    assert isinstance(generator(1, "x").bit_generator, np.random.PCG64)
