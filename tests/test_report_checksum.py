"""The metrics checksum hashes the condition labels a block of rows at a time: the digest must be
the one of the labels joined in one string (the definition analyses already written carry)."""

import hashlib
import json

import numpy as np
import pandas as pd
import pytest

from nudgecli.report.checksum import _LABEL_BLOCK_ROWS, metrics_digest


def _digest_in_one_string(table: pd.DataFrame, metrics: list[str]) -> str:
    # the definition written out: every label joined by \x1f, then each metric's float64 bytes
    digest = hashlib.sha256()
    digest.update(json.dumps({"rows": len(table), "columns": metrics}).encode("utf-8"))
    digest.update("\x1f".join(str(label) for label in table["condition"].astype(str)).encode("utf-8"))
    for metric in metrics:
        values = table[metric].to_numpy(dtype=float, na_value=np.nan)
        values = np.where(np.isnan(values), np.nan, values + 0.0)
        digest.update(b"\x1e" + np.ascontiguousarray(values, dtype="<f8").tobytes())
    return digest.hexdigest()


@pytest.mark.parametrize("rows", [0, 1, _LABEL_BLOCK_ROWS - 1, _LABEL_BLOCK_ROWS, _LABEL_BLOCK_ROWS + 1,
                                  2 * _LABEL_BLOCK_ROWS + 17])
@pytest.mark.parametrize("categorical", [False, True])
def test_digest_of_labels_in_blocks_is_the_digest_of_one_joined_string(rows, categorical):
    rng = np.random.default_rng(rows)
    labels = rng.choice(["control", "disambiguation", "näive"], size=rows).astype(object)
    table = pd.DataFrame({"condition": pd.Categorical(labels) if categorical else labels,
                          "time": rng.normal(size=rows)})
    assert metrics_digest(table, ["time"]) == _digest_in_one_string(table, ["time"])
