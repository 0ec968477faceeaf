"""Reading and checking a metrics table (CSV or Parquet): one row per trial with ``participant``,
``condition`` and metric columns (real study data), as ``nudge analyze``, ``nudge compare`` and
``nudge plot`` take it.

Every column other than ``participant``, ``condition``, ``block``, ``trial``, ``layout``,
``n_goals`` and ``true_goal`` is a metric and must be numeric (booleans count as 0/1): numbers, or
true/false, not both in one column (refused, naming the first number); an integer too large for
int64 is read as a float wherever it sits. An empty ``participant`` or ``condition`` is refused,
naming the row. A CSV's delimiter is sniffed. Two columns of one name, infinite values and
condition labels that differ only by case or surrounding spaces are errors naming the columns and
rows; repeated trials (same participant, condition, block and trial) are an error unless dropped
on request (:func:`drop_or_refuse_duplicates`).

A CSV's label columns (``participant``, ``block``, ``trial``) are kept as written: a column whose
every label is a canonical integer (``7``, ``12``, ``-3``: the text Python writes for an int64) is
read as integers, as it always was; a column with any other label (``07``, ``P7``, ``+3``,
``7.0``) is read as text, exactly as written (:func:`read_csv_labels`, the one owner of that rule
for every real table: metrics tables, ``metrics.csv`` read back, questionnaires). It also refuses a
row with fewer fields than the header (a file whose last line was cut off), which pandas would
read with its missing cells empty, and rows with more (which pandas would shift by a column), by
:func:`nudgecli.csv_rows.read_csv_whole_rows`, the rule of every user CSV. A Parquet table's columns keep the
types they were stored with.
"""

from __future__ import annotations

import contextlib
import csv
from collections.abc import Collection, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from nudgecli.csv_rows import read_csv_whole_rows
from nudgecli.csv_text import decimal_comma_advice, not_utf8_message
from nudgecli.errors import DataError, did_you_mean
from nudgecli.parquet_reader import read_parquet
from nudgecli.report.metrics import ID_COLUMNS, METRIC_NAMES

#: Columns of a metrics table that describe the trial rather than measure it.
NON_METRIC_COLUMNS = (*ID_COLUMNS, "layout", "n_goals", "true_goal")
TABLE_SUFFIXES = (".csv", ".parquet", ".pq")
#: The columns that identify one trial of a metrics table (those present are used).
TRIAL_KEY = ("participant", "condition", "block", "trial")
#: How many rows or pairs an error message lists.
_SHOWN = 5
#: The columns of a real table that hold labels, not quantities (read by :func:`read_csv_labels`).
LABEL_COLUMNS = ("participant", "block", "trial")
#: The range of a canonical integer label: pandas reads integers in it as int64.
_INT64_RANGE = (-(2**63), 2**63 - 1)


def is_canonical_integer(text: str) -> bool:
    """Whether ``text`` is exactly the text Python writes for an int64: ``7``, ``12``, ``-3``; not
    ``07``, ``+3``, ``-0``, ``7.0``, `` 7`` or ``1_000`` (``str(int(text))`` gives ``text`` back)."""
    try:
        number = int(text)
    except ValueError:
        return False
    return str(number) == text and _INT64_RANGE[0] <= number <= _INT64_RANGE[1]


def label_text(label: object) -> str:
    """A label as :func:`read_csv_labels` reads it, as text: the one way two tables' labels are
    matched (a questionnaire's respondents against a table's participants).

    A number (a column of canonical integers is read as int64, or float64 beside blanks; a
    Parquet table's numbers) is written as Python writes the integer it holds: ``7``, ``7.0`` and
    ``np.int64(7)`` give ``"7"``. Text stays exactly as written: ``"07"``, ``"7.0"`` and ``" 7"``
    are labels of their own, none of them ``"7"`` (a column holding one of them is read as text).
    """
    if isinstance(label, str):
        return label
    if isinstance(label, int | np.integer) and not isinstance(label, bool | np.bool_):
        return str(int(label))
    if isinstance(label, float | np.floating) and float(label).is_integer():
        return str(int(label))
    return str(label)


