"""Every command of issue 40 is a thin wrapper over the Python API: it parses, calls
:mod:`nudgecli.api`, prints. So none of their code imports the layers that compute (the model, the
simulation, the runs, the analysis, the experiment files): what a command prints is what an API
function returned, and a notebook gets the same numbers.

Two commands are exempt, and named here so a new command is held to the rule by default:
``study`` serves a web page a person drives by hand (an interactive server, nothing a notebook
calls and reads back), and ``bench`` measures the code itself (its timings are of this process, not
an analysis of a study).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "nudgecli"

#: The command modules whose commands call the API.
MODULES = ("commands/simulation.py", "commands/analysis.py", "commands/batches.py", "commands/tools.py",
           "commands/people.py")
#: Functions of those modules that may import the computing layers: the interactive study page and
#: the benchmark (see the module's docstring).
NOT_ON_THE_API = {"study_command", "bench_command"}
#: The layers that compute; a thin command imports none of them.
COMPUTING = ("nudgecli.model", "nudgecli.sim", "nudgecli.runs", "nudgecli.report", "nudgecli.config",
             "nudgecli.config_files", "nudgecli.locks", "nudgecli.bench", "nudgecli.live")


def _imports(node: ast.AST) -> list[str]:
    found = []
    for sub in ast.walk(node):
        if isinstance(sub, ast.Import):
            found += [alias.name for alias in sub.names]
        elif isinstance(sub, ast.ImportFrom) and sub.module and sub.level == 0:
            found += [sub.module, *(f"{sub.module}.{alias.name}" for alias in sub.names)]
    return found


def computing_imports(source: str, exempt: set[str]) -> list[str]:
    """``function: module`` for each import of a computing layer in ``source``, at any depth, outside
    the functions named in ``exempt``."""
    tree = ast.parse(source)
    skipped = {id(sub) for node in ast.walk(tree)
               if isinstance(node, ast.FunctionDef) and node.name in exempt for sub in ast.walk(node)}
    offending = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom) and id(node) not in skipped:
            offending += [module for module in _imports(node)
                          if any(module == layer or module.startswith(layer + ".") for layer in COMPUTING)]
    return offending


def test_the_walk_finds_an_import_inside_a_command() -> None:
    source = ("import click\nfrom nudgecli import api\n"
              "def analyze_command():\n    from nudgecli.report.analysis import analyze\n"
              "def study_command():\n    from nudgecli.live.app import run_live_study\n"
              "def run_command():\n    import nudgecli.runs.study\n")
    assert computing_imports(source, NOT_ON_THE_API) == [
        "nudgecli.report.analysis", "nudgecli.report.analysis.analyze", "nudgecli.runs.study"]


@pytest.mark.parametrize("module", MODULES)
def test_the_commands_compute_nothing_themselves(module: str) -> None:
    assert computing_imports((PACKAGE / module).read_text(encoding="utf-8"), NOT_ON_THE_API) == []


@pytest.mark.parametrize("module", MODULES)
def test_the_commands_call_the_api(module: str) -> None:
    imported = _imports(ast.parse((PACKAGE / module).read_text(encoding="utf-8")))
    assert any(name == "nudgecli.api" or name.startswith("nudgecli.api.") for name in imported)
