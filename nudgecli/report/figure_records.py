"""What ``nudge plot`` wrote into a figures' folder, so that the next plot there leaves no stale figure.

A plot records the names of the files it wrote in :data:`~nudgecli.run_folder_names.FIGURES_RECORD`
beside them (JSON, written atomically). The next plot into that folder, once it has written all
its files, removes those of the record it did not write again (another ``--formats``, a plan or
source without Fig. 5, a table instead of a run): a researcher would otherwise read a figure of an
earlier plot as one of this one. Only recorded names are removed, only where they are still a
figure's file (:func:`nudgecli.run_folder_record.is_figure_file`, the rule by which ``simulate
--force`` removes a replaced run's figures), and only where the file's bytes are still those the
record's SHA-256 says the plot wrote: a file the person put there (or wrote over a figure), or one
a record edited by hand names, is never removed; nor is one a record of an older nudge, which
holds no SHA-256, names. Figures a plot cannot draw for want of their data, not for a choice
(Fig. 5 and the trajectory of a run whose step logs are not there), it keeps, recorded, saying so.

A plot writes every file to its temporary first and renames them all into place only once all
are written (:func:`~nudgecli.report.figures.output.save_figures`): a plot that fails or is
interrupted before then changes no figure and no record. Just before the renames the record is
widened to the files about to be renamed (with their SHA-256), so that a kill between two renames
(a few milliseconds) leaves every new file it did rename named for the next plot to remove.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from nudgecli.report.figures.output import figure_file
from nudgecli.run_folder_names import FIGURES_RECORD
from nudgecli.run_folder_record import file_sha256, is_figure_file
from nudgecli.store import remove_temporaries, write_json_atomic

#: The record's key of the file names (a list of names, no folders).
RECORD_KEY = "written"
#: The record's key of the SHA-256 of each file the plot wrote (name -> hex).
SUMS_KEY = "sha256"


def recorded_figures(folder: Path) -> tuple[list[str], str | None]:
    """The file names the record in ``folder`` holds, and why it could not be read (``None``: read
    or absent; an absent record holds no names).

    Parameters
    ----------
    folder
        A figures' folder.

    Returns
    -------
    tuple[list[str], str | None]
        The recorded names (no names where the record is unreadable), and the reason it is.
    """
    path = folder / FIGURES_RECORD
    if not path.is_file():
        return [], None
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return [], f"cannot be read ({exc})"
    names = record.get(RECORD_KEY) if isinstance(record, dict) else None
    if not isinstance(names, list) or not all(isinstance(name, str) for name in names):
        return [], f"holds no list of file names under {RECORD_KEY!r}"
    return names, None


def recorded_sums(folder: Path) -> dict[str, str]:
    """The SHA-256 the record in ``folder`` holds of the files the plot wrote (name -> hex; empty for
    a record without them: an older nudge's, or an unreadable one)."""
    try:
        sums = json.loads((folder / FIGURES_RECORD).read_text(encoding="utf-8")).get(SUMS_KEY)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, AttributeError):
        return {}
    return {str(k): str(v) for k, v in sums.items()} if isinstance(sums, dict) else {}


def _write_record(folder: Path, names: Sequence[str], sums: Mapping[str, str]) -> None:
    """Record ``names`` and, of those, the SHA-256 in ``sums`` (the files the plot wrote)."""
    kept = sorted(set(names))
    write_json_atomic(folder / FIGURES_RECORD, {RECORD_KEY: kept,
                                                SUMS_KEY: {n: sums[n] for n in kept if n in sums}})


def _sums_of(paths: Sequence[Path]) -> dict[str, str]:
    return {path.name: file_sha256(path) for path in paths if path.is_file()}


def _removable(folder: Path, name: str, sums: Mapping[str, str]) -> bool:
    """Whether a recorded ``name`` is a figure's file right in ``folder`` whose bytes are those the
    record says the plot wrote (a record edited to name ``../x.png``, a folder, or a file of the
    person's own removes nothing)."""
    return Path(name).name == name and name not in ("", ".", "..") and is_figure_file(folder / name) \
        and name in sums and file_sha256(folder / name) == sums[name]


def removed_line(folder: Path, removed: Sequence[Path]) -> str:
    """The line that names the earlier plot's figures removed from ``folder``."""
    return (f"removed {len(removed)} figure file(s) an earlier `nudge plot` wrote into {folder} and this "
            f"one did not draw: {', '.join(path.name for path in removed)}")


def replace_earlier_figures(folder: Path, stems: Sequence[str], formats: Sequence[str],
                            write: Callable[..., list[Path]],
                            log: Callable[[str], None] | None = None,
                            keep: tuple[Sequence[str], str] = ((), "")) -> list[Path]:
    """Write a plot's figures with ``write`` into ``folder``, then remove those of the earlier plot
    there that this one did not write, and record this plot's files.

    Parameters
    ----------
    folder
        The figures' folder (its lock held: the temporaries a killed plot left are removed first).
    stems, formats
        The figures ``write`` writes (``stem -> <stem>.<fmt>`` for each format).
    write
        Writes the figures, every file to its temporary first, and calls its ``before_rename``
        with the files' SHA-256 (name -> hex) before renaming them all into place
        (:func:`~nudgecli.report.figures.output.save_figures`); returns the files written. The
        record then names them, so that a kill between the renames leaves each renamed file
        named for the next plot to remove; a failure before changes neither figure nor record.
    log
        Receives :func:`removed_line` where earlier figures were removed, a line where the earlier
        record could not be read (then nothing is removed), and one naming the figures ``keep``
        spared.
    keep
        Stems of earlier figures this plot cannot draw and leaves in place, still recorded, and
        why (a run whose step logs are not there: the Fig. 5 and trajectory drawn from them are
        still the run's own).

    Returns
    -------
    list[Path]
        ``write``'s files.
    """
    remove_temporaries((folder,))  # a killed plot's (the caller holds the folder's lock)
    earlier, unreadable = recorded_figures(folder)
    sums = recorded_sums(folder) if unreadable is None else {}
    if unreadable is not None and log is not None:
        log(f"{folder / FIGURES_RECORD} {unreadable}: no earlier figure is removed; it is written again")
    planned = [figure_file(folder, stem, fmt).name for stem in stems for fmt in formats]

    def before_rename(new_sums: dict[str, str]) -> None:
        _write_record(folder, [*earlier, *planned],
                      {**{n: d for n, d in sums.items() if n not in planned}, **new_sums})

    written = write(before_rename=before_rename)
    kept = {path.name for path in written}
    left = [name for name in sorted(set(earlier) - kept) if _removable(folder, name, sums)]
    spared = [name for name in left if Path(name).stem in keep[0]]
    removed = [folder / name for name in left if name not in spared]
    for path in removed:
        path.unlink()
    _write_record(folder, sorted(kept | set(spared)), {**{n: sums[n] for n in spared}, **_sums_of(written)})
    if removed and log is not None:
        log(removed_line(folder, removed))
    if spared and log is not None:
        log(f"kept {len(spared)} figure file(s) an earlier `nudge plot` wrote into {folder}: "
            f"{', '.join(spared)}; this one cannot draw them: {keep[1]}")
    return written


__all__ = ["RECORD_KEY", "recorded_figures", "removed_line", "replace_earlier_figures"]
