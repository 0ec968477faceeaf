"""The people file (``nudge fit-people --out PEOPLE.csv``, ``--people PEOPLE.csv``): one twin a row.

A CSV with a strict schema (:data:`PEOPLE_COLUMNS`):

- ``person``: 0, 1, 2 ... in order (study participant ``i`` is person ``i mod P``);
- ``source``, ``participant``: where the twin comes from (a file or folder name, the
  participant's label there);
- one column per parameter of :data:`~nudgecli.sim.twins.TWIN_PARAMETERS`: the fitted value, or
  empty where the population's draw is used;
- ``from_population``: the parameters left to the population's draw, separated by ``;`` (exactly
  the empty cells).

A parameter column may be left out (every person draws it); any other column is refused, and so
is a value the simulation does not accept (``[population]``'s check of that parameter).
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from nudgecli.csv_text import (
    PARQUET_MAGIC,
    decimal_comma_advice,
    header_delimiter,
    not_utf8_message,
    parquet_run_folder,
    starts_as_parquet,
)
from nudgecli.errors import DataError, did_you_mean, shell_words
from nudgecli.run_folder_names import MANIFEST, PEOPLE_DIR
from nudgecli.sim.twins import INTEGER_PARAMETERS, TWIN_PARAMETERS, Twin, parameter_is_valid, parameter_needs

#: The columns of a people file, in order.
PEOPLE_COLUMNS = ("person", "source", "participant", *TWIN_PARAMETERS, "from_population")
#: Columns every people file has.
REQUIRED_COLUMNS = ("person", "source", "participant", "from_population")
#: The columns only a people file has (a log or a habits table may have ``participant`` too).
_PEOPLE_OWN_COLUMNS = frozenset(PEOPLE_COLUMNS) - {"source", "participant"}
#: Separator of the ``from_population`` list.
LIST_SEPARATOR = ";"


@dataclass(frozen=True)
class People:
    """The twins of a people file, with what identifies the file.

    Attributes
    ----------
    name
        The file's name (no folder).
    sha256
        The SHA-256 of its bytes, hex.
    twins
        ``(P,)`` the twins in ``person`` order.
    data
        The file's bytes, for the copy a run or batch folder keeps (:func:`keep_copy`); empty for
        people made in memory, who have no file to copy.
    """

    name: str
    sha256: str
    twins: tuple[Twin, ...]
    data: bytes = field(default=b"", repr=False, compare=False)

    def record(self) -> dict[str, Any]:
        """What a manifest records of it (and what ``--resume`` compares)."""
        return {"file": self.name, "sha256": self.sha256, "people": len(self.twins)}


def _format_value(name: str, value: float) -> str:
    return str(int(value)) if name in INTEGER_PARAMETERS else repr(float(value))


def people_csv(twins: Sequence[Twin]) -> str:
    """The people file's text of ``twins`` (person ``i`` is ``twins[i]``)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(PEOPLE_COLUMNS)
    for person, twin in enumerate(twins):
        values = [_format_value(name, twin.parameters[name]) if name in twin.parameters else ""
                  for name in TWIN_PARAMETERS]
        writer.writerow([person, twin.source, twin.participant, *values,
                         LIST_SEPARATOR.join(twin.from_population)])
    return buffer.getvalue()


def _parse_value(path: Path, where: str, name: str, text: str) -> float:
    """A parameter cell's value, or a DataError naming the file, the person and the field."""
    try:
        value = float(text)
    except ValueError:
        advice = decimal_comma_advice(text)
        raise DataError(f"{path}: {where}: {name}: {text!r} is not a number"
                        f"{f' ({advice})' if advice else ''}") from None
    if not parameter_is_valid(name, value):
        raise DataError(f"{path}: {where}: {name}: {text} is out of its valid range (needs "
                        f"{parameter_needs(name)})")
    return int(value) if name in INTEGER_PARAMETERS else value


