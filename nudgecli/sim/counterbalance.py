"""The order of the conditions per participant: balanced Latin squares (Williams designs).

A Williams design (Williams, 1949, "Experimental designs balanced for the estimation of residual
effects of treatments") is a Latin square in which every condition immediately precedes every
other condition exactly once, so first-order carry-over is balanced. For an even number ``k`` of
conditions one ``k x k`` square does it: its first row is ``0, 1, k-1, 2, k-2, 3, ...`` and row
``r`` adds ``r`` (mod ``k``) to every entry. For an odd ``k`` no such single square exists for
the small ``k`` of a study (3, 5, 7); the standard remedy is the pair of squares: the square
built the same way and its mirror (every row reversed), ``2k`` orders in which every condition
precedes every other exactly twice.

With two conditions, the Williams square is ``[0, 1], [1, 0]``: participant ``i`` starting with
condition ``i mod 2``, the paper's rotation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from nudgecli.errors import ConfigError

#: The designs ``[study] counterbalancing`` may name.
DESIGNS = ("williams", "williams-pair", "rotation")


def williams_first_row(k: int) -> list[int]:
    """``0, 1, k-1, 2, k-2, ...``: the first row of the Williams square of ``k`` conditions."""
    row = [0]
    low, high = 1, k - 1
    for position in range(1, k):
        if position % 2:
            row.append(low)
            low += 1
        else:
            row.append(high)
            high -= 1
    return row


def williams_square(k: int) -> list[list[int]]:
    """The ``k x k`` Williams square: row ``r`` is the first row plus ``r`` (mod ``k``).

    Raises
    ------
    ConfigError
        ``k`` is odd (one square cannot balance it; use :func:`condition_orders` with
        ``williams-pair``) or below 2.
    """
    if k < 2:
        raise ConfigError(f"a Latin square of conditions needs at least 2 conditions, got {k}")
    if k % 2:
        raise ConfigError(f"one Williams square cannot balance {k} conditions (an odd count); use "
                          "counterbalancing = 'williams-pair' or an even number of conditions")
    first = williams_first_row(k)
    return [[(c + r) % k for c in first] for r in range(k)]


def condition_orders(k: int, design: str) -> list[list[int]]:
    """The condition orders (indices into the conditions list) a design cycles through.

    Parameters
    ----------
    k
        Number of conditions.
    design
        ``williams`` (one square, even ``k``), ``williams-pair`` (the square and its mirror:
        ``2k`` orders, any ``k``) or ``rotation`` (``k`` cyclic shifts).

    Returns
    -------
    list of list of int
    """
    if design == "rotation":
        return [[(r + c) % k for c in range(k)] for r in range(k)]
    if design == "williams":
        return williams_square(k)
    if design == "williams-pair":
        if k < 2:
            raise ConfigError(f"a Latin square of conditions needs at least 2 conditions, got {k}")
        first = williams_first_row(k)
        square = [[(c + r) % k for c in first] for r in range(k)]
        return square + [row[::-1] for row in square]
    raise ConfigError(f"unknown counterbalancing design {design!r}; use one of {', '.join(DESIGNS)}")


def participant_order(conditions: Sequence[str], design: str, participant: int,
                      condition_order: Sequence[str] | None = None) -> list[str]:
    """Participant ``participant``'s condition order: order ``participant mod n_orders`` of the
    design, or ``condition_order`` (a live session's ``--condition-order``), which must be one of
    the design's orders (:func:`check_design_order`)."""
    if condition_order is not None:
        return check_design_order(conditions, design, condition_order)
    orders = condition_orders(len(conditions), design)
    return [conditions[c] for c in orders[participant % len(orders)]]


def check_design_order(conditions: Sequence[str], design: str, condition_order: Sequence[str]) -> list[str]:
    """``condition_order`` as a list, when it is one of the orders the design assigns.

    Raises
    ------
    ConfigError
        The order is not one of the design's (the message lists them).
    """
    named = [[conditions[c] for c in row] for row in condition_orders(len(conditions), design)]
    order = list(condition_order)
    if order not in named:
        raise ConfigError(f"{','.join(order)} is not one of the orders of counterbalancing = '{design}' "
                          f"({'; '.join(','.join(row) for row in named)})")
    return order


def order_choice(conditions: Sequence[str], design: str, participant: int,
                 condition_order: Sequence[str]) -> str | None:
    """The ``--condition-order`` value that gives participant ``participant`` ``condition_order``
    (comma-joined), or ``None`` when it is the order the design assigns them by itself."""
    if list(condition_order) == participant_order(conditions, design, participant):
        return None
    return ",".join(condition_order)


def recorded_order_choice(experiment: object, participant: int, recorded: object) -> str | None:
    """:func:`order_choice` of an order a run's manifest records for a participant (``experiment``:
    the manifest's ``config``); ``None`` when none is recorded, the recorded order itself when the
    recorded design cannot tell (a damaged manifest)."""
    study = experiment.get("study") if isinstance(experiment, Mapping) else None
    if not isinstance(recorded, list) or not isinstance(study, Mapping) or not study.get("conditions"):
        return None
    order = [str(name) for name in recorded]
    try:
        return order_choice([str(c) for c in study["conditions"]], str(study.get("counterbalancing")),
                            participant, order)
    except (ConfigError, TypeError, IndexError):
        return ",".join(order)


def design_record(conditions: Sequence[str], design: str, participants: int) -> dict[str, object]:
    """The manifest's ``counterbalancing`` entry: the design, its orders, each participant's order,
    and whether the participant count balances it (a multiple of the number of orders)."""
    orders = condition_orders(len(conditions), design)
    return {
        "design": design,
        "orders": [[conditions[c] for c in row] for row in orders],
        "participant_orders": {str(i): [conditions[c] for c in orders[i % len(orders)]]
                               for i in range(participants)},
        "balanced": participants % len(orders) == 0,
    }
