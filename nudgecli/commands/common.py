"""What the commands share: the Ctrl-C hint's key, JSON on stdout, log lines on stderr, the
progress bar and the help texts of the options several commands have."""

from __future__ import annotations

import json
import sys
from typing import Any

import click

#: ``ctx.meta`` key of a callable returning what to tell the user after Ctrl-C (how to resume).
INTERRUPT_HINT = "nudge.interrupt_hint"
#: Exit status after Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130

SET_HELP = "Override one experiment field, e.g. --set disambiguation.window=5 (repeatable)."
YES_HELP = "Simulate more trials than the size limit allows without asking (see the README)."


def echo_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (the only output of ``--format json``)."""
    click.echo(json.dumps(data, indent=2, sort_keys=False, default=_json_default))


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def info(message: str) -> None:
    """A log line on stderr."""
    click.echo(message, err=True)


def progress_bar(label: str, unit: str = "trial") -> tuple[Any, Any]:
    """A tqdm bar on stderr (off when stderr is not a terminal) and its update callback."""
    from tqdm import tqdm

    bar = tqdm(total=0, desc=label, unit=unit, file=sys.stderr, disable=None, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return bar, update