def _row_twin(path: Path, row: dict[str, str], position: int, present: Sequence[str]) -> Twin:
    person, participant = row["person"].strip(), row["participant"].strip()
    where = f"person {person or '?'} (participant {participant!r})"
    if person != str(position):
        raise DataError(f"{path}: {where}: person: expected {position} (people are numbered 0, 1, 2 ... in "
                        "order)")
    listed = [name.strip() for name in row["from_population"].split(LIST_SEPARATOR) if name.strip()]
    for name in listed:
        if name not in TWIN_PARAMETERS:
            raise DataError(f"{path}: {where}: from_population: {name!r} is not a twin's parameter"
                            f"{did_you_mean(name, TWIN_PARAMETERS)}; they are {', '.join(TWIN_PARAMETERS)}")
    parameters: dict[str, float] = {}
    for name in present:
        text = row[name].strip()
        if not text:
            if name not in listed:
                raise DataError(f"{path}: {where}: {name}: empty but not listed in from_population")
            continue
        if name in listed:
            raise DataError(f"{path}: {where}: {name}: has a value but is listed in from_population")
        parameters[name] = _parse_value(path, where, name, text)
    return Twin(participant=participant, source=row["source"].strip(), parameters=parameters)


def _folder_message(path: Path) -> str:
    """The line for a folder given as a people file: the copy of one it keeps (a run or batch
    folder's ``people/<name>``), else how to make one (from a run folder's participants)."""
    kept = path / PEOPLE_DIR
    copies = sorted(item for item in kept.iterdir() if item.is_file()) if kept.is_dir() else []
    what = "a run folder" if (path / MANIFEST).is_file() else "a folder"
    if copies:
        return (f"{path}: {what}, not a people file; give the people file it keeps: --people "
                f"{' or '.join(str(copy) for copy in copies)}")
    if (path / MANIFEST).is_file():
        return (f"{path}: {what}, not a people file; make one of its participants with `nudge fit-people "
                f"{path} --out people.csv`, then give --people people.csv")
    return (f"{path}: {what}, not a people file; give a people file's path (make one with `nudge "
            "fit-people SOURCE... --out people.csv`)")


def _parquet_message(path: Path) -> str:
    """The line for a Parquet file given as a people file (a people file is CSV text, never Parquet):
    how to make one of the people of the run folder it is a part of (else of a source)."""
    run = parquet_run_folder(path)
    if run is None:
        of, fit = "a table", "nudge fit-people SOURCE... --out people.csv"
    else:
        of, fit = f"a part of the run folder {run}", shell_words(["nudge", "fit-people", str(run), "--out",
                                                                  "people.csv"])
    return (f"{path}: a Parquet file (it starts with {PARQUET_MAGIC.decode()}), {of}, not a people file (CSV "
            f"text that fit-people writes); make one with `{fit}`, then give --people people.csv")


def _other_table_message(path: Path, header: Sequence[str]) -> str:
    """The line for a CSV with none of a people file's own columns (:data:`_PEOPLE_OWN_COLUMNS`):
    most likely a source of people (a real log, a habits table), which ``nudge fit-people`` makes a
    people file of."""
    shown = ", ".join(header[:6]) + (", ..." if len(header) > 6 else "")
    fit = shell_words(["nudge", "fit-people", str(path), "--out", "people.csv"])
    return (f"{path}: not a people file (its columns are {shown}; a people file has person, source, "
            "participant, the parameters and from_population); if it is a real log or a habits table, make "
            f"a people file of its participants with `{fit}`, then give --people people.csv")


