"""The TOML writer (config_files.dump_toml): what it writes, tomllib reads back exactly, so a run's
config.toml and a batch's experiment.toml always load again (a resume reads them)."""

from __future__ import annotations

import tomllib
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.config import load_experiment
from nudgecli.config_files import dump_toml, toml_value

_SCALARS = st.one_of(st.text(), st.booleans(), st.integers(-(2**63), 2**63 - 1),
                     st.floats(allow_nan=False))
_VALUES = st.recursive(_SCALARS, lambda inner: st.lists(inner, max_size=3)
                       | st.dictionaries(st.text(), inner, max_size=3), max_leaves=8)
_TABLES = st.recursive(st.dictionaries(st.text(), _VALUES, max_size=3),
                       lambda inner: st.dictionaries(st.text(), inner | _VALUES, max_size=3), max_leaves=6)


@settings(max_examples=300, deadline=None)
@given(key=st.text(), text=st.text())
def test_any_key_and_text_round_trip(key: str, text: str) -> None:
    data = {key: text, "section": {key: {key: text}}}
    assert tomllib.loads(dump_toml(data)) == data


@settings(max_examples=200, deadline=None)
@given(data=_TABLES)
def test_nested_tables_round_trip(data: dict) -> None:
    assert tomllib.loads(dump_toml(data)) == data


@settings(max_examples=200, deadline=None)
@given(value=_VALUES)
def test_a_value_reads_back_as_itself(value: object) -> None:
    assert tomllib.loads(f"v = {toml_value(value)}")["v"] == value


def test_a_multiline_description_and_a_quoted_policy_name_load_again(tmp_path: Path) -> None:
    # valid TOML in, valid TOML out: a description across lines and a policy name with a space
    source = Path(__file__).parents[1] / "experiments" / "custom-policy.toml"
    text = source.read_text(encoding="utf-8").replace("[policies.threshold]", '[policies."thr esh"]')
    text = text.replace('"threshold"]', '"thr esh"]').replace(
        'description = "A researcher', 'description = """multi\nline\tA researcher').replace(
        'blending."\n', 'blending."""\n')
    (tmp_path / "policies").symlink_to(source.parent / "policies")
    (tmp_path / "exp.toml").write_text(text, encoding="utf-8")
    config = load_experiment(str(tmp_path / "exp.toml"))
    assert config.experiment.description.startswith("multi\nline\t")
    (tmp_path / "config.toml").write_text(config.to_toml(), encoding="utf-8")
    again = load_experiment(str(tmp_path / "config.toml"))
    assert again.model_dump() == config.model_dump()
