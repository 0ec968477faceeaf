"""NASA-TLX and Likert scores from a questionnaire table.

Table format (CSV, one row per questionnaire response, e.g. one per participant and block):

=========================== =============================================================
column                      content
=========================== =============================================================
``participant``             participant id (required)
``condition``               the condition the response is about (required)
``block``                   the block after which it was answered (optional)
``tlx_mental``,             the six NASA-TLX subscale ratings, 0..100 (all six or none):
``tlx_physical``,           mental, physical, temporal, performance, effort, frustration
``tlx_temporal``,
``tlx_performance``,
``tlx_effort``,
``tlx_frustration``
``tlx_pair_1`` ..           optional: the 15 pairwise comparisons, each naming the winning
``tlx_pair_15``             subscale (``mental``, ``physical``, ... ; case-insensitive)
``tlx_weight_<subscale>``   optional, instead of the pairs: the number of comparisons each
                            subscale won (integers 0..5 summing to 15)
``likert_<item>``           optional Likert items, integers 1..7 (1 strongly disagree,
                            7 strongly agree)
=========================== =============================================================

An empty cell is a missing answer: that score is missing for that response; an empty
``participant`` or ``condition`` is refused, naming the row, as in a metrics table. The six ratings, the
15 pairs and the six weights are each answered all or none in a row: a row that leaves some of
them empty is refused, naming the row and the empty columns (one blank rating would otherwise
lose the response's TLX scores unseen). Each participant
answers once per condition (with a ``block`` column: once per condition and block): a second row
for the same participant and condition (and block), repeated or conflicting, is refused, naming
both rows. Column names are matched in any case (``Participant``, ``TLX_Mental``, ``Likert_Q3``, as
survey exports and spreadsheets capitalise them) and the scores are named in lower case
(``likert_q3``); a column named twice, in one case or two, is refused, naming both. A column
named ``tlx_*`` that is none of the above is refused with the nearest name: a misspelt subscale
would otherwise be left out of the scores unseen; so is a column close to a name read (``likrt_Q3``:
did you mean ``likert_Q3``?); any other (``Timestamp``, ``notes``) is not read, a ``Note:`` names it. A
respondent who is not a participant of the analysed run is refused by :func:`check_respondents`.
Participant and block labels follow the tables' one rule (:mod:`nudgecli.report.tables`): kept
as written, and matched as written, so ``07`` answers for participant ``07`` and never for ``7``.
Scores:

- ``tlx_raw``: the mean of the six subscale ratings (the paper's "raw TLX");
- ``tlx_weighted``: ``sum(rating * wins) / 15`` (only with pairs or weights);
- ``likert_<item>``: the item's rating.

The scores get the same statistics as the trial metrics (:mod:`nudgecli.report.stats`), with
responses in place of trials. ``nudge analyze`` writes them as ``questionnaire_scores.csv``
(:func:`scores_csv`) and records the file's SHA-256 in ``stats.json`` (:func:`scores_checksum`),
as it records the metrics' (:mod:`nudgecli.report.checksum`); ``nudge plot`` draws only scores
that match the record (:func:`read_analysed_scores`): a scores file left by an earlier analysis
with questionnaires, or edited by hand, is refused, never drawn beside statistics it is not of.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from nudgecli.csv_text import not_utf8_message
from nudgecli.errors import DataError, did_you_mean
from nudgecli.report.tables import (
    check_unique_columns,
    is_canonical_integer,
    label_text,
    read_csv_labels,
    refuse_empty_cells,
)
from nudgecli.run_folder_live import LIVE_EXECUTOR
from nudgecli.run_folder_names import QUESTIONNAIRE_SCORES_CSV, QUESTIONNAIRES_CSV

TLX_SUBSCALES = ("mental", "physical", "temporal", "performance", "effort", "frustration")
TLX_RATING_COLUMNS = tuple(f"tlx_{s}" for s in TLX_SUBSCALES)
TLX_PAIR_COLUMNS = tuple(f"tlx_pair_{i}" for i in range(1, 16))
TLX_WEIGHT_COLUMNS = tuple(f"tlx_weight_{s}" for s in TLX_SUBSCALES)
TLX_PREFIX = "tlx_"
TLX_COLUMNS = (*TLX_RATING_COLUMNS, *TLX_PAIR_COLUMNS, *TLX_WEIGHT_COLUMNS)
TLX_COMPARISONS = 15
LIKERT_PREFIX = "likert_"
LIKERT_RANGE = (1, 7)
TLX_RANGE = (0.0, 100.0)
#: The response's id columns: ``participant`` and ``condition`` required, ``block`` optional.
ID_COLUMNS = ("participant", "condition", "block")
#: ``stats.json``'s record of the scores file its analysis wrote (:func:`scores_checksum`).
SCORES_CHECKSUM_KEY = "questionnaire_scores_checksum"
SCORES_ALGORITHM = "sha256"


def read_questionnaires(path: str | Path) -> pd.DataFrame:
    """Read a questionnaire CSV (see the module docstring) without interpreting it; ``participant``
    and ``block`` labels as written (:func:`~nudgecli.report.tables.read_csv_labels`).

    Raises
    ------
    DataError
        The file is missing, empty or not CSV, or names a column twice.
    """
    path = Path(path)
    if not path.is_file():
        what = "is a folder, not a file" if path.is_dir() else "does not exist"
        raise DataError(f"questionnaire file {path} {what}; give a CSV file with participant, "
                        "condition and tlx_*/likert_* columns")
    try:
        # the header as written: pandas names a repeated column `likert_q3.1`, scored as an item of its own
        header = pd.read_csv(path, header=None, nrows=1, dtype=str, keep_default_na=False).iloc[0]
        check_unique_columns(header.tolist(), path)
        table = read_csv_labels(path)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; it needs a header row and one row per response") from None
    except UnicodeDecodeError:
        raise DataError(not_utf8_message(path)) from None
    except pd.errors.ParserError as exc:
        raise DataError(f"{path} is not a readable CSV file: {exc}") from None
    return table


def read_run_questionnaires(path: str | Path, source: Path, trials: pd.DataFrame,
                            manifest: Mapping[str, Any] | None) -> pd.DataFrame:
    """:func:`read_questionnaires` for the analysis of ``source`` with the trials table ``trials``:
    a live folder's answers file that is not there yet is named as such (``manifest``: the run's,
    as the analysis read it, ``None`` for a source that is no run folder; a live folder's names the
    executor ``live``: given always, so that a live study is never taken for another source), and,
    ``source`` being a run folder, each row's condition is checked against the run's
    (:func:`check_run_conditions`).

    Raises
    ------
    DataError
        As :func:`read_questionnaires`, or a row's condition contradicts the run's.
    """
    path = Path(path)
    live = manifest is not None and manifest.get("executor") == LIVE_EXECUTOR
    if not path.exists() and source.is_dir() and live and \
            path.resolve() == (source / QUESTIONNAIRES_CSV).resolve():
        raise DataError(f"questionnaire file {path} does not exist: no questionnaire of the live study in "
                        f"{source} has been answered yet (nudge study writes it when a participant answers "
                        "after their first block); analyse without --questionnaires until then")
    table = read_questionnaires(path)
    if source.is_dir():
        check_run_conditions(table, trials, str(path), str(source))
    return table


def check_run_conditions(table: pd.DataFrame, trials: pd.DataFrame, source: str, run: str) -> None:
    """Refuse a response whose participant and block are the run's, but whose condition is not the
    one the run's trials table gives that block (it would be counted under the wrong condition).
    Labels are matched as the tables read them (:func:`~nudgecli.report.tables.label_text`); a table
    without a ``block`` column, and rows of blocks the run does not hold, are left to the other checks.

    Raises
    ------
    DataError
        Naming the file, the row, both conditions and the fix.
    """
    table = _lower_case_names(table, source)
    _check_ids_given(table, source)  # before conditions are compared: an empty one is no condition
    if not {"participant", "condition", "block"} <= set(table.columns) or \
            not {"participant", "condition", "block"} <= set(trials.columns):
        return
    pairs = trials[["participant", "block"]].drop_duplicates().index
    run_condition = {(label_text(trials.at[i, "participant"]), label_text(trials.at[i, "block"])):
                     str(trials.at[i, "condition"]) for i in pairs}
    for row, (participant, block, condition) in enumerate(
            zip(table["participant"], table["block"], table["condition"], strict=True)):
        expected = run_condition.get((label_text(participant), label_text(block)))
        if expected is not None and str(condition) != expected:
            raise DataError(
                f"{source}: row {row + 2} gives participant {participant}'s block {block} the condition "
                f"{condition}, but in {run} that block's trials are of condition {expected}; write "
                f"{expected} in the row's condition (or correct its participant or block)")


def _check_ids_given(table: pd.DataFrame, source: str) -> None:
    """Refuse a response whose participant or condition is empty, as a trial's is
    (:func:`~nudgecli.report.tables.refuse_empty_cells`): an empty condition broke the comparison
    of the conditions with a traceback, an empty participant was named a stranger ``'nan'``."""
    for column in ID_COLUMNS[:2]:
        if column in table.columns:
            refuse_empty_cells(table, column, source)


def _numeric_column(table: pd.DataFrame, column: str, source: str) -> pd.Series:
    values = pd.to_numeric(table[column], errors="coerce")
    bad = table[column].notna() & values.isna()
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(f"{source}: column {column!r} must be numeric; row {row + 2} holds "
                        f"{table[column].iloc[row]!r} (write a number or leave the cell empty)")
    return values.astype(float)


def _check_range(values: pd.Series, column: str, low: float, high: float, source: str,
                 integer: bool = False) -> None:
    outside = values.notna() & ((values < low) | (values > high))
    if integer:
        outside |= values.notna() & (values != np.round(values))
    if outside.any():
        row = int(np.flatnonzero(outside.to_numpy())[0])
        kind = "integers" if integer else "values"
        raise DataError(f"{source}: column {column!r} must hold {kind} from {low:g} to {high:g}; row "
                        f"{row + 2} holds {_plain(values.iloc[row])}")


def _plain(value: float) -> str:
    """A cell's number as a person writes it: ``150``, ``2.5`` (not ``np.float64(150.0)``)."""
    number = float(value)
    return str(int(number)) if number.is_integer() else repr(number)


