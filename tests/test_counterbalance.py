"""Counterbalancing k conditions: the Williams property by brute force, the paper's rotation kept."""

from __future__ import annotations

import itertools

import pytest

from nudgecli.config import experiment_from_toml, load_experiment
from nudgecli.errors import ConfigError
from nudgecli.sim.counterbalance import condition_orders, design_record, participant_order, williams_square
from nudgecli.sim.study import build_layouts, participant_schedule


def adjacent_pair_counts(orders: list[list[int]], k: int) -> dict[tuple[int, int], int]:
    """How often each ordered pair (a, b), a != b, appears with a immediately before b."""
    counts = dict.fromkeys(itertools.permutations(range(k), 2), 0)
    for row in orders:
        for a, b in itertools.pairwise(row):
            counts[(a, b)] += 1
    return counts


@pytest.mark.parametrize("k", [2, 4, 6, 8])
def test_the_williams_square_is_latin_and_each_condition_precedes_each_other_once(k):
    square = williams_square(k)
    assert len(square) == k
    for row in square:
        assert sorted(row) == list(range(k))
    for column in zip(*square, strict=True):
        assert sorted(column) == list(range(k))
    assert set(adjacent_pair_counts(square, k).values()) == {1}


@pytest.mark.parametrize("k", [3, 5, 7])
def test_the_pair_of_squares_balances_an_odd_count_twice_over(k):
    orders = condition_orders(k, "williams-pair")
    assert len(orders) == 2 * k
    for row in orders:
        assert sorted(row) == list(range(k))
    for column in zip(*orders, strict=True):  # each condition in each position twice
        assert sorted(column) == sorted(list(range(k)) * 2)
    assert set(adjacent_pair_counts(orders, k).values()) == {2}


@pytest.mark.parametrize("k", [3, 5])
def test_one_square_cannot_balance_an_odd_count(k):
    # brute force: no k x k Latin square of the small odd k has every ordered pair adjacent once
    if k == 3:
        rows = list(itertools.permutations(range(k)))
        balanced = [s for s in itertools.combinations(rows, k)
                    if all(sorted(c) == list(range(k)) for c in zip(*s, strict=True))
                    and set(adjacent_pair_counts([list(r) for r in s], k).values()) == {1}]
        assert balanced == []
    with pytest.raises(ConfigError, match="cannot balance"):
        williams_square(k)


def test_two_conditions_keep_the_papers_rotation():
    conditions = ["disambiguation", "control"]
    for participant in range(12):
        shift = participant % 2  # the paper's rotation (the rule this design replaced)
        rotation = conditions[shift:] + conditions[:shift]
        for design in ("williams", "rotation"):
            assert participant_order(conditions, design, participant) == rotation
    flipped = participant_order(conditions, "williams", 4, condition_order=["control", "disambiguation"])
    assert flipped == ["control", "disambiguation"]


def test_the_schedule_runs_the_blocks_in_the_participants_order():
    config = experiment_from_toml(
        '[study]\nconditions = ["disambiguation", "control", "teleoperation", "blending"]\n'
        'goal_counts = [3]\ncorners = ["tr"]\nstart_modes = ["x", "y", "theta"]\nblocks_per_condition = 3\n'
        '[blending]\ngate = "gap"\n')
    layouts = build_layouts(config, 3)
    for participant in range(8):
        schedule = participant_schedule(config, 3, participant, layouts)
        blocks = [spec.condition for spec in schedule]  # one trial per block here
        order = participant_order(list(config.study.conditions), "williams", participant)
        assert blocks == [c for _ in range(3) for c in order]


def test_the_papers_schedule_is_unchanged():
    config = load_experiment("paper")
    layouts = build_layouts(config, 2022)
    for participant in range(4):
        first = participant_schedule(config, 2022, participant, layouts)[0].condition
        assert first == ("disambiguation", "control")[participant % 2]


def test_the_record_says_whether_the_count_balances_the_design():
    conditions = ["a", "b", "c", "d"]
    assert design_record(conditions, "williams", 8)["balanced"]
    record = design_record(conditions, "williams", 6)
    assert not record["balanced"] and record["participant_orders"]["5"] == record["orders"][1]


def test_the_orders_are_the_documented_constructions_by_hand():
    # Williams: first row 0, 1, k-1, 2, k-2, ...; row r adds r (mod k). Rotation: cyclic shifts of 0..k-1
    assert williams_square(4) == [[0, 1, 3, 2], [1, 2, 0, 3], [2, 3, 1, 0], [3, 0, 2, 1]]
    assert williams_square(6)[0] == [0, 1, 5, 2, 4, 3]
    assert condition_orders(3, "williams-pair") == [[0, 1, 2], [1, 2, 0], [2, 0, 1],
                                                    [2, 1, 0], [0, 2, 1], [1, 0, 2]]
    assert condition_orders(3, "rotation") == [[0, 1, 2], [1, 2, 0], [2, 0, 1]]


def test_participants_cycle_through_every_order_of_the_pair_of_squares():
    conditions = ["a", "b", "c"]
    orders = condition_orders(3, "williams-pair")
    for participant in range(12):  # 6 orders: participants 3-5 take the mirrored rows
        expected = [conditions[c] for c in orders[participant % 6]]
        assert participant_order(conditions, "williams-pair", participant) == expected
    assert participant_order(conditions, "williams-pair", 4) == ["a", "c", "b"]
