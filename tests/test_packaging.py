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


def _source_folder(package: str, package_dirs: dict[str, str]) -> Path:
    """Where ``package``'s files are in the checkout (``[tool.setuptools.package-dir]`` applied)."""
    for prefix, folder in package_dirs.items():
        if package == prefix or package.startswith(prefix + "."):
            return ROOT / folder / Path(*package[len(prefix):].split(".")[1:])
    return ROOT / Path(*package.split("."))


def test_every_data_file_is_shipped_from_a_listed_package() -> None:
    # setuptools ships package data only of listed packages (a data folder Python sees as a
    # package but not listed is warned about, and may be dropped by a later setuptools)
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed, package_dirs = set(config["packages"]), config["package-dir"]
    package_data = config["package-data"]
    assert set(package_data) - listed == set(), "list these data folders in [tool.setuptools] packages"
    shipped = {path for package, patterns in package_data.items() for pattern in patterns
               for path in _source_folder(package, package_dirs).glob(pattern)}
    sources = [ROOT / "nudgecli", *(ROOT / folder for folder in package_dirs.values())]
    # experiments/pilots: example logs that docs/people.md's commands read by path in a checkout
    examples = ROOT / "experiments" / "pilots"
    data = {path for source in sources for path in source.rglob("*")
            if path.is_file() and path.suffix not in (".py", ".pyc") and "__pycache__" not in path.parts
            and not path.is_relative_to(examples)}
    assert data - shipped == set(), "add these files to [tool.setuptools.package-data]"