def _lower_case_names(table: pd.DataFrame, source: str) -> pd.DataFrame:
    """``table`` with its id, ``tlx_*`` and ``likert_*`` columns named in lower case, the one
    spelling the rest of this module matches (other columns are left as they are).

    Raises
    ------
    DataError
        Two of those columns whose names differ only in case (``tlx_mental`` and ``TLX_Mental``):
        which one holds the answers cannot be told.
    """
    written_as: dict[str, str] = {}
    for column in table.columns:
        name = str(column)
        lower = name.lower()
        if lower not in ID_COLUMNS and not lower.startswith((TLX_PREFIX, LIKERT_PREFIX)):
            continue
        if lower in written_as:
            raise DataError(f"{source}: columns {written_as[lower]!r} and {name!r} differ only in case, "
                            "and column names are matched in any case; keep one of the two")
        written_as[lower] = name
    return table.rename(columns={name: lower for lower, name in written_as.items() if name != lower})


def _check_tlx_names(table: pd.DataFrame, source: str) -> None:
    """Refuse a ``tlx_*`` column (in any case) that is not one of :data:`TLX_COLUMNS`, with the
    nearest name: a misspelt ``tlx_mentl`` beside the six ratings would be dropped unseen. Names
    as written (before :func:`_lower_case_names`), so that the message quotes the file."""
    unknown = [str(c) for c in table.columns
               if str(c).lower().startswith(TLX_PREFIX) and str(c).lower() not in TLX_COLUMNS]
    if unknown:
        hint = did_you_mean(unknown[0].lower(), TLX_COLUMNS)
        raise DataError(f"{source}: unknown NASA-TLX column {unknown[0]!r}{hint}; "
                        f"rename it or remove it (the TLX columns are {', '.join(TLX_RATING_COLUMNS)}, "
                        "tlx_pair_1..tlx_pair_15 or tlx_weight_<subscale>)")