def labels_as_written(labels: pd.Series) -> pd.Series:
    """A label column read as text, as a researcher's table means it.

    Parameters
    ----------
    labels
        ``(N,)`` the column's cells as written (Python strings; missing cells NaN).

    Returns
    -------
    pd.Series
        ``(N,)`` integers when every label is a canonical integer (:func:`is_canonical_integer`),
        exactly as pandas reads such a column (int64; float64 with missing cells), so that the
        numbers and the order of participants of existing analyses stay as they were; otherwise
        the labels as written, as text (``str``, as pandas reads a column of text): ``07`` stays
        ``07``, and a column of ``07`` and ``7`` holds two labels.
    """
    # the distinct labels only: a large table has millions of cells but few participants
    codes, written = pd.factorize(labels.to_numpy(dtype=object))
    if not all(is_canonical_integer(str(label)) for label in written):
        return labels.astype("str")
    numbers = np.array([int(label) for label in written] or [0], dtype=np.int64)[codes]
    missing = codes < 0
    if missing.any():  # pandas reads integers with blanks as float64 (int64 -> float64 rounds to nearest)
        return pd.Series(np.where(missing, np.nan, numbers.astype(np.float64)), index=labels.index,
                         name=labels.name)
    return pd.Series(numbers, index=labels.index, name=labels.name)


def read_csv_labels(path: str | Path, dtype: dict[str, object] | None = None,
                    **options: object) -> pd.DataFrame:
    """``pandas.read_csv`` of a real table with its :data:`LABEL_COLUMNS` kept as written
    (:func:`labels_as_written`): the one reading of a real table's labels, refusing a row with
    fewer or more fields than the header (:func:`nudgecli.csv_rows.read_csv_whole_rows`).

    Parameters
    ----------
    path
        The CSV file.
    dtype
        Further columns' dtypes (e.g. ``{"condition": "category"}``).
    options
        Passed on to ``pandas.read_csv`` (``sep``, ``float_precision``).

    Raises
    ------
    DataError
        A row with fewer or more fields than the header.
    """
    as_text = {column: object for column in LABEL_COLUMNS}  # a column the table lacks is ignored
    table = read_csv_whole_rows(path, dtype={**as_text, **(dtype or {})}, **options)
    for column in LABEL_COLUMNS:
        if column in table.columns:
            table[column] = labels_as_written(table[column])
    return table


def read_metrics_table(path: str | Path) -> pd.DataFrame:
    """Read a metrics table (CSV or Parquet) as it is.

    Raises
    ------
    DataError
        Not a CSV/Parquet file, empty, unreadable, or no rows.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in TABLE_SUFFIXES:
        raise DataError(f"{path} is neither a run folder nor a metrics table; give a run folder (with "
                        "trials/ and steps/) or a .csv/.parquet table with one row per trial")
    try:
        if suffix == ".csv":
            delimiter = sniff_delimiter(path)
            check_unique_columns(_csv_header(path, delimiter), path)
            # conditions as categories: a large table's labels are not copied into millions of strings
            table = read_csv_labels(path, sep=delimiter, dtype={"condition": "category"})
        else:
            check_unique_columns(pq.read_schema(path).names, path)
            table = read_parquet(path)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; a metrics table needs a header (participant, condition, "
                        "metrics) and one row per trial") from None
    except UnicodeDecodeError:
        raise DataError(not_utf8_message(path)) from None
    except (pd.errors.ParserError, OSError, ValueError, pa.ArrowException) as exc:
        raise DataError(f"{path} cannot be read as a {suffix[1:]} table: {exc}") from None
    if table.empty:
        raise DataError(f"{path} has no rows; a metrics table needs one row per trial")
    release_free_memory()
    return table


def _csv_header(path: Path, delimiter: str) -> list[str]:
    """The column names of a CSV file's first line, as written."""
    with open(path, encoding="utf-8-sig", errors="replace", newline="") as handle:
        return next(csv.reader(handle, delimiter=delimiter), [])


def check_unique_columns(names: Sequence[str], source: str | Path) -> None:
    """Refuse a table in which two columns share a name (pandas would rename the second
    ``name.1`` and analyse it as a metric of its own).

    Raises
    ------
    DataError
        Naming the column and its positions (1-based).
    """
    positions: dict[str, list[int]] = {}
    for position, name in enumerate(names, start=1):
        positions.setdefault(str(name), []).append(position)
    repeated = {name: where for name, where in positions.items() if len(where) > 1}
    if repeated:
        listed = "; ".join(f"{name!r} (columns {', '.join(map(str, where[:-1]))} and {where[-1]})"
                           for name, where in repeated.items())
        raise DataError(f"{source}: more than one column of one name: {listed}; rename or remove the "
                        "repeats so that each column has its own name")


