"""``file_sha256`` (the SHA-256 every recorded checksum is, read in 1 MiB blocks) equals hashlib's
of the whole bytes at and around the block boundaries: a reader that stops after one block, or
drops a short last block, gives another digest."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from nudgecli.run_folder_record import file_sha256

BLOCK = 1 << 20


@pytest.mark.parametrize("size", [0, 1, BLOCK - 1, BLOCK, BLOCK + 1, 2 * BLOCK + 12345])
def test_file_sha256_is_hashlibs_of_the_whole_file(tmp_path, size):
    data = np.random.default_rng(size).integers(0, 256, size, dtype=np.uint8).tobytes()
    path = tmp_path / "file.bin"
    path.write_bytes(data)
    assert file_sha256(path) == file_sha256(str(path)) == hashlib.sha256(data).hexdigest()
