"""The Python types of the API's arguments, refused as :class:`~nudgecli.errors.ConfigError`.

On the command line argparse turns each option's text into its type; a notebook passes Python
objects, so the functions of :mod:`nudgecli.api` check each argument's type here before any
work, and a wrong one (``participants="2"``, ``seed=1.5``, a number for a path) is one ``Error:``
line naming the argument as it is written in Python (``participants=``) and what to give instead.
This module owns that wording; the ranges (``participants`` at least 1, ...) stay with the rules
that own them, whose messages are the command line's (docs/api.md).
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal, overload

from nudgecli.errors import ConfigError


def _refuse(name: str, value: object, wanted: str, got: str | None = None) -> ConfigError:
    """The error of argument ``name`` given ``value`` where ``wanted`` (``"a whole number"``) is needed;
    ``got`` says what was given instead (its type's name when absent)."""
    return ConfigError(f"{name}={_shown(value)}: {name}= takes {wanted}, not {got or type(value).__name__}")


def _shown(value: object) -> str:
    """``repr(value)``, or for one of many lines or characters (a DataFrame, an array) its type and
    shape: the error stays one line."""
    text = repr(value)
    if "\n" not in text and len(text) <= 80:
        return text
    shape = getattr(value, "shape", None)
    return f"<{type(value).__name__}{'' if shape is None else f' of shape {tuple(shape)}'}>"


@overload
def whole_number(name: str, value: object, *, optional: Literal[False] = False,
                 minimum: int | None = None) -> int: ...
@overload
def whole_number(name: str, value: object, *, optional: bool, minimum: int | None = None) -> int | None: ...
def whole_number(name: str, value: object, *, optional: bool = False,
                 minimum: int | None = None) -> int | None:
    """``value`` as an ``int`` (a Python or NumPy integer; never a bool, a float or a text).

    ``minimum`` is for the ranges the command line's option type holds (``click.IntRange``), which
    no other rule checks again; a range a rule of the work owns is that rule's to refuse.

    Raises
    ------
    ConfigError
        Anything else (``None`` too, unless ``optional``), or below ``minimum``.
    """
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise _refuse(name, value, "a whole number (an int)" + (" or None" if optional else ""))
    if minimum is not None and value < minimum:
        raise _refuse(name, value, f"a whole number of at least {minimum}", got=repr(value))
    return int(value)


@overload
def seed(value: object, *, optional: Literal[False] = False) -> int: ...
@overload
def seed(value: object, *, optional: bool) -> int | None: ...
def seed(value: object, *, optional: bool = False) -> int | None:
    """``value`` as a master seed: a whole number (:func:`whole_number`) that the seed's rule,
    :func:`nudgecli.rng.check_seed`, takes, refused in the words of every command's ``--seed``.

    Raises
    ------
    ConfigError
        Not a whole number (``None`` too, unless ``optional``), or negative.
    """
    from nudgecli.rng import check_seed  # numpy's import, only where a seed is given

    number = whole_number("seed", value, optional=optional)
    check_seed(number)
    return number


def whole_numbers(name: str, values: object) -> list[int]:
    """``values`` as a list of ``int``: a list, tuple or other sequence of whole numbers (Python or
    NumPy integers, e.g. ``[6, 9, 12]``), or a one-dimensional NumPy array of integers.

    Raises
    ------
    ConfigError
        Not a sequence (a text, a single number), an array of more dimensions or of no integer
        type, or an item that is no whole number (the message names the first such item).
    """
    wanted = "a list of whole numbers, e.g. [6, 9, 12]"
    dimensions = getattr(values, "ndim", None)  # a NumPy array (or a pandas Series)
    if isinstance(dimensions, int) and dimensions >= 1:
        kind = getattr(getattr(values, "dtype", None), "kind", None)
        if dimensions > 1:
            raise _refuse(name, values, wanted, got=f"an array of {dimensions} dimensions")
        if kind not in ("i", "u"):  # its items would all be refused: say why once
            raise _refuse(name, values, wanted, got=f"an array of {getattr(values, 'dtype', '?')}")
        values = list(values)  # type: ignore[call-overload]  # one dimension: its items
    if isinstance(values, str | bytes) or not isinstance(values, Sequence):
        raise _refuse(name, values, wanted)
    for index, value in enumerate(values):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise _refuse_item(name, values, wanted, index)
    return [int(value) for value in values]


def _refuse_item(name: str, values: Sequence[object], wanted: str, index: int) -> ConfigError:
    """The error of list argument ``name`` whose item ``index`` is not what ``wanted`` holds: it
    names that item and its type (``not a list whose item 1 is '3' (a str)``), not the list's type,
    which is right."""
    value = values[index]
    return _refuse(name, values, wanted, got=f"{_a(type(values).__name__)} whose item {index} is {value!r} "
                                             f"({_a(type(value).__name__)})")


def _a(noun: str) -> str:
    """``noun`` after its indefinite article: ``a list``, ``an int``."""
    return f"{'an' if noun[:1] in 'aeiou' else 'a'} {noun}"


def real_number(name: str, value: object, *, between: tuple[float, float] | None = None) -> float:
    """``value`` as a ``float`` (an int or a float; never a bool or a text), strictly inside
    ``between`` where given (the command line's ``click.FloatRange``; NaN is outside it).

    A NaN without ``between`` is the argument's own check's to refuse (with the wording the command
    line gives, as ``validate``'s ``--belief-concentration``): here it is of the right type.

    Raises
    ------
    ConfigError
        Anything else, or outside ``between``.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _refuse(name, value, "a number")
    number = float(value)
    if between is not None and not between[0] < number < between[1]:
        raise _refuse(name, value, f"a number between {between[0]} and {between[1]} (both excluded)")
    return number


def texts(name: str, values: object, *, optional: bool = False, empty: bool = True) -> list[str] | None:
    """``values`` as a list of ``str`` (a list or tuple of texts, e.g. ``["completion_time"]``).

    ``empty=False`` refuses an empty list where ``None`` means "all" (``metrics=``): ``[]`` would
    read as "none", and the work would do all.

    Raises
    ------
    ConfigError
        A single text or bytes (which would read as its letters), a number, an item that is no text
        (the message names the first such item), or an empty list where ``empty`` is false.
    """
    if values is None and optional:
        return None
    wanted = "a list of texts, e.g. ['a', 'b']" + (" or None" if optional else "")
    if isinstance(values, str | bytes) or not isinstance(values, Sequence):
        raise _refuse(name, values, wanted)
    for index, value in enumerate(values):
        if not isinstance(value, str):  # the list is right: name the item that is not
            raise _refuse_item(name, values, wanted, index)
    if not values and not empty:
        raise ConfigError(f"{name}={values!r}: an empty list names none; name at least one"
                          + (f", or leave {name}= out (None) for all" if optional else ""))
    return list(values)


def switch(name: str, value: object) -> bool:
    """``value``, which must be ``True`` or ``False`` (``force=``, ``confirm=``, ...).

    Raises
    ------
    ConfigError
        Anything else (a text such as ``"yes"`` is not read as true).
    """
    if not isinstance(value, bool):
        raise _refuse(name, value, "True or False")
    return value


@overload
def text(name: str, value: object, *, optional: Literal[False] = False) -> str: ...
@overload
def text(name: str, value: object, *, optional: bool) -> str | None: ...
def text(name: str, value: object, *, optional: bool = False) -> str | None:
    """``value``, which must be a ``str`` (or ``None`` where ``optional``).

    Raises
    ------
    ConfigError
        Anything else.
    """
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise _refuse(name, value, "a text (a str)" + (" or None" if optional else ""))
    return value


@overload
def path(name: str, value: object, *, optional: Literal[False] = False) -> str | Path: ...
@overload
def path(name: str, value: object, *, optional: bool) -> str | Path | None: ...
def path(name: str, value: object, *, optional: bool = False) -> str | Path | None:
    """``value``, which must be a path: a ``str`` or an ``os.PathLike`` (or ``None`` where ``optional``).

    Raises
    ------
    ConfigError
        Anything else, or an empty text (a path would make it the current folder, as ``--out ""``).
    """
    if value is None and optional:
        return None
    if isinstance(value, os.PathLike):
        return Path(value)
    if not isinstance(value, str):  # first: a DataFrame or an array has no truth value to compare with ""
        raise _refuse(name, value, "a path (a str or a pathlib.Path)" + (" or None" if optional else ""))
    if value == "":
        raise ConfigError(f"{name}='': an empty path; name the folder or file to "
                          + ("write" if name == "out" else "read")
                          + (f", or leave {name}= out (None) for the default" if optional else ""))
    return value


def source_path(name: str, value: object) -> str:
    """A source to read as its path's text: a :class:`~nudgecli.api.run.Run` (its folder), an
    :class:`~nudgecli.api.analysis.Analysis` (what it analysed) or a path (:func:`path`).

    Raises
    ------
    ConfigError
        Anything else (a DataFrame, an array, a number), or an empty text.
    """
    from nudgecli.api.analysis import Analysis
    from nudgecli.api.run import Run

    if isinstance(value, Run):
        return str(value.path)
    if isinstance(value, Analysis):
        return str(value.source)
    return str(path(name, value))


def plan(value: object, *, loaded: bool = True) -> Any:
    """``plan=`` of a run or a batch: ``None``, a preset's name or a plan file (a ``str`` or an
    ``os.PathLike``, :func:`path`) as its text, the label its errors name, or, where ``loaded``, a
    loaded :class:`~nudgecli.report.plans.AnalysisPlan`.

    Raises
    ------
    ConfigError
        Anything else, or an empty text.
    """
    if value is None:
        return None
    if loaded:
        from nudgecli.report.plans import AnalysisPlan

        if isinstance(value, AnalysisPlan):
            return value
    return str(path("plan", value))


def out_folder(value: object) -> str | Path | None:
    """``out=`` of a function that writes a folder: a path (:func:`path`) or ``None``, and not a file
    that exists (:func:`nudgecli.outputs.check_not_a_file`, the message of every command's ``--out``).

    Raises
    ------
    NudgeError
        No path, an empty one, or an existing file.
    """
    from nudgecli.outputs import check_not_a_file

    folder = path("out", value, optional=True)
    if folder is not None:
        check_not_a_file(folder)
    return folder


def formats(value: object) -> tuple[str, ...]:
    """``formats=`` as figure formats: one text ``"png,pdf"`` (``--formats``, checked by
    :func:`~nudgecli.report.plotting.parse_formats`) or a list of texts.

    Raises
    ------
    ConfigError
        Neither, or an unknown format in the text.
    """
    from nudgecli.report.plotting import parse_formats

    if isinstance(value, str):
        return parse_formats(value)
    return tuple(texts("formats", value) or ())


def axes(value: object) -> Any:
    """``ax=`` as one matplotlib ``Axes`` (``fig.add_subplot()``, one item of ``plt.subplots()``'s
    array) or ``None``: checked here, where matplotlib would fail deep in its drawing.

    Raises
    ------
    ConfigError
        Anything else: a text, a figure, or several axes (the array of ``plt.subplots(1, 2)``).
    """
    from matplotlib.axes import Axes

    if value is None or isinstance(value, Axes):
        return value
    wanted = "one matplotlib Axes (e.g. fig.add_subplot()) or None"
    if isinstance(value, str | bytes) or not hasattr(value, "__len__"):
        raise _refuse("ax", value, wanted)
    raise ConfigError(f"ax={type(value).__name__} of {len(value)}: ax= takes {wanted}, not several axes; "
                      "give one of them, e.g. ax=axes[0]")


def trial(value: object) -> tuple[int, int] | None:
    """``trial=`` as ``(participant, trial)``: a pair of whole numbers, or ``"P:T"`` as ``--trial``
    takes it (read by :func:`~nudgecli.report.plotting.parse_trial`), or ``None``.

    Raises
    ------
    ConfigError
        Anything else (a text that is not ``P:T`` gets ``--trial``'s message).
    """
    from nudgecli.report.plotting import parse_trial

    if value is None or isinstance(value, str):
        return parse_trial(value)
    got = None
    if isinstance(value, Sequence):  # say what is wrong with the pair: its length, or its items' types
        kind = type(value).__name__
        if len(value) != 2:
            got = f"a {kind} of {len(value)} item{'' if len(value) == 1 else 's'}"
        elif all(isinstance(part, numbers.Integral) and not isinstance(part, bool) for part in value):
            return int(value[0]), int(value[1])
        else:
            got = (f"a {kind} of {type(value[0]).__name__} and {type(value[1]).__name__}: its two items "
                   "must be whole numbers (int)")
    raise _refuse("trial", value, "(participant, trial) or 'PARTICIPANT:TRIAL', e.g. (0, 12) or '0:12'",
                  got=got)


def switches(**values: object) -> None:
    """Each of ``values`` (``force=force, yes=yes``) must be ``True`` or ``False`` (:func:`switch`)."""
    for name, value in values.items():
        switch(name, value)


def run_options(*, workers: object, seed: object, scheduler: object, people: object, progress: object,
                resume: object, force: object, confirm: object, log: object = None) -> dict[str, Any]:
    """The options of a simulated study (:func:`~nudgecli.runs.study.run_study`'s keywords of the
    same names), their types checked: local workers, the master seed, a scheduler's address, the
    people file, the progress and log callbacks and the resume, force and confirm switches.

    Raises
    ------
    ConfigError
        The first of them of a wrong type.
    """
    switches(resume=resume, force=force, confirm=confirm)
    return {"workers": whole_number("workers", workers), "seed": whole_number("seed", seed, optional=True),
            "scheduler": text("scheduler", scheduler, optional=True), "people": people_file(people),
            "progress": callback("progress", progress), "log": callback("log", log), "resume": resume,
            "force": force, "confirm": confirm}


def callback(name: str, value: object) -> Any:
    """``value``, which must be callable or ``None`` (``progress=``, ``log=``).

    Raises
    ------
    ConfigError
        Anything else, before the work whose progress it would be told.
    """
    if value is not None and not callable(value):
        raise _refuse(name, value, "a function or None")
    return value


def people_file(value: object) -> Any:
    """``people=`` as a run takes it: a people file's path, the :class:`~nudgecli.sim.people_file.People`
    read from one, or ``None``; a :class:`~nudgecli.api.fitting.FittedPeople` stands for the file
    :func:`~nudgecli.api.fitting.fit_people` wrote (``out=``).

    Raises
    ------
    ConfigError
        A ``FittedPeople`` that wrote no file, its ``.table`` (a DataFrame), or anything else that is
        no path: the message says to pass the file ``fit_people(..., out=...)`` writes.
    """
    from nudgecli.api.fitting import FittedPeople
    from nudgecli.sim.people_file import People

    if value is None or isinstance(value, People):
        return value
    if isinstance(value, FittedPeople) and value.files:
        return value.files[0]
    if isinstance(value, str | os.PathLike):
        return value
    raise ConfigError(f"people={type(value).__name__}: people= takes a people file's path; write the "
                      "people with nudgecli.fit_people(sources, out='people.csv') and pass "
                      "people='people.csv' (or the FittedPeople it returns)")