def release_free_memory() -> None:
    """Hand the heap that parsing freed back to the operating system (glibc only; else nothing).

    The CSV parser makes and frees millions of small objects (one per label cell); glibc keeps
    that memory in the process unless asked, which for a table of millions of rows is a few
    hundred MB of resident memory that nothing uses.
    """
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    if name is None:  # pragma: no cover - not a C library ctypes can find
        return
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(name).malloc_trim(0)


def sniff_delimiter(path: Path, sample_bytes: int = 65536) -> str:
    """The field separator of a CSV file (``,``, ``;``, tab or ``|``), from its first 64 KiB.

    ``csv.Sniffer`` decides; a file it cannot decide (one column) is read with ``,``.
    """
    try:
        with open(path, encoding="utf-8", errors="replace", newline="") as handle:
            sample = handle.read(sample_bytes)
    except OSError:
        return ","  # pandas reports the problem when it reads the file
    lines = sample.splitlines()
    if len(sample) == sample_bytes and len(lines) > 1:
        sample = "\n".join(lines[:-1])  # the last line may be cut
    try:
        return csv.Sniffer().sniff(sample, delimiters=",;\t|").delimiter
    except csv.Error:
        return ","


def _rows(positions: Sequence[int], first_row: int) -> str:
    """Row numbers for a message: the first few, then how many more."""
    shown = ", ".join(str(int(i) + first_row) for i in positions[:_SHOWN])
    more = f" and {len(positions) - _SHOWN} more" if len(positions) > _SHOWN else ""
    return shown + more


def check_condition_labels(table: pd.DataFrame, source: str) -> None:
    """Refuse condition labels that differ only by case or surrounding spaces (``Control``, ``control ``).

    Raises
    ------
    DataError
        Naming the near-identical labels and the most frequent spelling as the one meant.
    """
    counts = table["condition"].value_counts()  # most frequent first
    groups: dict[str, list[str]] = {}
    for label in (str(value) for value, count in counts.items() if count > 0):
        groups.setdefault(label.strip().casefold(), []).append(label)
    for spellings in groups.values():
        if len(spellings) > 1:
            listed = ", ".join(repr(label) for label in spellings)
            raise DataError(f"{source}: condition labels {listed} differ only by case or surrounding spaces "
                            f"(did you mean {spellings[0]!r}?); spell each condition one way")


def find_duplicate_trials(table: pd.DataFrame) -> tuple[list[str], np.ndarray]:
    """The trial key columns present and a mask of rows repeating an earlier row's key.

    Returns
    -------
    (list of str, np.ndarray)
        The key columns used (``participant``, ``condition`` and whichever of ``block``,
        ``trial`` exist) and ``(n_rows,)`` booleans, True for each repeat after the first. No
        ``trial`` column: no key, nothing is a duplicate.
    """
    if "trial" not in table.columns:
        return [], np.zeros(len(table), dtype=bool)
    key = [c for c in TRIAL_KEY if c in table.columns]
    combined = np.zeros(len(table), dtype=np.int64)
    span = 1
    for column in key:  # one int64 code per row: far less memory than DataFrame.duplicated on a large table
        column_codes, uniques = pd.factorize(table[column], use_na_sentinel=False)
        size = max(1, len(uniques))
        span *= size
        if span >= 2**62:  # the combined code would overflow: let pandas hash the rows
            return key, table.duplicated(subset=key, keep="first").to_numpy()
        combined *= size
        combined += column_codes
        del column_codes
    order = np.argsort(combined, kind="stable")  # equal keys stay in row order: the first is kept
    ordered = combined[order]
    repeats = np.zeros(len(table), dtype=bool)
    repeats[order[1:][ordered[1:] == ordered[:-1]]] = True
    return key, repeats


def _check_finite(table: pd.DataFrame, metric_columns: Sequence[str], source: str, first_row: int) -> None:
    """Refuse infinite values in metric columns (missing values are allowed: they are left out)."""
    bad: list[str] = []
    positions: set[int] = set()
    for column in metric_columns:
        if pd.api.types.is_bool_dtype(table[column]):
            continue
        values = table[column].to_numpy(dtype=float, na_value=np.nan)
        infinite = np.flatnonzero(np.isinf(values))
        if infinite.size:
            bad.append(f"{column!r} (rows {_rows(list(infinite), first_row)})")
            positions.update(int(i) for i in infinite)
    if bad:
        raise DataError(f"{source}: infinite values in {len(positions)} row(s): {'; '.join(bad)}; "
                        "replace them with a number or leave the cell empty (a missing value)")


