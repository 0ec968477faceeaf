"""The package's one Parquet reader: pandas' frames, read without Arrow's thread pools."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nudgecli.parquet_reader import read_parquet

ROOT = Path(__file__).resolve().parents[1]


def _frame() -> pd.DataFrame:
    return pd.DataFrame({
        "participant": np.arange(6, dtype=np.int64),
        "condition": ["disambiguation", "control", "blending", "control", "x", "y"],
        "speed": [0.5, np.nan, -0.0, 1e-300, np.inf, 2.0],
        "success": [True, False, True, True, False, True],
        "goal_cells": [[[1, 2], [3, 4]], [[0, 0]], [], [[5, 6]], [[7, 8]], [[9, 9]]],
        "small": np.arange(6, dtype=np.int8),
    })


def test_read_parquet_gives_pandas_frames(tmp_path: Path) -> None:
    path = tmp_path / "t.parquet"
    _frame().to_parquet(path, index=False)
    expected = pd.read_parquet(path)
    for source in (path, str(path), path.read_bytes()):
        got = read_parquet(source)
        pd.testing.assert_frame_equal(got, expected, check_exact=True)
        assert list(got.dtypes) == list(expected.dtypes)
    # an index kept in the file's pandas metadata comes back as the index
    indexed = tmp_path / "indexed.parquet"
    _frame().set_index(pd.Index([3, 1, 4, 1, 5, 9], name="trial")).to_parquet(indexed)  # stored as a column
    pd.testing.assert_frame_equal(read_parquet(indexed), pd.read_parquet(indexed), check_exact=True)
    pd.testing.assert_frame_equal(read_parquet(indexed, ["speed"]),
                                  pd.read_parquet(indexed, columns=["speed"]), check_exact=True)
    # a subset of the columns, in the order asked
    pd.testing.assert_frame_equal(read_parquet(path, ["speed", "participant"]),
                                  pd.read_parquet(path, columns=["speed", "participant"]), check_exact=True)


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc (Linux)")
def test_read_parquet_starts_no_thread(tmp_path: Path) -> None:
    # apache/arrow#34314: a pool thread still busy at exit aborts the process; pandas' reader starts
    # Arrow's pools (the control below), this one starts none
    path = tmp_path / "t.parquet"
    pd.DataFrame({"a": np.arange(100_000), "b": [f"x{i}" for i in range(100_000)]}).to_parquet(path)
    script = (
        "import os, sys\n"
        "import pandas as pd\n"
        "from nudgecli.parquet_reader import read_parquet\n"
        "def threads(): return len(os.listdir('/proc/self/task'))\n"
        "before = threads()\n"
        "for _ in range(3):\n"
        "    read_parquet(sys.argv[1]); read_parquet(open(sys.argv[1], 'rb').read(), ['b'])\n"
        "ours = threads()\n"
        "pd.read_parquet(sys.argv[1])\n"
        "print(before, ours, threads())\n"
    )
    out = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True,
                         check=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)}).stdout
    before, ours, pandas_ = (int(v) for v in out.split())
    assert ours == before
    assert pandas_ > before  # the control: the count does see Arrow's pool threads


def test_no_module_reads_parquet_another_way() -> None:
    owner = ROOT / "nudgecli" / "parquet_reader.py"
    offending = []
    for path in sorted((ROOT / "nudgecli").rglob("*.py")):
        if path == owner:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr in ("read_parquet", "read_table") and \
                    isinstance(node.value, ast.Name) and node.value.id in ("pd", "pandas", "pq", "parquet"):
                offending.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert offending == []
