"""What to tell a researcher whose CSV file a spreadsheet wrote in its locale's way: text that is
not UTF-8 (latin-1 or Windows-1252, as a European spreadsheet saves "CSV") and numbers written
with a decimal comma (``0,5``, with semicolons between the columns, which
:func:`header_delimiter` finds). The one wording of that
advice for every reader of a user table (metrics tables, real habit logs), and the test for a
JSON or TOML file given where a CSV is read (:func:`starts_as_json`, :func:`starts_as_toml`); it
sits outside ``report/`` and ``sim/`` so that both can use it.
"""

from __future__ import annotations

import csv
import json
import math
import re
from collections.abc import Callable
from pathlib import Path

from nudgecli.errors import shell_words
from nudgecli.run_folder_names import MANIFEST, PART_KINDS

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


def not_utf8_message(path: Path, *, reads_run_folders: bool = False) -> str:
    """The one line for a CSV file that is not UTF-8: where its first byte that is not UTF-8 is
    (line and byte), and how to save it as UTF-8; a Parquet file: :func:`parquet_message`.

    The file is read line by line from the start (only once its reading has failed): the position
    a decoder reports is within the block it was given, not within the file.

    Parameters
    ----------
    path
        The file whose reading failed with a ``UnicodeDecodeError``.
    reads_run_folders
        Whether the reader also takes a run folder (``nudge habits``, ``fit-people``), which a
        run's Parquet part is then named as a part of; the other readers take CSV files only.
    """
    if starts_as_parquet(path):  # binary, so never UTF-8: a run's part given for a CSV
        return parquet_message(path, reads_run_folders=reads_run_folders)
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


#: The 4 bytes a Parquet file starts (and ends) with.
PARQUET_MAGIC = b"PAR1"


def starts_as_parquet(path: Path) -> bool:
    """Whether a file starts with Parquet's magic bytes (:data:`PARQUET_MAGIC`), whatever its name."""
    try:
        with path.open("rb") as file:
            return file.read(len(PARQUET_MAGIC)) == PARQUET_MAGIC
    except OSError:
        return False


def parquet_run_folder(path: Path) -> Path | None:
    """The run folder a Parquet file is a part of (in its ``steps/``, ``trials/`` or
    ``participants/``, or a table beside its manifest); ``None`` where it is none's."""
    parent = path.parent
    if parent.name in PART_KINDS and (parent.parent / MANIFEST).is_file():
        return parent.parent
    return parent if (parent / MANIFEST).is_file() else None


def parquet_message(path: Path, *, reads_run_folders: bool = False) -> str:
    """The one line for a Parquet file given where CSV text is read: to a reader that
    ``reads_run_folders``, a run folder's part (its ``steps/``, ``trials/`` or ``participants/``,
    or a table beside its manifest) names the run folder to give instead; otherwise it is no CSV,
    and the CSV file is to be given (a reader of CSV files only would refuse the run folder)."""
    said = f"{path}: a Parquet file (it starts with {PARQUET_MAGIC.decode()}), not CSV text"
    if not reads_run_folders:
        return f"{said}; give the CSV file"
    run = parquet_run_folder(path)
    if run is not None:
        return f"{said}; it is a part of the run folder {run}, which is read whole: give the run folder {run}"
    return f"{said}; give the CSV file (or the run folder it came from)"


#: A TOML file's first line: a table header (``[study]``, ``[[conditions]]``, ``[population.x]``)
#: or a ``key = value`` (a value starting as TOML's do: text, array, table, boolean or number).
_TOML_HEADER = re.compile(r"\[\[?\s*[A-Za-z_][\w.\- ]*\]\]?\s*(#.*)?")
_TOML_KEY_VALUE = re.compile(r"[A-Za-z_][\w.\-]*\s*=\s*(\"|'|\[|\{|true|false|[-+]?\d).*")


def _first_line(path: Path) -> str:
    """A file's first line that is neither blank nor a ``#`` comment (a BOM left out), stripped;
    looked for in its first 4096 bytes."""
    with path.open("rb") as file:
        start = file.read(4096).decode("utf-8", errors="replace").lstrip("\ufeff")
    return next((line.strip() for line in start.splitlines()
                 if line.strip() and not line.strip().startswith("#")), "")


def starts_as_toml(path: Path) -> bool:
    """Whether a file is TOML (an experiment, plan or sweep file, a run's ``config.toml``): its
    suffix ``.toml``, or a first line that is a ``[name]`` header (not a JSON array: ``[1, 2]``)
    or a ``key = value``. No CSV log or table starts so."""
    if path.suffix.lower() == ".toml":
        return True
    line = _first_line(path)
    if _TOML_KEY_VALUE.fullmatch(line):
        return True
    if _TOML_HEADER.fullmatch(line) is None:
        return False
    try:
        json.loads(line)
    except ValueError:
        return True
    return False  # [true], a JSON array of one word


def starts_as_json(path: Path) -> bool:
    """Whether a file's text starts as JSON does (``{`` or ``[``, as ``nudge habits --format json``
    and a run's ``manifest.json`` do; not a TOML file's ``[section]``: :func:`starts_as_toml`): no
    CSV log or table starts so, and read as CSV its lines give the column messages of a log, not
    what the file is."""
    with path.open("rb") as file:
        start = file.read(4096).lstrip(b"\xef\xbb\xbf \t\r\n")  # a BOM, then blank space
    return start[:1] in (b"{", b"[") and not starts_as_toml(path)


def toml_source_message(path: Path, reads: str, command: list[str]) -> str:
    """What ``nudge habits`` or ``fit-people`` (``command``: its words after ``nudge``, ``SOURCE``
    the source's place) says of a TOML file given as its source, which says what it ``reads``: a run's
    own ``config.toml``: give the folder; else an experiment is simulated first."""
    said = f"{path}: a TOML file (an experiment or plan file), not a source; {reads}"
    if (path.parent / MANIFEST).is_file():
        return f"{said}; for the run this file belongs to, give the run folder itself: " \
               f"{_command_of(command, str(path.parent))}"
    return (f"{said}; to measure an experiment's people, simulate it and give the run: "
            f"{shell_words(['nudge', 'simulate', str(path), '--out', 'RUN'])}, then "
            f"{_command_of(command, 'RUN')}")


def _command_of(command: list[str], source: str) -> str:
    """``nudge`` and ``command``'s words, ``source`` in place of ``SOURCE``."""
    return shell_words(["nudge", *(source if word == "SOURCE" else word for word in command)])
