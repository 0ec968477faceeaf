"""The README's command table lists every value an option with a fixed set of values takes:
``nudge bench [--only model|study|scale|analyze|all]`` left out ``pipeline``, which the README
itself uses (``nudge bench --only pipeline``)."""

from __future__ import annotations

import re
from pathlib import Path

import click

from nudgecli.cli import main

ROOT = Path(__file__).resolve().parents[1]
#: ``--option a\|b\|c`` in a row of the table (lower-case values: not a FILE\|preset placeholder).
LISTED = re.compile(r"--([a-z][\w-]*) ((?:[a-z][\w-]*\\\|)+[a-z][\w-]*)(?=[\]` ])")


def _synopses() -> list[tuple[str, str, list[str]]]:
    rows = []
    for line in (ROOT / "README.md").read_text(encoding="utf-8").splitlines():
        command = re.match(r"\| `nudge ([a-z-]+)", line)
        if command:
            synopsis = line.split("` |")[0]
            rows += [(command.group(1), option, values.split("\\|"))
                     for option, values in LISTED.findall(synopsis)]
    return rows


def test_the_synopses_list_every_choice_of_their_options() -> None:
    rows = _synopses()
    assert ("bench", "only", ["model", "study", "scale", "pipeline", "analyze", "all"]) in rows
    for command, option, values in rows:
        (param,) = [p for p in main.commands[command].params if f"--{option}" in p.opts]
        assert isinstance(param.type, click.Choice), (command, option)
        assert values == list(param.type.choices), (command, option, values)