def read_people(path: str | Path) -> People:
    """The people file at ``path``.

    Raises
    ------
    DataError
        A missing or unreadable file, no people, an unknown or missing column, or a bad cell (naming
        the file, the person and the field).
    """
    path = Path(path)
    if path.is_dir():
        raise DataError(_folder_message(path))
    if not path.is_file():
        raise DataError(f"{path}: no such people file; make one with `nudge fit-people SOURCE... --out "
                        f"{path.name}`")
    if starts_as_parquet(path):  # a run's table, never a people file: the people file is made of the run
        raise DataError(_parquet_message(path))
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(not_utf8_message(path)) from None
    # a spreadsheet in a locale with a decimal comma saves it with semicolons between the columns
    delimiter = header_delimiter(text.partition("\n")[0], set(REQUIRED_COLUMNS).issubset)
    reader = csv.DictReader(io.StringIO(text), delimiter=delimiter)
    header = [name.strip() for name in (reader.fieldnames or [])]
    if not header:
        raise DataError(f"{path}: empty; a people file has the columns {', '.join(PEOPLE_COLUMNS)}")
    if not set(header) & _PEOPLE_OWN_COLUMNS:
        raise DataError(_other_table_message(path, header))
    for name in header:
        if name not in PEOPLE_COLUMNS:
            raise DataError(f"{path}: column {name!r} is not a people file's"
                            f"{did_you_mean(name, PEOPLE_COLUMNS)}; the columns are "
                            f"{', '.join(PEOPLE_COLUMNS)}")
    missing = [name for name in REQUIRED_COLUMNS if name not in header]
    if missing:
        raise DataError(f"{path}: no column {missing[0]!r}; a people file has the columns "
                        f"{', '.join(PEOPLE_COLUMNS)}")
    if len(set(header)) != len(header):
        raise DataError(f"{path}: a column is named twice ({', '.join(header)})")
    reader.fieldnames = header
    present = [name for name in TWIN_PARAMETERS if name in header]
    twins = []
    for position, row in enumerate(reader):
        if None in row or any(value is None for value in row.values()):
            more = "more" if None in row else "fewer"
            raise DataError(f"{path}: person {position}: the row has {more} cells than the header's "
                            f"{len(header)}")
        twins.append(_row_twin(path, row, position, present))
    if not twins:
        raise DataError(f"{path}: holds no people (a header and no rows)")
    return People(name=path.name, sha256=hashlib.sha256(data).hexdigest(), twins=tuple(twins), data=data)



#: The manifest key of the people file a run or batch simulated.
MANIFEST_KEY = "people"


def people_of(people: People | str | Path | None) -> People | None:
    """``people`` as :class:`People`: read where it is a path (:func:`read_people`)."""
    if people is None or isinstance(people, People):
        return people
    return read_people(people)


def check_same_people(recorded: object, people: People | None, where: str | Path,
                      manifest: str | Path | None = None, key: str = MANIFEST_KEY) -> None:
    """Refuse to resume ``where`` with other people than it was simulated with.

    ``recorded`` is the manifest's :data:`MANIFEST_KEY` entry (None: the population's people), as
    read from ``manifest`` (``where``'s ``manifest.json`` unless given) under ``key``.

    Raises
    ------
    DataError
        The entry is damaged (not an object with the file's name and SHA-256: which people the
        folder holds is unknown); the people file's name or SHA-256 differs from the recorded one,
        or one of the two has none (a file of the same bytes under another name is named as such).
    """
    if recorded is not None and recorded != {} and not (
            isinstance(recorded, dict) and isinstance(recorded.get("file"), str)
            and isinstance(recorded.get("sha256"), str)):
        shown = json.dumps(recorded)
        shown = shown[:60] + "..." if len(shown) > 60 else shown
        raise DataError(f"{manifest or Path(where) / MANIFEST}: its {key!r} entry, the people file the "
                        f"folder was simulated with, is damaged ({shown}: not an object with the file's "
                        "name and sha256), so which people it holds is unknown: start again with --force, "
                        "or choose another --out")
    now = people.record() if people is not None else None
    if (recorded or None) == now:
        return

    if recorded and now and recorded.get("sha256") == now["sha256"]:  # the same people, named otherwise
        raise DataError(f"{where}: was simulated with --people {recorded.get('file')}; "
                        f"--people {now['file']} holds the same bytes (sha256 {now['sha256'][:12]}...), "
                        "only its name differs, and "
                        f"the folder records its people file by name (its copy is {PEOPLE_DIR}/"
                        f"{recorded.get('file')}): resume with --people {recorded.get('file')}")

    if recorded and now and recorded.get("file") == now["file"] and \
            _sha256_of(copy := copy_path(where, recorded)) == now["sha256"]:  # the folder's copy, edited
        kept = str(recorded.get("sha256"))[:12]
        raise DataError(f"{copy}: the copy {where} keeps of its people file changed since it was kept "
                        f"(sha256 {now['sha256'][:12]}..., the manifest's {kept}...), so it is not the "
                        f"people the folder was simulated with: resume with the file it was "
                        f"simulated with, --people {recorded.get('file')} (the resume puts the copy back), "
                        "or start again with --force")

    def said(record: dict[str, Any] | None) -> str:
        return "the population's people (no --people)" if record is None else \
            f"--people {record.get('file')} (sha256 {str(record.get('sha256'))[:12]}...)"
    raise DataError(f"{where}: was simulated with {said(recorded)}, not {said(now)}; resume with the same "
                    "people file, or start again with --force")