def _check_other_names(table: pd.DataFrame, source: str) -> list[str]:
    """Refuse a column (any case) that is no id, ``tlx_*`` or ``likert_*`` column but close to one (a
    misspelt ``likrt_Q3`` would be dropped unseen), with the nearest name as written; the columns close
    to none (``Timestamp``, ``notes``: a survey export's), not read, are returned for a note."""
    unread = []
    for column in (str(c) for c in table.columns):
        if column.lower() in ID_COLUMNS or column.lower().startswith((TLX_PREFIX, LIKERT_PREFIX)):
            continue
        head, underscore, item = column.partition("_")
        prefix = did_you_mean(f"{head.lower()}_", (TLX_PREFIX, LIKERT_PREFIX)) if underscore else ""
        meant = next((p for p in (TLX_PREFIX, LIKERT_PREFIX) if repr(p) in prefix), None)
        hint = f" (did you mean {meant + item!r}?)" if meant else did_you_mean(column.lower(), ID_COLUMNS)
        if not hint:
            unread.append(column)
            continue
        raise DataError(f"{source}: unknown column {column!r}{hint}; rename it or remove it (a "
                        "questionnaire's columns are participant, condition, block, tlx_* and likert_<item>)")
    return unread


def _pair_wins(table: pd.DataFrame, source: str) -> np.ndarray:
    """``(rows, 6)`` wins per subscale from the 15 ``tlx_pair_*`` columns (NaN where unanswered)."""
    wins = np.zeros((len(table), len(TLX_SUBSCALES)))
    unanswered = np.zeros(len(table), dtype=bool)
    for column in TLX_PAIR_COLUMNS:
        raw = table[column]
        names = raw.astype("string").str.strip().str.lower()
        names = names.str.removesuffix(" demand").str.removesuffix("_demand")
        missing = raw.isna().to_numpy() | (names == "").fillna(True).to_numpy()
        valid = names.isin(TLX_SUBSCALES).fillna(False).to_numpy()
        bad = ~missing & ~valid
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise DataError(f"{source}: column {column!r} row {row + 2} holds {raw.iloc[row]!r}; name "
                            f"the winning subscale: {', '.join(TLX_SUBSCALES)}")
        unanswered |= missing
        for index, subscale in enumerate(TLX_SUBSCALES):
            wins[:, index] += (names == subscale).fillna(False).to_numpy()
    wins[unanswered] = np.nan
    return wins


