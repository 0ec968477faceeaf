"""Reading a Parquet file into a frame on the calling thread: the one reader of the package.

pandas' ``read_parquet`` goes through Arrow's dataset scanner, which runs its reads and their
completions on Arrow's thread pools. A pool thread still finishing such a task when the process
exits makes the C++ runtime abort it ("terminate called without an active exception", exit code
-6; apache/arrow#34314, open). It was seen here on a loaded 2-core machine, after a
``nudge simulate`` that had completed its run folder. Arrow's file reader with threads and
pre-buffering off reads synchronously and starts no pool thread, and the tables are small.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pandas loads on the first read, after a batch has started its workers
    import pandas as pd


def read_parquet(source: str | Path | bytes, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """The frame of a Parquet file (or its bytes), as ``pandas.read_parquet`` gives it.

    Parameters
    ----------
    source
        A path, or the file's bytes.
    columns
        Columns to read, in this order (``None``: all).

    Returns
    -------
    pandas.DataFrame
        The frame, with the dtypes ``pandas.read_parquet`` gives (its pandas metadata applied).
    """
    import pyarrow.parquet as pq

    handle = io.BytesIO(source) if isinstance(source, bytes) else source
    with pq.ParquetFile(handle, pre_buffer=False) as parquet:
        table = parquet.read(columns=list(columns) if columns is not None else None, use_threads=False,
                             use_pandas_metadata=True)
    return table.to_pandas(use_threads=False)


def parquet_column_names(data: bytes) -> list[str]:
    """The column names of a Parquet file's bytes (its schema only; raises as pyarrow does for a
    file that is not Parquet)."""
    import pyarrow.parquet as pq

    return list(pq.ParquetFile(io.BytesIO(data)).schema_arrow.names)