def _why_not_numeric(series: pd.Series, first_row: int) -> tuple[str, str]:
    """What is wrong with a non-numeric column, and its fix. A column of true/false cells
    (:func:`_boolean_cells`) and numbers, each a metric's format alone, ``mixes`` them: the first
    number is named (``row 3 holds '1'``), for the column to be written in one format. Otherwise the
    first cell that is not a number (a blank is a missing value, not the culprit; among true/false,
    one that is neither: ``'yes'``), with the decimal-comma advice where it is one
    (:func:`nudgecli.csv_text.decimal_comma_advice`); none named if none can be singled out."""
    present = series.notna().to_numpy()
    numbers = pd.to_numeric(series, errors="coerce").notna().to_numpy()
    booleans = _boolean_cells(series)
    culprits = np.flatnonzero(present & ~numbers & ~booleans)
    if not culprits.size and booleans.any() and (present & numbers).any():
        # True or 1 alone is each a success; together the column is neither format (1 and True both
        # count as 1, but 0.5 or 7 among true/false would be counted too)
        mixed = np.flatnonzero(present & numbers & ~booleans)
        value = series.iloc[int(mixed[0])]
        return (f"mixes true/false with numbers (row {int(mixed[0]) + first_row} holds {value!r})",
                "write it all as true/false or all as numbers (1 and 0)")
    if not culprits.size:  # no true/false among them: every cell that is not a number
        culprits = np.flatnonzero(present & ~numbers)
    if not culprits.size:
        return "is not numeric", "make it numeric"
    more = f", and {culprits.size - 1} more cell(s)" if culprits.size > 1 else ""
    value = series.iloc[int(culprits[0])]
    advice = decimal_comma_advice(value) if isinstance(value, str) else None
    return (f"is not numeric (row {int(culprits[0]) + first_row} holds {value!r}{more}"
            f"{'; ' + advice if advice else ''})", "make it numeric")


def _beyond_int64(value: object) -> bool:
    """Whether a cell is an integer outside int64: a Python int, or its text (``99999999999999999999``)."""
    if isinstance(value, str):
        text = value.strip()
        if not (text.lstrip("+-").isascii() and text.lstrip("+-").isdigit()):
            return False
        value = int(text)
    return isinstance(value, int) and not isinstance(value, bool) and \
        not _INT64_RANGE[0] <= value <= _INT64_RANGE[1]


def _large_integers_as_floats(series: pd.Series) -> pd.Series | None:
    """A column not read as numbers that holds an integer beyond int64 and numbers only, as
    floats; else ``None``.

    pandas reads such a column as numbers (floats) when a decimal comes first and as text or Python
    ints otherwise (the large integer in the first row, or no decimal at all), so one value was
    accepted in row 3 and refused, with no row named, in row 2: read here as the floats it is
    wherever it sits, like any other number too large for an integer column."""
    if _is_numeric(series):
        return None
    numbers = pd.to_numeric(series, errors="coerce")
    present = series.notna()
    if numbers[present].isna().any() or not any(_beyond_int64(v) for v in series[present]):
        return None
    return numbers.astype(float)


def _is_numeric(series: pd.Series) -> bool:
    return pd.api.types.is_bool_dtype(series) or pd.api.types.is_numeric_dtype(series)


#: The texts a CSV reader takes for true and false (pandas' default ``true_values`` and
#: ``false_values``): a column of them, blanks aside, is read as booleans.
BOOLEAN_TEXTS = {"True": True, "TRUE": True, "true": True, "False": False, "FALSE": False, "false": False}


def _boolean_cells(series: pd.Series) -> np.ndarray:
    """``(T,)`` bool: which cells hold true or false, a boolean or its text (:data:`BOOLEAN_TEXTS`):
    the one rule of a boolean metric's cells."""
    return np.fromiter((isinstance(v, bool | np.bool_) or (isinstance(v, str) and v in BOOLEAN_TEXTS)
                        for v in series), dtype=bool, count=len(series))


def _as_boolean(series: pd.Series) -> pd.Series | None:
    """A column of True/False with blanks (read by pandas as objects) as nullable booleans, else None."""
    values = series.dropna()
    if len(values) and _boolean_cells(values).all():
        return series.map(lambda v: BOOLEAN_TEXTS.get(v, v) if isinstance(v, str) else v).astype("boolean")
    return None