def _tlx_parts(table: pd.DataFrame, source: str) -> tuple[bool, bool, bool]:
    """Whether ``table`` (its names in lower case) holds the TLX ratings, pairs and weights, each
    a complete set of columns answered all or none in each row (:func:`_check_all_or_none`).

    Raises
    ------
    DataError
        An incomplete set of columns, pairs beside weights, weights without the ratings, or a row
        that answers part of a set.
    """
    rating_present = [c for c in TLX_RATING_COLUMNS if c in table.columns]
    if rating_present and len(rating_present) < len(TLX_RATING_COLUMNS):
        missing = [c for c in TLX_RATING_COLUMNS if c not in table.columns]
        raise DataError(f"{source}: NASA-TLX needs all six subscales; missing column(s) {', '.join(missing)}")
    pair_present = [c for c in TLX_PAIR_COLUMNS if c in table.columns]
    weight_present = [c for c in TLX_WEIGHT_COLUMNS if c in table.columns]
    if pair_present and weight_present:
        raise DataError(f"{source} has both tlx_pair_* and tlx_weight_* columns; keep one of the two")
    for present, expected, kind in ((pair_present, TLX_PAIR_COLUMNS, "pairwise comparison"),
                                    (weight_present, TLX_WEIGHT_COLUMNS, "weight")):
        if present and len(present) < len(expected):
            missing = [c for c in expected if c not in table.columns]
            raise DataError(f"{source}: incomplete TLX {kind} columns; missing {', '.join(missing)}")
    if (pair_present or weight_present) and not rating_present:
        raise DataError(f"{source}: TLX weights without the ratings; add the columns "
                        f"{', '.join(TLX_RATING_COLUMNS)}")
    for present, columns, what in ((rating_present, TLX_RATING_COLUMNS, "the six NASA-TLX ratings"),
                                   (pair_present, TLX_PAIR_COLUMNS, "the 15 TLX pairwise comparisons"),
                                   (weight_present, TLX_WEIGHT_COLUMNS, "the six TLX weights")):
        if present:
            _check_all_or_none(table, columns, what, source)
    return bool(rating_present), bool(pair_present), bool(weight_present)


