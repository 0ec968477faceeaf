"""The experiment of a researcher's own policy that the policy tests run (imported as ``from
policy_helpers import ...``; pytest puts this folder on the path, as for ``cli_helpers``): one owner
for its TOML, so each test says only what it varies (the policies, their conditions, their modules)."""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

#: The module source of a policy that only passes the person's command on (``Quiet``): what a test of
#: the harness around a policy needs, whatever the policy does.
QUIET_POLICY = """
from nudgecli.sim.policy_interface import Assistance, AutonomyTurn


class Quiet:
    infers = True
    takes_turns = False

    def assist(self, view):
        return Assistance(view.u_h)

    def start_turn(self, view):
        return AutonomyTurn.stay()
"""


def policy_experiment(folder: Path, factories: Mapping[str, str], *, modules: Mapping[str, str] | None = None,
                      params: Mapping[str, str] | None = None, conditions: Sequence[str] | None = None,
                      participants: int = 1) -> Path:
    """Write ``folder/mine.toml``, a one-layout study (3 goals, the top-right corner, mode x, one
    block a condition) of the given policies, and their modules; the experiment file's path.

    Parameters
    ----------
    folder
        The experiment's folder (made if missing).
    factories
        ``[policies.NAME]`` section name -> its ``factory`` (``"module:attribute"``).
    modules
        A path under ``folder`` (``"mymodule.py"``, ``"policies/threshold.py"``) -> the module's
        source (dedented); its folders are made.
    params
        Section name -> its ``params``, a TOML inline table (``"{ weight = 0.3 }"``); none without.
    conditions
        The study's conditions; by default ``control`` and each of ``factories``.
    participants
        The study's participants.
    """
    folder.mkdir(parents=True, exist_ok=True)
    for relative, source in (modules or {}).items():
        path = folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(source))
    names = ["control", *factories] if conditions is None else list(conditions)
    sections = []
    for name, factory in factories.items():
        section = f'[policies.{name}]\nfactory = "{factory}"\n'
        if params is not None and name in params:
            section += f"params = {params[name]}\n"
        sections.append(section)
    quoted = ", ".join(f'"{name}"' for name in names)
    path = folder / "mine.toml"
    path.write_text(f'[experiment]\nname = "mine"\n\n[study]\nparticipants = {participants}\n'
                    f"conditions = [{quoted}]\ngoal_counts = [3]\ncorners = [\"tr\"]\nstart_modes = [\"x\"]\n"
                    f"blocks_per_condition = 1\n\n" + "\n".join(sections))
    return path