def refuse_empty_cells(table: pd.DataFrame, column: str, source: str, first_row: int = 2) -> None:
    """Refuse an empty cell in ``column``, one a row is counted by (a trial's or a questionnaire
    response's ``participant`` or ``condition``): the one rule of every real table.

    Raises
    ------
    DataError
        Naming the file, the column, the first such row and the fix.
    """
    empty = table[column].isna()
    if empty.any():
        row = int(empty.to_numpy().nonzero()[0][0])
        raise DataError(f"{source}: column {column!r} is empty in row {row + first_row}; fill it in "
                        "or remove the row")


def validate_metrics_table(table: pd.DataFrame, source: str, first_row: int = 2,
                           min_conditions: int = 1, chosen: Collection[str] | None = None) -> list[str]:
    """Check a metrics table and return its metric columns.

    Boolean columns with blanks (``True``, ``False``, empty) are converted in place to nullable
    booleans.

    Parameters
    ----------
    table
        The table as read.
    source
        Its name in messages.
    first_row
        The row number messages give the table's first row (2 for a CSV: line 1 is the header).
    min_conditions
        Fewest conditions the table must hold.
    chosen
        The metrics asked for (``--metric``); ``None``: every metric column. Only a chosen column
        must be numeric: one that is not, and not chosen, is ignored (left out of the result).

    Returns
    -------
    list of str
        The numeric metric columns (every column but :data:`NON_METRIC_COLUMNS`, less the
        non-numeric ones not chosen), in the table's order.

    Raises
    ------
    DataError
        A missing or incomplete ``participant``/``condition`` column, no metric column, a
        non-numeric metric column (a chosen one, with ``chosen``), an infinite value, condition
        labels differing only by case or surrounding spaces, or fewer than ``min_conditions``
        conditions (a single condition is analysed descriptively).
    """
    for column in ("participant", "condition"):
        if column not in table.columns:
            hint = did_you_mean(column, [str(c) for c in table.columns])
            raise DataError(f"{source} has no {column!r} column{hint}; a metrics table needs "
                            "participant, condition and metric columns, one row per trial")
        refuse_empty_cells(table, column, source, first_row)
    metric_columns = [str(c) for c in table.columns if c not in NON_METRIC_COLUMNS]
    if not metric_columns:
        raise DataError(f"{source} has no metric columns; add one numeric column per metric "
                        f"(e.g. {', '.join(METRIC_NAMES[:3])})")
    numeric_columns: list[str] = []
    for column in metric_columns:
        if table[column].dtype == object and (converted := _as_boolean(table[column])) is not None:
            table[column] = converted
        if (numbers := _large_integers_as_floats(table[column])) is not None:
            table[column] = numbers
        if not _is_numeric(table[column]):
            if chosen is not None and column not in chosen:
                continue  # not analysed: --metric picked others
            wrong, fix = _why_not_numeric(table[column], first_row)
            choice = "leave it out of --metric" if chosen is not None else "pick the metrics with --metric"
            raise DataError(f"{source}: metric column {column!r} {wrong}; {fix}, remove it, or {choice}")
        numeric_columns.append(column)
    _check_finite(table, numeric_columns, source, first_row)
    check_condition_labels(table, source)
    conditions = sorted({str(value) for value in table["condition"].dropna().unique()})
    if len(conditions) < min_conditions:
        raise DataError(f"{source}: column 'condition' holds {len(conditions)} condition(s); "
                        f"this needs at least {min_conditions}")
    return numeric_columns


def drop_or_refuse_duplicates(table: pd.DataFrame, source: Path, first_row: int, drop_duplicates: bool,
                              notes: list[str]) -> tuple[pd.DataFrame, bool]:
    """``table`` without repeated trial rows (:func:`find_duplicate_trials`), and whether any were
    dropped: the one check of duplicated trials, for ``analyze`` and ``compare`` alike.

    Raises
    ------
    DataError
        Repeated trial rows and not ``drop_duplicates`` (naming the rows and the flag).
    """
    key, repeats = find_duplicate_trials(table)
    if not repeats.any():
        return table, False
    positions = np.flatnonzero(repeats)
    if not drop_duplicates:
        raise DataError(f"{source}: {positions.size} duplicate trial row(s) (same {', '.join(key)} as an "
                        f"earlier row): rows {_rows(list(positions), first_row)}; remove them, or pass "
                        "--drop-duplicates to keep the first of each")
    notes.append(f"{source}: dropped {positions.size} duplicate trial row(s) (same {', '.join(key)}; the "
                 f"first of each kept): rows {_rows(list(positions), first_row)}")
    return table.loc[~repeats].reset_index(drop=True), True
