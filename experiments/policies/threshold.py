"""A policy of one's own: assist only once the most likely goal is likely enough.

While the agent's belief in its leading goal ``g'`` is below ``threshold`` the person drives
alone; from then on, on every step with a motion command, the command is blended with the
autonomy's command towards ``g'`` at a fixed weight (``u_f = w u_a + (1 - w) u_h``). There is no
autonomy turn: the person's turn is the whole trial.

Run it with ``nudge run experiments/custom-policy.toml`` (docs/policies.md walks through it).
"""

from __future__ import annotations

from nudgecli.sim.policy_interface import Assistance, AutonomyTurn, StepView, drive_towards


class ThresholdAssist:
    """Blend towards ``g'`` at weight ``weight`` once ``p(g') >= threshold``."""

    infers = True  # the protocol runs goal inference (Eq. 7): view.belief is the posterior
    takes_turns = False  # no autonomy turn: the person never hands over
    # alpha is 0 or weight: the strength (mean alpha where it acts) is weight by construction
    constant_metrics = frozenset({"assistance_strength"})

    def __init__(self, threshold: float = 0.6, weight: float = 0.5) -> None:
        if not 0.0 <= weight <= 1.0:
            raise ValueError(f"weight must lie in [0, 1], got {weight}")
        self.threshold = threshold
        self.weight = weight

    def assist(self, view: StepView) -> Assistance:
        goal = view.leader  # -1 while two or more goals tie for the highest belief
        if goal < 0 or view.leader_probability < self.threshold or not any(view.u_h):
            return Assistance(view.u_h)  # the person's own command, unassisted
        u_a = drive_towards(view, view.goal_poses[goal])
        return Assistance.convex(view.u_h, u_a, self.weight, goal)

    def start_turn(self, view: StepView) -> AutonomyTurn:
        return AutonomyTurn.stay()  # never called: the policy takes no turns
