"""One owner per concept of the run folder's life (issue 22): each is spelled in one module of
``nudgecli`` only, so simulate, the batches, ``nudge study``, analyze and plot cannot drift apart.

- the names of a run folder's and an analysis folder's files: ``nudgecli/run_folder_names.py``;
- the prepare rule (a folder holding another run, a non-empty folder, ``--resume`` with nothing
  there), the manifest skeleton and the suggested ``--resume`` command: ``nudgecli/store.py``;
- the executor's name a study's or a batch's manifest records (``serial``, ``processes:W``,
  ``dask``): ``nudgecli/runs/study.py``.

The code is read as Python (string constants and names, docstrings left out), so prose that
mentions ``stats.json`` does not count and a second spelling in an f-string does.
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "nudgecli"

NAMES_MODULE = "nudgecli/run_folder_names.py"
STORE = "nudgecli/store.py"
EXECUTOR_NAME = "nudgecli/runs/study.py"

#: File and folder names of a run folder and of an analysis folder.
FILE_NAMES = ("manifest.json", "participants.parquet", "layouts.parquet", ".nudge.lock", "metrics.csv",
              "stats.json", "stats.csv", "summary.md", "questionnaires.csv", "figures")
#: Words of the prepare rule's refusals.
PREPARE_TEXTS = ("exists and is not empty", "nothing to resume", "already holds a")


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring constants of a module, its classes and functions."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def _click_declarations(tree: ast.AST) -> set[int]:
    """ids of the string constants inside ``click.option(...)``/``click.argument(...)`` calls (an
    option's own name and help are the command's declaration, not a command line built)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                node.func.attr in ("option", "argument"):
            found.update(id(sub) for sub in ast.walk(node) if isinstance(sub, ast.Constant))
    return found


@cache
def code_of_package() -> dict[str, tuple[list[str], set[str]]]:
    """Module path -> (its string constants outside docstrings and click declarations, the names
    it uses: variables, attributes, called functions)."""
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        skipped = _docstrings(tree) | _click_declarations(tree)
        strings = [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
                   and isinstance(node.value, str) and id(node) not in skipped]
        names = {node.id for node in ast.walk(tree) if isinstance(node, ast.Name)}
        names |= {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)}
        modules[path.relative_to(PACKAGE.parent).as_posix()] = (strings, names)
    return modules


def modules_with_string(text: str, *, exact: bool) -> set[str]:
    return {module for module, (strings, _) in code_of_package().items()
            if any(s == text if exact else text in s for s in strings)}


def modules_using(name: str) -> set[str]:
    return {module for module, (_, names) in code_of_package().items() if name in names}


@pytest.mark.parametrize("name", FILE_NAMES)
def test_each_file_name_is_spelled_in_one_module(name: str) -> None:
    assert modules_with_string(name, exact=True) == {NAMES_MODULE}


@pytest.mark.parametrize("text", PREPARE_TEXTS)
def test_the_prepare_rule_is_written_once(text: str) -> None:
    assert modules_with_string(text, exact=False) == {STORE}


def test_the_manifest_skeleton_is_built_once() -> None:
    # the keys every manifest opens with: versions and creation time, then a run's own
    assert modules_with_string("created", exact=True) == {STORE}
    assert modules_with_string("trials_per_participant", exact=True) == {STORE}
    assert modules_using("library_versions") == {STORE}


def test_the_resume_command_is_built_once() -> None:
    assert modules_with_string("--resume", exact=True) == {STORE}
    assert modules_using("shlex") == {STORE}


def test_the_executor_name_is_spelled_once() -> None:
    assert modules_with_string("processes:", exact=False) == {EXECUTOR_NAME}
    assert modules_with_string("serial", exact=True) == {EXECUTOR_NAME}
    assert {EXECUTOR_NAME, "nudgecli/runs/batch.py"} <= modules_using("executor_name")


def test_the_walk_sees_f_strings_and_skips_docstrings(tmp_path: Path) -> None:
    source = ('"""Writes stats.json."""\nimport click\n@click.option("--resume", help="--resume")\n'
              'def f(x):\n    """stats.json"""\n    return f"{x}/{\'stats.json\'}: nothing to resume"\n')
    tree = ast.parse(source)
    skipped = _docstrings(tree) | _click_declarations(tree)
    strings = [n.value for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str)
               and id(n) not in skipped]
    assert "stats.json" in strings and any("nothing to resume" in s for s in strings)
    assert "--resume" not in strings and "Writes stats.json." not in strings
