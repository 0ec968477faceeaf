"""The pages a command's help points to exist and say what the help sends the reader there for:
``nudge validate --reading`` said "(see the README)", which does not describe the readings;
docs/findings.md does."""

from __future__ import annotations

import re
from pathlib import Path

from cli_helpers import nudge

from nudgecli.api.validation import reading_names

ROOT = Path(__file__).resolve().parents[1]


def _option_help(command: str, option: str) -> str:
    """The help text of ``option`` of ``nudge command --help``, on one line (``option`` as its
    entry starts: other options' help may name it)."""
    text = " ".join(nudge(command, "--help").output.split())
    start = text.index(option)
    following = re.search(r" --[a-z]", text[start + len(option):])
    return text[start:start + len(option) + (following.start() if following else len(text))]


def test_the_reading_option_points_to_the_page_that_describes_every_reading() -> None:
    text = _option_help("validate", "--reading [")
    assert "README" not in text, text
    pages = re.findall(r"docs/[\w-]+\.md", text)
    assert pages == ["docs/findings.md"], text
    page = (ROOT / pages[0]).read_text(encoding="utf-8")
    section = page[page.index("### The validation's readings"):]
    assert all(f"| `{name}` |" in section for name in reading_names())


def test_every_page_a_help_names_exists() -> None:
    named: set[str] = set()
    for command in ("analyze", "bench", "compare", "fit", "fit-people", "habits", "plot", "plot-population",
                    "power", "replicate", "run", "simulate", "study", "sweep", "validate"):
        named.update(re.findall(r"docs/[\w-]+\.md", " ".join(nudge(command, "--help").output.split())))
    assert named and all((ROOT / page).is_file() for page in named), named