def _check_all_or_none(table: pd.DataFrame, columns: tuple[str, ...], what: str, source: str) -> None:
    """Refuse a row that answers some of ``columns`` but not all: ``tlx_raw`` and ``tlx_weighted``
    need every rating and every comparison, and a score left out for one blank cell would shrink
    the condition's n unseen. A row that answers none of them is a respondent who skipped that part
    (its score is missing, as documented).

    Raises
    ------
    DataError
        Naming the file, the first such row, its blank columns and the fix.
    """
    blank = np.column_stack([_blank_cells(table[column]) for column in columns])
    partial = blank.any(axis=1) & ~blank.all(axis=1)
    if partial.any():
        row = int(np.flatnonzero(partial)[0])
        missing = [column for column, empty in zip(columns, blank[row], strict=True) if empty]
        raise DataError(f"{source}: row {row + 2} answers {len(columns) - len(missing)} of {what} but leaves "
                        f"{', '.join(missing)} empty; a TLX score needs all of them: fill in the empty "
                        "cell(s), or leave all of them empty for a respondent who did not answer that part")


def _blank_cells(column: pd.Series) -> np.ndarray:
    """Whether each cell of ``column`` is unanswered: empty, missing or only spaces."""
    text = column.astype("string").str.strip()
    return (column.isna().to_numpy() | (text == "").fillna(True).to_numpy())


def _weight_wins(table: pd.DataFrame, source: str) -> np.ndarray:
    """``(rows, 6)`` wins per subscale from the ``tlx_weight_*`` columns."""
    wins = np.column_stack([_numeric_column(table, c, source).to_numpy() for c in TLX_WEIGHT_COLUMNS])
    for index, column in enumerate(TLX_WEIGHT_COLUMNS):
        _check_range(pd.Series(wins[:, index]), column, 0, 5, source, integer=True)
    totals = wins.sum(axis=1)
    bad = np.isfinite(totals) & (totals != TLX_COMPARISONS)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise DataError(f"{source}: the tlx_weight_* columns of row {row + 2} sum to {totals[row]:g}; "
                        f"the six weights are pairwise wins and must sum to {TLX_COMPARISONS}")
    return wins


def questionnaire_scores(table: pd.DataFrame, source: str = "questionnaire table",
                         notes: list[str] | None = None) -> pd.DataFrame:
    """Validate a questionnaire table and compute its scores.

    Parameters
    ----------
    table
        The table as read (see the module docstring for its columns).
    source
        Its name (file path) for error messages.
    notes
        Gets a note naming the columns not read (:func:`_check_other_names`), where there are any.

    Returns
    -------
    pd.DataFrame
        One row per response: ``participant, condition`` (and ``block`` if given), then
        ``tlx_raw`` and ``tlx_weighted`` (when TLX data are present) and each ``likert_*`` item.

    Raises
    ------
    DataError
        Missing id columns, an incomplete set of TLX subscales, pairs or weights, a value that
        is not numeric or out of range, an unknown subscale name, weights not summing to 15,
        no score column at all, an unknown ``tlx_*`` column, or two rows of one participant and
        condition (and block, with a ``block`` column).
    """
    if table.empty:
        raise DataError(f"{source} has no rows; it needs one row per questionnaire response")
    _check_tlx_names(table, source)
    if (unread := _check_other_names(table, source)) and notes is not None:
        notes.append(f"{source}: not read: {', '.join(unread)} (no id, tlx_* or likert_* column)")
    table = _lower_case_names(table, source)
    for column in ID_COLUMNS[:2]:
        if column not in table.columns:
            raise DataError(f"{source} has no {column!r} column; add it (one value per response row)")
    _check_ids_given(table, source)
    ids = [c for c in ID_COLUMNS if c in table.columns]
    scores = table[ids].copy()
    scores["condition"] = scores["condition"].astype(str)

    rating_present, pair_present, weight_present = _tlx_parts(table, source)
    if rating_present:
        ratings = np.column_stack([_numeric_column(table, c, source).to_numpy() for c in TLX_RATING_COLUMNS])
        for index, column in enumerate(TLX_RATING_COLUMNS):
            _check_range(pd.Series(ratings[:, index]), column, *TLX_RANGE, source)
        scores["tlx_raw"] = ratings.mean(axis=1)
        if pair_present or weight_present:
            wins = _pair_wins(table, source) if pair_present else _weight_wins(table, source)
            too_many = np.nan_to_num(wins) > len(TLX_SUBSCALES) - 1
            if too_many.any():
                row, subscale = (int(i[0]) for i in np.nonzero(too_many))
                raise DataError(f"{source}: row {row + 2}: {TLX_SUBSCALES[subscale]!r} wins "
                                f"{wins[row, subscale]:g} of the 15 pairwise comparisons, but each subscale "
                                f"is in only 5 pairs; check the tlx_pair_* columns")
            scores["tlx_weighted"] = (ratings * wins).sum(axis=1) / TLX_COMPARISONS
            scores.loc[np.isnan(wins).any(axis=1) | np.isnan(ratings).any(axis=1), "tlx_weighted"] = np.nan

    likert_columns = [c for c in table.columns if str(c).startswith(LIKERT_PREFIX)]
    for column in likert_columns:
        values = _numeric_column(table, column, source)
        _check_range(values, column, *LIKERT_RANGE, source, integer=True)
        scores[column] = values
    if not rating_present and not likert_columns:
        raise DataError(f"{source} holds no scores; add the six columns {', '.join(TLX_RATING_COLUMNS)} "
                        f"and/or Likert items named {LIKERT_PREFIX}<item>")
    # a valid table otherwise: now, one response per participant and condition (and block)
    _check_one_response_each(table, ids, source)
    return scores.reset_index(drop=True)


