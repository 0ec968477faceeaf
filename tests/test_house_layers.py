"""The house's layers hold (issue 22): the domain (`nudgecli.model`, `nudgecli.sim`) imports
nothing from the analysis (`nudgecli.report`) or the orchestration (`nudgecli.runs`), so the
simulation can be read, tested and reused without them; imports inside functions count too."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "nudgecli"


def imported_modules(path: Path) -> set[str]:
    """Every absolute module a file imports, at any depth of its code."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def test_the_import_walk_sees_imports_inside_functions(tmp_path: Path) -> None:
    source = tmp_path / "m.py"
    source.write_text("def f():\n    from nudgecli.report import plans\n    import nudgecli.runs.batch\n")
    assert {"nudgecli.report", "nudgecli.report.plans", "nudgecli.runs.batch"} <= imported_modules(source)


@pytest.mark.parametrize("layer", ["model", "sim"])
def test_the_domain_imports_no_analysis_and_no_orchestration(layer: str) -> None:
    offending = {
        f"{path.relative_to(PACKAGE.parent)}: {module}"
        for path in sorted((PACKAGE / layer).rglob("*.py"))
        for module in imported_modules(path)
        if module.startswith(("nudgecli.report", "nudgecli.runs", "nudgecli.cli", "nudgecli.commands",
                              "nudgecli.live"))
    }
    assert offending == set()
