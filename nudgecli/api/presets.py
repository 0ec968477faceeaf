"""``nudgecli.presets``: the shipped experiments and analysis plans, as ``nudge presets`` lists them.

The files are :func:`nudgecli.config_files.list_presets`'; ``nudge presets`` prints this table.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    import pandas as pd

#: The kinds of preset, in the order they are listed: ``kind`` -> the heading ``nudge presets`` prints.
PRESET_KINDS: dict[Literal["experiments", "analysis"], str] = {
    "experiments": "Experiments", "analysis": "Analysis plans"}


def presets() -> pd.DataFrame:
    """The shipped presets, experiments first, each kind sorted by name.

    Returns
    -------
    DataFrame
        ``(N, 4)``: ``kind`` (``experiments`` or ``analysis``), ``name`` (what ``simulate``,
        ``run`` or ``--plan`` take), ``description`` (empty when the file has none) and ``path``
        (the TOML file, text).

    Raises
    ------
    NudgeError
        A shipped file that is not valid TOML (names the file).
    """
    import pandas as pd

    from nudgecli.config_files import list_presets, read_toml

    rows = []
    for kind in PRESET_KINDS:
        for name, path in list_presets(kind).items():
            data = read_toml(path)
            # experiments describe themselves in [experiment], plans at the top level
            text = data.get("experiment", {}).get("description", "") if kind == "experiments" \
                else data.get("description", "")
            rows.append({"kind": kind, "name": name, "description": text, "path": str(path)})
    return pd.DataFrame(rows, columns=["kind", "name", "description", "path"])
