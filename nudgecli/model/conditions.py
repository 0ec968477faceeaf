"""The study conditions by name: the one list of the built-in policies a condition may run, the
paper's pair, the aliases, and the metrics each built-in policy makes constant (no dependencies,
so the configuration, the protocol and the statistics all read it without loading numerical
libraries). What each policy does is :mod:`nudgecli.sim.builtin_policies`."""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence

#: Every built-in policy, by condition name (:mod:`nudgecli.sim.builtin_policies` implements them).
POLICIES = ("disambiguation", "control", "teleoperation", "blending", "mode-switch", "hindsight",
            "turn-taking")
#: The paper's two conditions, in the paper's order.
PAPER_CONDITIONS: tuple[str, ...] = ("disambiguation", "control")
#: Condition names of other studies that are one of :data:`POLICIES` under another name.
POLICY_ALIASES = {"no_assistance": "teleoperation"}


def policy_name(condition: str) -> str:
    """The built-in policy a condition names (``no_assistance`` is ``teleoperation``)."""
    return POLICY_ALIASES.get(condition, condition)


#: The per-trial metrics, in the metrics table's column order (``nudgecli.report.metrics``
#: computes them; here so that the simulation can check the names a policy declares constant).
METRIC_NAMES = (
    "assistance_engagement",
    "assistance_strength",
    "mode_switches",
    "human_effort",
    "completion_time",
    "human_turns",
    "success",
    "first_input_latency",
    "active_input_fraction",
    "wrong_goal",
)

#: Metrics a built-in policy makes constant by construction (not applicable to its condition):
#: without turn-taking the person's turn is the whole trial (``human_effort`` 1, ``human_turns`` 1);
#: without assistance there is nothing to engage; an additive assistance has no blending weight
#: to average (its alpha is 1 whenever it acts).
CONSTANT_METRICS: dict[str, frozenset[str]] = {
    "disambiguation": frozenset(),
    "control": frozenset(),
    "turn-taking": frozenset(),
    "mode-switch": frozenset(),
    "teleoperation": frozenset({"assistance_engagement", "assistance_strength", "human_effort",
                                "human_turns"}),
    "blending": frozenset({"human_effort", "human_turns"}),
    "hindsight": frozenset({"assistance_strength", "human_effort", "human_turns"}),
}


#: The metrics only a policy that infers the goal gives: a condition whose policy makes both
#: constant infers no goal (teleoperation, the CIAA study's ``no_assistance``).
INFERENCE_METRICS = frozenset({"assistance_engagement", "assistance_strength"})
#: The success definitions that read the inferred goal (``nudgecli.report.plans``' ``success``):
#: the study software's proxy, never true without inference, so not applicable there.
INFERRED_SUCCESS = frozenset({"last_inferred_goal"})


def not_applicable_metrics(conditions: Sequence[str],
                           constant_metrics: Mapping[str, Collection[str]] | None = None,
                           *, success: str = "reached_goal") -> dict[str, tuple[str, ...]]:
    """Metric -> the conditions for which it is not applicable (constant by construction).

    Parameters
    ----------
    conditions
        The study's conditions, in order.
    constant_metrics
        Condition -> the metrics its policy makes constant (an experiment's resolved policies:
        ``nudgecli.sim.policy_registry.constant_metrics_of``); a condition it does not list (and
        every condition by default) has the built-in policies' :data:`CONSTANT_METRICS` under its
        policy name (aliases resolved), nothing if it names no built-in policy.
    success
        The plan's success definition: one of :data:`INFERRED_SUCCESS` makes ``success`` not
        applicable to a condition without inference (:data:`INFERENCE_METRICS` constant).

    Returns
    -------
    dict
        Only metrics with at least one such condition; conditions in the study's order.
    """
    given = constant_metrics or {}
    table: dict[str, list[str]] = {}
    for condition in conditions:
        constant = set(given[condition] if condition in given else
                       CONSTANT_METRICS.get(POLICY_ALIASES.get(condition, condition), frozenset()))
        if success in INFERRED_SUCCESS and constant >= INFERENCE_METRICS:
            constant.add("success")
        for metric in sorted(constant):
            table.setdefault(metric, []).append(condition)
    return {metric: tuple(names) for metric, names in sorted(table.items())}
