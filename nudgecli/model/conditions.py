"""The study conditions by name: the one list of the policies a condition may run, the paper's
pair, and which policies take turns, blend or assist (no dependencies, so the configuration, the
protocol and the statistics all read it without loading numerical libraries)."""

from __future__ import annotations

#: Every policy, by condition name (:mod:`nudgecli.model.policies` implements them).
POLICIES = ("disambiguation", "control", "teleoperation", "blending", "mode-switch", "hindsight")
#: The paper's two conditions, in the paper's order.
PAPER_CONDITIONS: tuple[str, ...] = ("disambiguation", "control")
#: Condition names of other studies that are one of :data:`POLICIES` under another name.
POLICY_ALIASES = {"no_assistance": "teleoperation"}
#: Policies with the paper's turn-taking (the person hands the turn over when idle).
TURN_TAKING = frozenset({"disambiguation", "control", "mode-switch"})
#: Policies without inference or any autonomous command.
UNASSISTED = frozenset({"teleoperation"})
#: Policies that blend during the human's turn with the paper's alpha (Algorithm 1, line 8).
BLENDING = frozenset({"disambiguation", "control", "mode-switch", "blending"})
