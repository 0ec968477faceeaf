"""Refusing a CSV file whose rows do not have the header's number of fields: the one rule of
every user file nudge reads as CSV (metrics tables, questionnaires, real habit logs, habits
tables, calibration logs).

pandas reads both kinds of uneven row without a word:

- a row with FEWER fields than the header (a file whose last line was cut off: ``1,disambig``)
  gets its missing cells empty, so the fragment becomes a row of its own (a fake condition, a
  calibration prompt read as cleared);
- when every row has MORE fields than the header (a separator at the end of each line, a header
  that lost a name), ``pandas.read_csv`` takes the first field as the row label (its implicit
  index) and shifts every cell one column to the left; a single long row further down is a
  ``ParserError`` whose text names pandas' own count of lines.

:func:`read_csv_whole_rows` reads with ``pandas.read_csv`` and looks at the file's rows
(:func:`refuse_uneven_rows`) only when the result shows a sign of an uneven row (the last column
has a missing or empty cell, the first row is longer than the header, a parser error), so a
large complete table is read as fast as before. It sits outside ``report/`` and ``sim/`` so that
both can use it.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pandas as pd

from nudgecli.errors import DataError


def read_csv_whole_rows(path: str | Path, **options: Any) -> pd.DataFrame:
    """``pandas.read_csv(path, **options)``, refusing a row with fewer or more fields than the
    header (:func:`refuse_uneven_rows`).

    Parameters
    ----------
    path
        The CSV file.
    options
        Passed on to ``pandas.read_csv`` (``sep``: a delimiter, a comma when absent as for pandas,
        or ``None`` for pandas' sniffing of the first line; the rows are counted with the same one).

    Returns
    -------
    pd.DataFrame
        ``(rows, header fields)``: the table as pandas reads it, with its default row numbers.

    Raises
    ------
    DataError
        A row with fewer or more fields than the header (naming the file and the line).
    pandas.errors.ParserError, pandas.errors.EmptyDataError, UnicodeDecodeError, OSError
        As ``pandas.read_csv`` raises them for anything else (the caller words them).
    """
    # pandas' own default: no sep is a comma; only sep=None is its sniffing of the first line
    sep = options.get("sep", ",")
    try:
        table = pd.read_csv(path, **options)
    except pd.errors.ParserError:
        # pandas refuses a long row below the first one: name the line as the file counts it
        refuse_uneven_rows(path, _delimiter(path, sep))
        raise
    delimiter = _delimiter(path, sep)
    # pandas makes an implicit index exactly when the first row is longer than the header (its
    # row labels can look like the default 0, 1, 2, ..., so the first row is what is looked at)
    if _first_row_is_long(path, delimiter) or (len(table.columns) and _has_empty_cell(table.iloc[:, -1])):
        refuse_uneven_rows(path, delimiter)
    return table


def _has_empty_cell(cells: pd.Series) -> bool:
    """Whether a column holds a missing cell (NaN) or, read as text without NaN, an empty one:
    how pandas fills the missing fields of a short row."""
    if cells.isna().any():
        return True
    is_text = cells.dtype == object or pd.api.types.is_string_dtype(cells.dtype)
    return is_text and bool((cells == "").any())


def _first_row_is_long(path: str | Path, delimiter: str) -> bool:
    """Whether the first row after the header has more fields than the header (blank lines
    skipped, as pandas skips them)."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace", newline="") as handle:
            rows = (row for row in csv.reader(handle, delimiter=delimiter)
                    if len(row) > 1 or "".join(row).strip())
            header, first = next(rows, []), next(rows, [])
    except (csv.Error, OSError):
        return False  # pandas read it; refuse_uneven_rows would say what it cannot read
    return len(first) > len(header)


def _delimiter(path: str | Path, sep: object) -> str:
    """The field separator pandas read ``path`` with: ``sep`` as given (the caller passes a comma
    when its options name none, pandas' default), or for ``sep=None`` the one ``csv.Sniffer``
    finds in the first line, as pandas' sniffing does (a comma where it finds none)."""
    if sep is not None:
        return str(sep)
    try:
        with open(path, encoding="utf-8-sig", errors="replace", newline="") as handle:
            first = handle.readline()
        return csv.Sniffer().sniff(first).delimiter
    except (csv.Error, OSError):
        return ","


def refuse_uneven_rows(path: str | Path, delimiter: str) -> None:
    """Refuse a CSV row with fewer or more fields than the header (see the module docstring).

    A row of empty cells written out (``,,,``) is complete; blank lines are skipped, as pandas
    skips them; quoted fields may hold the delimiter and line breaks. Lines are the file's own
    (line 1 is the header).

    Parameters
    ----------
    path
        The CSV file.
    delimiter
        Its field separator.

    Raises
    ------
    DataError
        Naming the file, the first uneven line, its fields and the header's: a short last line as
        a file cut off, other short lines as rows that lost cells, a long line as fields that
        would shift every cell.
    """
    width = 0
    first_short = first_long = (0, 0)  # (line, fields) of the first short and the first long row
    n_short = n_long = 0
    last_is_short = False
    try:
        with open(path, encoding="utf-8-sig", errors="replace", newline="") as handle:
            reader = csv.reader(handle, delimiter=delimiter)
            for row in reader:
                if len(row) <= 1 and not "".join(row).strip():
                    continue  # a blank (or white-space) line: pandas skips it
                if not width:
                    width = len(row)  # the header
                    continue
                last_is_short = len(row) < width
                if last_is_short:
                    n_short += 1
                    first_short = first_short if n_short > 1 else (reader.line_num, len(row))
                elif len(row) > width:
                    n_long += 1
                    first_long = first_long if n_long > 1 else (reader.line_num, len(row))
    except (csv.Error, OSError) as exc:
        raise DataError(f"{path} cannot be read as a csv table: {exc}") from None
    if n_long and (not n_short or first_long[0] < first_short[0]):
        line, fields = first_long
        more = f" (and {n_long - 1} more line(s) like it)" if n_long > 1 else ""
        raise DataError(f"{path}: line {line} has {fields} fields, the header {width}{more}; a row longer "
                        "than the header would shift its cells into the wrong columns: name the column the "
                        "header lacks, remove the extra field (a separator at the end of the line too), or "
                        "quote a cell that holds the separator")
    if not n_short:
        return
    line, fields = first_short
    if n_short == 1 and last_is_short:
        raise DataError(f"{path}: line {line} has {fields} of {width} fields; the file looks cut off: "
                        "complete that line or remove it")
    more = f" (and {n_short - 1} more line(s) like it)" if n_short > 1 else ""
    raise DataError(f"{path}: line {line} has {fields} of {width} fields{more}; the file looks cut off or "
                    "a row lost cells: write every field of each row (an empty cell still needs its "
                    "separator) or remove the line")
