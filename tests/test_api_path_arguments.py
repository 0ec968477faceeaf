"""A path argument of the API is a ``str`` or a ``pathlib.Path``, never empty: ``out=""`` would
make the current folder the run's (``nudge --out ""`` is refused, as by every command), and
``Run.open(3)`` names its argument instead of pathlib's ``TypeError``; nothing is written."""

from __future__ import annotations

import pytest

import nudgecli
from nudgecli.errors import ConfigError


def test_an_empty_out_is_refused_before_any_work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=r"^out='': an empty path; name the folder or file to write, "
                                          r"or leave out= out \(None\) for the default$"):
        nudgecli.simulate("smoke", participants=1, seed=1, out="", force=True)
    assert list(tmp_path.iterdir()) == []


def test_an_empty_path_to_read_is_refused(tmp_path, monkeypatch):
    from nudgecli.api import arguments

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=r"^source='': an empty path; name the folder or file to read$"):
        arguments.path("source", "")
    assert arguments.path("source", "run") == "run"


@pytest.mark.parametrize(("value", "words"), [
    (3, r"^path=3: path= takes a path \(a str or a pathlib.Path\), not int$"),
    ("", r"^path='': an empty path; name the folder or file to read$")])
def test_run_open_names_a_path_that_is_not_one(tmp_path, monkeypatch, value, words):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=words):
        nudgecli.Run.open(value)