def _check_one_response_each(table: pd.DataFrame, ids: list[str], source: str) -> None:
    """Refuse two rows of one participant and condition, and of one block if ``ids`` holds
    ``block`` (a repeated or conflicting response: counted twice it would be two people's)."""
    # labels as the tables read them (two spellings are two people), conditions as written
    keys = pd.DataFrame({column: table[column].map(label_text) for column in ids})
    repeated = keys.duplicated(keep=False)
    if not repeated.any():
        return
    first = int(np.flatnonzero(repeated.to_numpy())[0])
    same = keys.eq(keys.iloc[first]).all(axis=1).to_numpy()
    rows = np.flatnonzero(same)[:2]
    a, b = (table.iloc[int(r)] for r in rows)
    answers = [c for c in table.columns if c not in ids]
    alike = all((pd.isna(a[c]) and pd.isna(b[c])) or str(a[c]) == str(b[c]) for c in answers)
    what = ("the same answers twice (a repeated response)" if alike
            else "different answers (conflicting responses)")
    if "block" in ids:
        block, fix = f", block {a['block']}", "keep one row per participant, condition and block"
    else:
        block, fix = "", ("keep one row per participant and condition, or add a block column if they "
                          "answered after different blocks")
    raise DataError(
        f"{source}: rows {rows[0] + 2} and {rows[1] + 2} are both participant {a['participant']}'s response "
        f"for condition {a['condition']}{block}, with {what}; {fix}"
    )


def check_respondents(scores: pd.DataFrame, participants: pd.Series, source: str, run: str) -> None:
    """Refuse responses of people who are not participants of the analysed run, naming them.

    A respondent is the participant whose label is the same label: both are compared as the
    tables read them (:func:`~nudgecli.report.tables.label_text`), so ``7`` answers for
    participant ``7`` of a run or of a table of canonical integers, and ``07`` only for a
    participant written ``07``. ``07``, ``7.0`` and ``7`` are never taken for one another (a table
    may hold ``07`` and ``7`` as two people): a respondent whose label is another spelling of a
    participant's is refused like any stranger, and the message shows how the run writes it.

    Parameters
    ----------
    scores
        The table of :func:`questionnaire_scores`.
    participants
        The run's ``participant`` column (any length; its distinct values count).
    source, run
        The questionnaire file and the run or table, for the message.

    Raises
    ------
    DataError
        A respondent is not among ``participants``.
    """
    known = {label_text(p) for p in pd.unique(participants)}
    strangers = sorted({label_text(p) for p in pd.unique(scores["participant"])} - known,
                       key=lambda k: (len(k), k))
    if not strangers:
        return
    more = f" and {len(strangers) - 10} more" if len(strangers) > 10 else ""
    shown = ", ".join(_shown(label) for label in strangers[:10]) + more
    raise DataError(f"{source}: respondent(s) {shown} are not participants of {run}"
                    f"{_other_spellings(strangers, known, run)}; remove their rows, or analyse the run they "
                    "belong to")


