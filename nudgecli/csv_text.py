"""What to tell a researcher whose CSV file a spreadsheet wrote in its locale's way: text that is
not UTF-8 (latin-1 or Windows-1252, as a European spreadsheet saves "CSV") and numbers written
with a decimal comma (``0,5``, with semicolons between the columns, which
:func:`header_delimiter` finds). The one wording of that
advice for every reader of a user table (metrics tables, real habit logs), and the test for a
JSON file given where a CSV is read (:func:`starts_as_json`); it sits outside ``report/`` and
``sim/`` so that both can use it.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable
from pathlib import Path

#: The delimiters a CSV file of a researcher's may use, in the order tried: a spreadsheet in a
#: locale with a decimal comma writes semicolons.
DELIMITERS = (",", ";", "\t", "|")

#: A number as a spreadsheet in a decimal-comma locale writes it: 0,5, -1,25, ,5, 1,5E-03.
_DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+(?:[eE][+-]?\d+)?")


def decimal_comma_advice(text: str) -> str | None:
    """``"a decimal comma? write 0.5"`` where ``text`` is a finite number written with one decimal
    comma (``0,5``, ``-1,25``), else ``None`` (``inf``, ``abc``, ``1,000,5``, ``1,``: a point for
    the comma makes no number of them, and the advice would be wrong).

    Parameters
    ----------
    text
        A cell as written.
    """
    written = text.strip()
    if _DECIMAL_COMMA.fullmatch(written) is None:
        return None
    pointed = written.replace(",", ".")
    if not math.isfinite(float(pointed)):  # 1,5e999
        return None
    return f"a decimal comma? write {pointed}"


def header_delimiter(header: str, fits: Callable[[set[str]], bool]) -> str:
    """The first of :data:`DELIMITERS` under which the ``header`` line's column names (stripped)
    ``fits`` (say, holds every required column), else a comma (for the error to say what the
    header holds). The one rule of the readers of a user's table whose columns are known (real
    logs, people files)."""
    for delimiter in DELIMITERS:
        names = next(csv.reader([header], delimiter=delimiter), [])
        if fits({name.strip() for name in names}):
            return delimiter
    return ","


def not_utf8_message(path: Path) -> str:
    """The one line for a CSV file that is not UTF-8: where its first byte that is not UTF-8 is
    (line and byte), and how to save it as UTF-8.

    The file is read line by line from the start (only once its reading has failed): the position
    a decoder reports is within the block it was given, not within the file.

    Parameters
    ----------
    path
        The file whose reading failed with a ``UnicodeDecodeError``.
    """
    fix = "save it as UTF-8 (a spreadsheet's \"CSV UTF-8\", an editor's encoding UTF-8)"
    try:
        with path.open("rb") as file:
            for number, line in enumerate(file, start=1):
                try:
                    line.decode("utf-8")
                except UnicodeDecodeError as exc:
                    return (f"{path}: not UTF-8 text (byte 0x{line[exc.start]:02x} on line {number}; a "
                            f"spreadsheet's latin-1 or Windows encoding?); {fix}")
    except OSError:  # gone since its reading failed: say what is known
        pass
    return f"{path}: not UTF-8 text; {fix}"


def starts_as_json(path: Path) -> bool:
    """Whether a file's text starts as JSON does (``{`` or ``[``, as ``nudge habits --format json``
    and a run's ``manifest.json`` do): no CSV log or table starts so, and read as CSV its lines give
    the column messages of a log, not what the file is."""
    with path.open("rb") as file:
        start = file.read(4096).lstrip(b"\xef\xbb\xbf \t\r\n")  # a BOM, then blank space
    return start[:1] in (b"{", b"[")
