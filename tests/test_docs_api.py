"""docs/api.md runs: its ```python blocks, which examples/walkthrough.ipynb holds as its code cells, are
executed in order in a fresh folder, and the tables they write equal the commands', byte for byte."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from nudgecli.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _walkthrough_maker() -> Any:
    """examples/make_walkthrough.py as a module (examples/ is no package)."""
    path = ROOT / "examples" / "make_walkthrough.py"
    spec = importlib.util.spec_from_file_location("make_walkthrough", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module

DOC = ROOT / "docs" / "api.md"
NOTEBOOK = ROOT / "examples" / "walkthrough.ipynb"


def run_cli(arguments: list[str]) -> str:
    """``nudge ARGUMENTS`` in this process; its stdout (the command must succeed)."""
    result = CliRunner().invoke(main, arguments)
    assert result.exit_code == 0, result.output
    return result.stdout


def python_blocks(markdown: str) -> list[str]:
    """The ```python blocks of a Markdown page, in order (their code, without the fences)."""
    return [block.rstrip("\n") for block in re.findall(r"^```python\n(.*?)^```", markdown, flags=re.S | re.M)]


def notebook_code(notebook: dict[str, Any]) -> list[str]:
    """The code cells of a notebook (nbformat 4), in order."""
    return ["".join(cell["source"]).rstrip("\n") for cell in notebook["cells"] if cell["cell_type"] == "code"]


def test_the_block_reader_sees_every_python_block_and_nothing_else() -> None:
    page = "text\n```python\na = 1\n```\n```console\n$ nudge\n```\n```python\nb = 2\nc = 3\n```\n"
    assert python_blocks(page) == ["a = 1", "b = 2\nc = 3"]


def test_the_notebook_is_the_pages_walkthrough() -> None:
    # one walkthrough in two forms: the test below runs the notebook, so it must be the page's, made
    # by examples/make_walkthrough.py (run it after editing the page)
    notebook = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    page = DOC.read_text(encoding="utf-8")
    assert notebook == _walkthrough_maker().notebook_of(page)
    assert notebook["nbformat"] == 4 and notebook_code(notebook) == python_blocks(page)


def test_the_walkthrough_runs_and_its_tables_equal_the_commands(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    # the cells run as a kernel would run plain Python cells, one namespace, top to bottom (a
    # Jupyter kernel would add seconds and three dependencies and run the same code)
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, Any] = {"__name__": "__main__"}
    for index, code in enumerate(notebook_code(json.loads(NOTEBOOK.read_text(encoding="utf-8")))):
        exec(compile(code, f"walkthrough cell {index}", "exec"), namespace)
    assert (tmp_path / "completion_time.png").stat().st_size > 0
    assert not namespace["quiet"].path.exists()  # the with-block removed its temporary run

    run_cli(["simulate", "smoke", "--participants", "3", "--seed", "7", "--out", str(tmp_path / "cli-run")])
    run_cli(["analyze", str(tmp_path / "cli-run"), "--out", str(tmp_path / "cli-analysis")])
    for name in ("stats.csv", "metrics.csv"):
        cli_table, api_table = (tmp_path / "cli-analysis" / name), (tmp_path / "smoke-analysis" / name)
        assert cli_table.read_bytes() == api_table.read_bytes()
    api_trials = sorted((tmp_path / "smoke-run" / "trials").glob("part-*.parquet"))
    cli_trials = sorted((tmp_path / "cli-run" / "trials").glob("part-*.parquet"))
    assert [p.read_bytes() for p in api_trials] == [p.read_bytes() for p in cli_trials]
