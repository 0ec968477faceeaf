"""The wheel ships every package: `pip install .` (what CI and users run) lists packages
explicitly in pyproject.toml, so a new subpackage must be named there too."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_of_nudgecli_is_shipped() -> None:
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    inits = (ROOT / "nudgecli").rglob("__init__.py")
    found = {".".join(init.parent.relative_to(ROOT).parts) for init in inits}
    assert found - listed == set(), "add these to [tool.setuptools] packages in pyproject.toml"


def test_the_package_marks_itself_typed() -> None:
    # PEP 561: without py.typed in the wheel, mypy ignores nudgecli's hints in users' code
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "py.typed" in data.get("nudgecli", [])
    assert (ROOT / "nudgecli" / "py.typed").is_file()
