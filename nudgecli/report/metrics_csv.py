"""Reading back the ``metrics.csv`` that ``nudge analyze`` wrote, exactly as written."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import DataError
from nudgecli.report.tables import read_csv_labels, validate_metrics_table


def read_metrics_csv(path: Path, again: str | None = None) -> pd.DataFrame:
    """``metrics.csv`` as ``nudge analyze`` wrote it, its floats read back exactly and its labels as
    written (:func:`~nudgecli.report.tables.read_csv_labels`); a file cut off or damaged is named
    with ``again``, the command that writes it again where the caller knows it (a file nudge writes
    is written again, not mended by hand).

    pandas 3 parses floats exactly by default; pandas 2 needs the round-trip parser for that
    (its default may differ in the last bit, which the checksum would see).
    """
    pandas_3 = int(pd.__version__.split(".")[0]) >= 3
    exact: dict[str, Any] = {} if pandas_3 else {"float_precision": "round_trip"}
    fix = f"write it again with `{again}`" if again else "run `nudge analyze` again"
    try:
        table = read_csv_labels(path, **exact)
    except DataError as exc:  # a row cut short or lost cells (the csv check's words)
        problem = str(exc).split("; ", 1)[0]
        raise DataError(f"{problem}; the file looks cut off or damaged: it is written by `nudge analyze`: "
                        f"{fix}") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, OSError, ValueError) as exc:
        raise DataError(f"{path} cannot be read as a metrics table ({exc}); {fix}") from None
    validate_metrics_table(table, str(path))
    return table
