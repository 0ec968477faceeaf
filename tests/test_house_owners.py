"""One owner per concept of the run folder's life (issue 22): each is spelled in one module of
``nudgecli`` only, so simulate, the batches, ``nudge study``, analyze and plot cannot drift apart.

- the names of a run folder's and an analysis folder's files: ``nudgecli/run_folder_names.py``;
- the prepare rule (a folder holding another run, a non-empty folder, ``--resume`` with nothing
  there), the manifest skeleton and the suggested ``--resume`` command: ``nudgecli/store.py``;
- the executor's name a study's or a batch's manifest records (``serial``, ``processes:W``,
  ``dask``): ``nudgecli/runs/study.py``.

And one owner of a figure concept: "draw on the given axes, or on a new figure's of this size"
(the ``ax=None`` convention of every panel) is ``nudgecli/report/figures/common.py``'s
``axes_or_new``; no module of ``nudgecli/report`` makes a panel's figure itself.

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
              "stats.json", "stats.csv", "summary.md", "questionnaires.csv", "questionnaire_scores.csv",
              "figures")
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
    # quoting for the shell has one owner too, which the resume command and every suggestion use
    assert modules_using("shlex") == {"nudgecli/errors.py"}
    assert {STORE, "nudgecli/report/compare.py"} <= modules_using("shell_words")


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


# --- "the given axes, or a new figure's": one owner ----------------------------------------------------

#: The one owner of "draw on the given axes, or on a new figure's of this size".
AXES_OWNER = "nudgecli/report/figures/common.py"


def _takes_ax(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    arguments = node.args
    return any(a.arg == "ax" for a in (*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs))


def _called(node: ast.AST) -> str:
    """The name a call calls (``Figure`` of ``Figure(...)`` and of ``matplotlib.figure.Figure(...)``)."""
    if not isinstance(node, ast.Call):
        return ""
    return node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", "")


def _imported(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if isinstance(node, ast.ImportFrom):
        return [f"{node.module}.{alias.name}" for alias in node.names]
    return []


def axes_copies(source: str) -> list[str]:
    """Where ``source`` makes "the given axes, or a new figure's" itself instead of calling
    :func:`nudgecli.report.figures.common.axes_or_new`: a function taking ``ax`` that makes a
    ``Figure``, a test of ``ax is None``/``ax is not None``, a new figure's single axes
    (``subplots()`` without arguments), or pyplot (``plt.subplots``)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and _takes_ax(node):
            found += [f"{node.name} takes ax and makes a Figure (line {call.lineno})"
                      for call in ast.walk(node) if _called(call) == "Figure"]
        if isinstance(node, ast.Compare) and isinstance(node.left, ast.Name) and node.left.id == "ax" and \
                isinstance(node.ops[0], ast.Is | ast.IsNot) and \
                isinstance(node.comparators[0], ast.Constant) and node.comparators[0].value is None:
            found.append(f"ax is None (line {node.lineno})")
        if isinstance(node, ast.Call) and _called(node) == "subplots" and not node.args and not node.keywords:
            found.append(f"subplots() of one new axes (line {node.lineno})")
        if any(name.endswith("pyplot") for name in _imported(node)):
            found.append(f"pyplot imported (line {node.lineno})")
    return sorted(set(found))


def test_the_given_axes_or_a_new_figure_has_one_owner() -> None:
    copies = {}
    for path in sorted((PACKAGE / "report").rglob("*.py")):
        name = path.relative_to(PACKAGE.parent).as_posix()
        if name != AXES_OWNER and (found := axes_copies(path.read_text(encoding="utf-8"))):
            copies[name] = found
    assert copies == {}, "call nudgecli.report.figures.common.axes_or_new instead"


@pytest.mark.parametrize("source", [
    "def _axes(ax):\n    return ax if ax is not None else Figure(figsize=(3, 2)).subplots()\n",
    "def panel(x, *, ax=None):\n    if ax is None:\n        ax = 1\n",
    "def panel(x, *, ax=None):\n    fig = matplotlib.figure.Figure()\n    return fig.axes\n",
    "def panel(x):\n    return make().subplots()\n",
    "import matplotlib.pyplot as plt\n",
    "from matplotlib import pyplot\n",
])
def test_the_axes_walk_sees_each_kind_of_copy(source: str) -> None:
    assert axes_copies(source) != []