def copy_path(folder: str | Path, recorded: dict[str, Any]) -> Path:
    """Where ``folder`` keeps its copy of the people file its manifest records (``recorded``: the
    :data:`MANIFEST_KEY` entry): ``FOLDER/people/<the file's name>``, ``folder`` as given (a path
    that works from where it was typed)."""
    return Path(folder) / PEOPLE_DIR / Path(str(recorded.get("file"))).name


def resume_people(folder: str | Path, recorded: object, otherwise: str | None) -> str | None:
    """The ``--people`` a command that resumes ``folder`` names: the copy the folder keeps
    (:func:`copy_path`, by ``folder`` as given, so the command works from wherever the folder's
    path does) where it holds the bytes the manifest records, else ``otherwise`` (a copy not written
    yet, or edited since).

    The one rule of every resume command a run or batch folder is named in: the one printed for
    a damaged run and the Ctrl-C hints.

    Parameters
    ----------
    folder
        The run or batch folder, as the user gave it.
    recorded
        Its manifest's :data:`MANIFEST_KEY` entry, read from disk (anything; not a mapping: no
        people file recorded yet, and no copy to name).
    otherwise
        What to name where no copy is there yet (interrupted before it was written, or a folder
        of an older nudge): the ``--people`` as typed, or the recorded file's name.
    """
    if not isinstance(recorded, dict):
        return otherwise
    copy = copy_path(folder, recorded)
    # a copy edited since it was kept would be refused as other people: the file it was simulated with
    kept = recorded.get("sha256")
    return str(copy) if copy.is_file() and (not isinstance(kept, str) or _sha256_of(copy) == kept) \
        else otherwise


def _sha256_of(path: Path) -> str | None:
    """The SHA-256 of the file ``path`` (hex), ``None`` where it cannot be read (not there)."""
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def keep_copy(people: People | None, folder: str | Path) -> None:
    """Keep the people file's exact bytes in ``folder`` (:func:`copy_path`), written atomically, so
    that the folder's resume command names a file that is there and passes the people check.

    Nothing is written without people, for people made in memory (no file), or where the copy
    already holds these bytes (a resume given the copy itself as ``--people`` must not replace
    its own input); a copy with other bytes (edited since) is put back.
    """
    if people is None or not people.data:
        return
    target = copy_path(folder, people.record())
    if target.is_file() and target.read_bytes() == people.data:
        return
    from nudgecli.store import write_bytes_atomic  # the folders' writer; it imports the config

    write_bytes_atomic(target, people.data)


def remove_copy(folder: str | Path, recorded: object) -> None:
    """Remove the copy of the people file a replaced run or batch kept (``recorded``: its manifest's
    :data:`MANIFEST_KEY` entry, read from disk: anything), and ``people/`` where nothing else is left
    in it. Other files there stay: a folder that was not a run may keep the person's own files."""
    copy = copy_path(folder, recorded) if isinstance(recorded, dict) else None
    if copy is not None and copy.is_file():
        copy.unlink()
    with contextlib.suppress(OSError):
        (Path(folder) / PEOPLE_DIR).rmdir()

