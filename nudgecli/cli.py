"""The ``nudge`` command line: parse, call one function, print. No model logic here.

stdout carries results (tables, JSON); logs and progress go to stderr. A ``NudgeError``
prints one ``Error: ...`` line and exits 1 (``--debug`` shows the traceback); click usage
errors exit 2.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import click

from nudgecli import __version__
from nudgecli.errors import NudgeError


class NudgeGroup(click.Group):
    """A click group that turns ``NudgeError`` into one ``Error:`` line and exit status 1."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except NudgeError as exc:
            if ctx.meta.get("nudge.debug"):
                raise
            click.echo(f"Error: {exc}", err=True)
            ctx.exit(1)


@click.group(cls=NudgeGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="nudge")
@click.option("--debug", is_flag=True, help="Show full tracebacks for errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Simulate and analyse assistive shared-control studies (sip-and-puff intent disambiguation)."""
    ctx.meta["nudge.debug"] = debug


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


# --- presets -------------------------------------------------------------------------------

# --- bench ---------------------------------------------------------------------------------

# --- fit -----------------------------------------------------------------------------------

# --- simulate / run ------------------------------------------------------------------------

# --- analyze -------------------------------------------------------------------------------

# --- plot ----------------------------------------------------------------------------------

# --- validate ------------------------------------------------------------------------------


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