def test_the_axes_walk_leaves_figures_of_several_axes_and_callers_alone() -> None:
    source = ("def figure(rows):\n    fig = Figure(figsize=(6, 3))\n    left, right = fig.subplots(1, 2)\n"
              "    panel(rows, ax=left)\n    return fig\n\n"
              "def panel(rows, *, ax=None):\n    ax = axes_or_new(ax, (3, 2))\n    return ax\n")
    assert axes_copies(source) == []


def test_the_step_length_is_derived_once() -> None:
    # a study's dt is [study] rate_hz's StudySection.dt: no other module divides by a section's rate
    dividing = set()
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div) and \
                    isinstance(node.right, ast.Attribute) and node.right.attr == "rate_hz":
                dividing.add(path.relative_to(PACKAGE.parent).as_posix())
    assert dividing == {"nudgecli/config.py"}


def _tuples_of_strings(path: Path) -> list[tuple[str, ...]]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Tuple | ast.List) and node.elts and all(
                isinstance(e, ast.Constant) and isinstance(e.value, str) for e in node.elts):
            found.append(tuple(e.value for e in node.elts))  # type: ignore[attr-defined]
    return found


def test_the_condition_names_and_the_paper_pair_are_listed_once() -> None:
    from nudgecli.model.conditions import PAPER_CONDITIONS, POLICIES

    owners: dict[tuple[str, ...], set[str]] = {PAPER_CONDITIONS: set(), POLICIES: set()}
    for path in sorted(PACKAGE.rglob("*.py")):
        for names in _tuples_of_strings(path):
            if names in owners:
                owners[names].add(path.relative_to(PACKAGE.parent).as_posix())
    assert owners == {PAPER_CONDITIONS: {"nudgecli/model/conditions.py"},
                      POLICIES: {"nudgecli/model/conditions.py"}}


def test_the_entropy_gate_is_written_once() -> None:
    # the confidence gate (alpha 0 and no g' while H(b)/log|G| > kappa) is assistance.entropy_gated
    comparing = set()
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare) and any(
                    isinstance(sub, ast.Attribute) and sub.attr == "entropy_gate" for sub in ast.walk(node)):
                comparing.add(path.relative_to(PACKAGE.parent).as_posix())
    assert not comparing
    owners = {"nudgecli/model/assistance.py", "nudgecli/sim/builtin_policies.py"}
    assert owners <= modules_using("entropy_gated")



def test_the_signed_rank_test_has_one_owner() -> None:
    # every participant-level Wilcoxon goes through participant_tests.signed_rank_test, so none
    # runs scipy's one-flip-at-a-time permutation test or drifts from it
    assert modules_using("wilcoxon") == {"nudgecli/report/participant_tests.py"}
    assert modules_using("signed_rank_test") == {"nudgecli/report/participant_tests.py"}


#: Numeric option defaults that belong to the command line alone (no function behind restates them).
CLI_ONLY_DEFAULTS = {"--workers": 1, "--participants": 100}


def _numeric_option_defaults(path: Path) -> dict[str, float]:
    """``--option`` -> its default, where that default is a number written in the option."""
    found = {}
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        is_option = isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
            node.func.attr == "option"
        if not is_option:
            continue
        for keyword in node.keywords:
            value = keyword.value
            if keyword.arg == "default" and isinstance(value, ast.Constant) and \
                    isinstance(value.value, int | float) and not isinstance(value.value, bool):
                name = next(str(a.value) for a in node.args if isinstance(a, ast.Constant)
                            and str(a.value).startswith("--"))
                found[name] = value.value
    return found


def test_command_options_take_their_defaults_from_their_owners() -> None:
    # a number written as an option's default would be a second copy of the function's default
    for path in sorted((PACKAGE / "commands").glob("*.py")):
        for name, value in _numeric_option_defaults(path).items():
            assert CLI_ONLY_DEFAULTS.get(name) == value, f"{path.name}: {name} default={value}"
    from nudgecli import command_defaults

    for name in (n for n in vars(command_defaults) if n.isupper()):
        modules = modules_using(name)
        assert any(m.startswith("nudgecli/commands/") for m in modules), name  # the option shows it
        assert any(not m.startswith("nudgecli/commands/") for m in modules), name  # the function uses it
