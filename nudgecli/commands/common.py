"""What the commands share: the Ctrl-C hint's key, JSON on stdout, log lines on stderr, the
progress bar and the help texts of the options several commands have."""

from __future__ import annotations

import functools
import json
import math
import sys
from typing import Any

import click

from nudgecli.errors import ConfigError
from nudgecli.outputs import command_inputs, declare_input
from nudgecli.runs.dask_cluster import SCHEDULER_OPTION, scheduler_named
from nudgecli.runs.size import YES_OPTION, override_named

#: ``ctx.meta`` key of a callable returning what to tell the user after Ctrl-C (how to resume).
INTERRUPT_HINT = "nudge.interrupt_hint"
#: Exit status after Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130

SET_HELP = "Override one experiment field, e.g. --set disambiguation.window=5 (repeatable)."
YES_HELP = "Simulate a study above the size limit (docs/reliability.md)."
PEOPLE_HELP = ("Simulate the twins of a people file (nudge fit-people): participant i has the habits of "
               "person i mod P, the rest of their physiology drawn as usual.")
FORCE_HELP = ("Write into --out even when it is not empty or holds a run (files of the same names are "
              "replaced; nothing else is touched).")


def echo_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (the only output of ``--format json``): strict JSON, every
    NaN or infinity as ``null`` (:func:`strict_json_value`), as every JSON file the toolkit writes."""
    click.echo(json.dumps(strict_json_value(data), indent=2, sort_keys=False, allow_nan=False))


def strict_json_value(value: Any) -> Any:
    """A copy of ``value`` that strict JSON can hold: mappings with string keys, lists, numpy
    arrays and scalars made plain, and a float that is NaN or infinite made ``None`` (``null``;
    Python's ``json`` would write ``NaN``, which no strict JSON reader accepts).

    Raises
    ------
    TypeError
        A value of another kind (a bug: the document was not made JSON-ready).
    """
    if isinstance(value, dict):
        return {str(key): strict_json_value(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [strict_json_value(item) for item in value]
    if hasattr(value, "tolist"):  # a numpy array or scalar: Python lists and scalars
        plain = value.tolist()
        return strict_json_value(plain) if isinstance(plain, list) else _strict_scalar(plain)
    return _strict_scalar(value)


def _strict_scalar(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if value is None or isinstance(value, str | int | float):  # bool is an int
        return value
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def comma_integers(text: str, option: str, example: str) -> list[int]:
    """The integers of the comma-separated value of ``option`` (``"6,9,12"``); a click usage error
    naming the option and ``example`` for anything else, an empty item beside integers (``"3,,4"``,
    a trailing comma) or an integer given twice (``"3,3"``), which were dropped without a word."""
    parts = [part.strip() for part in text.split(",")]
    try:
        numbers = [int(part) for part in parts if part]
    except ValueError:
        raise click.BadParameter(f"{text!r}: give comma-separated integers, e.g. {example}",
                                 param_hint=option) from None
    twice = next((n for i, n in enumerate(numbers) if n in numbers[:i]), None)
    if ("" in parts and numbers) or twice is not None:  # none at all: the caller says what to give
        problem = "an empty item" if "" in parts else f"{twice} is given twice"
        raise click.BadParameter(f"{text!r}: {problem}; give comma-separated integers, each once, e.g. "
                                 f"{example}", param_hint=option)
    return numbers


def info(message: str) -> None:
    """A log line on stderr."""
    click.echo(message, err=True)


def progress_bar(label: str, unit: str = "trial") -> tuple[Any, Any]:
    """A tqdm bar on stderr (off when stderr is not a terminal) and its update callback.

    The bar has no monitor thread (tqdm's, which adjusts the refresh rate of bars left alone; this
    one is refreshed on every update): a thread left running keeps the command from writing its
    figures in forked processes (:func:`nudgecli.report.figures.output.save_figures`)."""
    from tqdm import tqdm

    class Bar(tqdm):  # type: ignore[type-arg]
        monitor_interval = 0

    bar = Bar(total=0, desc=label, unit=unit, file=sys.stderr, disable=None, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return bar, update


#: Options that name a file the command reads though their type is not a path (a plan preset or
#: its TOML file; ``ciaa-people`` or a reference JSON).
FILE_OPTIONS = ("plan", "compare")


def declaring_inputs(command: click.Command) -> click.Command:
    """``command``, its callback run with the files it reads declared
    (:func:`nudgecli.outputs.declare_input`): the values of its path arguments and options and of
    :data:`FILE_OPTIONS`, ``--out`` aside. So no command replaces a file it read with an output,
    whoever wrote the command (:func:`nudgecli.store.atomic_path` refuses). An empty ``--out``
    (``--out ""``, a variable left unset) is refused here, for every command, before any work; and
    a refusal of the size guard names ``--yes`` (:func:`nudgecli.runs.size.override_named`)."""
    callback = command.callback
    if callback is None or getattr(callback, "declares_inputs", False):
        return command
    out_required = any(param.name == "out" and param.required for param in command.params)
    named = [(param.name, param.opts[-1] if isinstance(param, click.Option) else param.human_readable_name)
             for param in command.params
             if param.name not in (None, "out") and (isinstance(param.type, click.Path)
                                                     or param.name in FILE_OPTIONS)]

    @functools.wraps(callback)
    def run(*args: Any, **kwargs: Any) -> Any:
        if kwargs.get("out") == "":  # a path would make it the current folder, or no file at all
            raise ConfigError('--out "": an empty path; name the folder or file to write'
                              + ("" if out_required else ", or leave --out out for the default"))
        # the API it calls names confirm=True and scheduler=
        with command_inputs(), override_named(YES_OPTION), scheduler_named(SCHEDULER_OPTION):
            for name, label in named:
                value = kwargs.get(str(name))
                for path in value if isinstance(value, tuple | list) else (value,):
                    declare_input(label, path)
            return callback(*args, **kwargs)

    run.declares_inputs = True  # type: ignore[attr-defined]
    command.callback = run
    return command
