"""The readings of the paper's validation paragraph, side by side.

The paper (end of section 3.3): "For a local neighborhood of each s in S, we computed s* using
Eq. 16 and compared it to a ground truth that was computed by picking the state in the same
neighborhood that provided maximum expected difference between first and second maxima of
b_g^t over a single timestep. We ran a total of 100 simulations for |G| ranging from 3 to 30
and |S| = 200, and the match percentage was 100%." It leaves open the world, the belief the
queries use, lambda, what the expectation is taken under, and what counts as a match. Each
:class:`Reading` fixes one choice of each; ``nudge validate --reading NAME`` runs one,
``--all-readings`` all of them on the same worlds.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal

from nudgecli.errors import ConfigError, did_you_mean

World = Literal["two-mode", "three-mode"]
Belief = Literal["dirichlet", "two-goal"]
Truth = Literal["top-two-gap", "entropy-drop"]
Expectation = Literal["belief", "true-goal"]
Match = Literal["same-state", "reaches-maximum"]

#: The share of the belief that the goals outside the pair keep in the two-goal reading.
TWO_GOAL_REST = 0.01
#: The two goals' split in the two-goal reading: the larger share is uniform in this range.
TWO_GOAL_SPLIT = (0.5, 0.75)


@dataclass(frozen=True)
class Reading:
    """One reading of the validation paragraph.

    Attributes
    ----------
    name
        What ``--reading`` takes.
    summary
        One line: what this reading changes.
    world
        ``two-mode``: the paper's ``|S| = 200`` (a 10 x 10 grid, modes x and y); ``three-mode``:
        the study's 2400-state world (10 x 10 cells, 8 headings, 3 modes).
    belief
        The query beliefs: ``dirichlet`` (``Dirichlet(c)`` over all goals) or ``two-goal`` (split
        between two random goals, the situation of the paper's Fig. 5).
    truth
        The ground truth: ``top-two-gap`` (the paper's words) or ``entropy-drop`` (the expected
        one-step fall of the belief's entropy).
    expectation
        What the one-step expectation is taken under: ``belief`` (``p(phi_m | s)``) or
        ``true-goal`` (``p(phi_m | g*, s)``, the true goal drawn from the belief).
    regularisation
        lambda of Eq. 16 (distance in grid cells); 0 compares the information term alone.
    match
        ``same-state``: s* is the ground truth's first argmax; ``reaches-maximum``: s* attains
        the ground truth's maximum (within the tie tolerance).
    by_construction
        Why the match rate is 100 % whatever the world, or ``""`` when it is an empirical result.
    """

    name: str
    summary: str
    world: World = "two-mode"
    belief: Belief = "dirichlet"
    truth: Truth = "top-two-gap"
    expectation: Expectation = "belief"
    regularisation: float = 0.0
    match: Match = "same-state"
    by_construction: str = ""

    def describe(self) -> dict[str, Any]:
        """The reading as JSON-ready values."""
        return asdict(self)


READINGS: dict[str, Reading] = {r.name: r for r in (
    Reading("dirichlet", "the default: Dirichlet beliefs, lambda = 0, the paper's gap under the belief, "
                         "same state"),
    Reading("two-goal", "beliefs split between two goals (the situation of Fig. 5)", belief="two-goal"),
    Reading("true-goal", "the expectation taken under the true goal's labels instead of the belief's",
            expectation="true-goal"),
    Reading("lambda-1", "Eq. 16 literally: D(s) = I(s) - 1 * sum_g b_g ||g - q(s)|| (grid cells)",
            regularisation=1.0),
    Reading("reaches-maximum", "a match when s* reaches the ground truth's maximum (ties count)",
            match="reaches-maximum"),
    Reading("three-mode", "the study's world: 10 x 10 cells x 8 headings x 3 modes, the model's window",
            world="three-mode"),
    Reading("entropy-drop", "ground truth: the expected one-step fall of the belief's entropy",
            truth="entropy-drop",
            by_construction="the expected one-step entropy fall H(b) - E[H(b')] is the mutual information "
                            "I(s) itself, so with lambda = 0 both criteria rank the candidates identically; "
                            "only last-bit differences inside the tie tolerance could split them"),
)}


def get_reading(name: str) -> Reading:
    """The reading called ``name``, or a :class:`ConfigError` naming the known ones."""
    if name not in READINGS:
        raise ConfigError(f"--reading {name!r} is not a reading{did_you_mean(name, list(READINGS))}; "
                          f"choose from {', '.join(READINGS)}")
    return READINGS[name]


__all__ = ["READINGS", "TWO_GOAL_REST", "TWO_GOAL_SPLIT", "Reading", "get_reading"]
