"""Write examples/walkthrough.ipynb from docs/api.md: the page's prose as markdown cells, its
```python blocks as code cells, in order (``python examples/make_walkthrough.py``).

One walkthrough in two forms: tests/test_docs_api.py checks that the notebook is this script's
output for the page as it is, and runs the notebook's cells top to bottom.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "api.md"
NOTEBOOK = ROOT / "examples" / "walkthrough.ipynb"

#: The page's sentence about the notebook, and what the notebook says instead.
SELF_REFERENCE = ("This page is also a notebook: "
                  "[examples/walkthrough.ipynb](../examples/walkthrough.ipynb)\n"
                  "runs the same code, and CI runs both top to bottom.",
                  "This notebook is the walkthrough of\n[docs/api.md](../docs/api.md), cell for cell; CI "
                  "runs it top to bottom.")


def _cell(kind: str, text: str, index: int) -> dict[str, Any]:
    cell: dict[str, Any] = {"cell_type": kind, "id": f"cell-{index:02d}", "metadata": {},
                            "source": text.splitlines(keepends=True)}
    if kind == "code":
        cell.update(execution_count=None, outputs=[])
    return cell


def notebook_of(page: str) -> dict[str, Any]:
    """The notebook (nbformat 4.5) of a Markdown page: prose -> markdown cells, ```python -> code cells."""
    parts = re.split(r"^```python\n(.*?)^```\n?", page.replace(*SELF_REFERENCE), flags=re.S | re.M)
    cells: list[dict[str, Any]] = []
    for index, part in enumerate(parts):
        text = part.strip("\n") if index % 2 == 0 else part.rstrip("\n")
        if text:
            cells.append(_cell("markdown" if index % 2 == 0 else "code", text, len(cells)))
    return {"cells": cells,
            "metadata": {"kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
                         "language_info": {"name": "python"}},
            "nbformat": 4, "nbformat_minor": 5}


def main() -> None:
    notebook = notebook_of(PAGE.read_text(encoding="utf-8"))
    NOTEBOOK.write_text(json.dumps(notebook, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