def _shown(label: str) -> str:
    """A label for a message: a canonical integer bare, any other text quoted (``'07'``, ``' 7'``)."""
    return label if is_canonical_integer(label) else repr(label)


def _other_spellings(strangers: list[str], known: set[str], run: str) -> str:
    """`` (labels are matched exactly as written: RUN writes 7, not '07')``: the strangers that spell a
    participant's number another way, which is the likely mistake; empty if none does."""
    def number(label: str) -> float | None:
        try:
            return float(label)
        except ValueError:
            return None

    by_number: dict[float, str] = {}
    for label in sorted(known):
        if (value := number(label)) is not None:
            by_number.setdefault(value, label)
    pairs = [(label, by_number[value]) for label in strangers
             if (value := number(label)) is not None and value in by_number]
    if not pairs:
        return ""
    listed = "; ".join(f"{_shown(written)}, not {_shown(label)}" for label, written in pairs[:3])
    return f" (labels are matched exactly as written: {run} writes {listed})"


def score_columns(scores: pd.DataFrame) -> list[str]:
    """The score columns of :func:`questionnaire_scores`' result (everything but the ids)."""
    return [c for c in scores.columns if c not in ("participant", "condition", "block")]


def scores_csv(scores: pd.DataFrame) -> str:
    """The text of ``questionnaire_scores.csv``: the one spelling that is written and checksummed.

    Parameters
    ----------
    scores
        The table of :func:`questionnaire_scores`, one row per response.
    """
    return scores.to_csv(index=False)


def scores_checksum(scores: pd.DataFrame) -> dict[str, Any]:
    """``stats.json``'s record of the scores file an analysis writes: ``algorithm``, ``rows`` and
    the hex ``digest`` of the file's bytes (:func:`scores_csv` as UTF-8).

    Parameters
    ----------
    scores
        The table of :func:`questionnaire_scores` that the analysis writes.
    """
    data = scores_csv(scores).encode("utf-8")
    return {"algorithm": SCORES_ALGORITHM, "rows": len(scores),
            "digest": hashlib.new(SCORES_ALGORITHM, data).hexdigest()}


def read_analysed_scores(folder: str | Path, stats: Mapping[str, Any], where: str) -> pd.DataFrame | None:
    """The questionnaire scores of the analysis in ``folder``: its ``questionnaire_scores.csv``,
    read only if its bytes are those ``stats.json`` records (:func:`scores_checksum`).

    Parameters
    ----------
    folder
        The analysis folder (a run folder, ``<table>-analysis/``, an ``--out``).
    stats
        Its ``stats.json`` document.
    where
        The ``stats.json`` path, for the messages.

    Returns
    -------
    pd.DataFrame or None
        The scores, labels as written; ``None`` when the analysis has none and there is no file.

    Raises
    ------
    DataError
        A scores file that the analysis did not write (it records none: analysed without
        questionnaires, or by an older nudge), a file whose bytes differ from the record (edited,
        or of another analysis), a recorded file that is gone, or a malformed record.
    """
    path = Path(folder) / QUESTIONNAIRE_SCORES_CSV
    record = stats.get(SCORES_CHECKSUM_KEY)
    again = "run `nudge analyze` on the source with --questionnaires ANSWERS.csv again"
    if record is None:
        if not path.is_file():
            return None
        raise DataError(f"{path} is not from the analysis in {where}, which records no questionnaire scores "
                        f"(analysed without --questionnaires, or by an older nudge); {again} to plot them, "
                        f"or delete {path}")
    if not (isinstance(record, Mapping) and record.get("algorithm") == SCORES_ALGORITHM
            and isinstance(record.get("digest"), str)):
        raise DataError(f"{where}: its `{SCORES_CHECKSUM_KEY}` is malformed; {again}")
    if not path.is_file():
        raise DataError(f"{where} records questionnaire scores, but {path} is gone; {again}")
    if hashlib.new(SCORES_ALGORITHM, path.read_bytes()).hexdigest() != record["digest"]:
        raise DataError(f"{path} does not match {where}: the scores were edited, or written by another "
                        f"analysis; {again} before plotting")
    return read_csv_labels(path)
