"""The trial loop's written-out copies of rules owned elsewhere, held to their owners: the entropy
gate in ``PaperBlending.assist`` (``assistance.entropy_gated``), the leader's probability in
``TrialSession._set_belief`` (numpy's ``max``) and ``Assistance.additive``'s float sum (numpy's
``add``)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_sim_protocol import session_of

from nudgecli.config import load_experiment
from nudgecli.model import assistance
from nudgecli.model.interface import NO_COMMAND
from nudgecli.sim.builtin_policies import Disambiguation
from nudgecli.sim.policy_interface import Assistance
from nudgecli.sim.protocol import ProtocolSettings
from nudgecli.sim.study import build_layouts


@pytest.fixture(scope="module")
def paper():
    config = load_experiment("paper")
    return config, ProtocolSettings.from_config(config), build_layouts(config, 11)


@pytest.mark.parametrize("gate", [0.65, 0.3])
def test_the_blending_entropy_gate_is_entropy_gated_at_and_around_kappa(gate: float) -> None:
    protocol = ProtocolSettings.from_config(load_experiment("paper", ["assistance.entropy_gate=true",
                                                                      f"inference.kappa={gate}"]))
    goals = np.array([[40.0, 30.0, 0.0], [5.0, 5.0, 0.0], [70.0, 10.0, 0.0]])
    for entropy in (gate, math.nextafter(gate, 0.0), math.nextafter(gate, 1.0), 0.1, 0.99):
        view = SimpleNamespace(x=30.0, y=20.0, theta=0.0, step=9, goal_poses=goals, leader=0,
                               leader_probability=0.9, entropy=entropy, u_h=NO_COMMAND, initiated_at=2)
        answer = Disambiguation(protocol).assist(view)
        gated = assistance.entropy_gated(entropy, protocol.blending.entropy_gate)
        assert (answer.goal == -1 and answer.alpha == 0.0) == gated, entropy
        assert answer.alpha == (0.0 if gated else 0.8)


values = st.one_of(st.floats(0.0, 1.0), st.just(math.nan), st.just(0.0), st.just(-0.0))


@settings(max_examples=200, deadline=None)
@given(st.integers(3, 3).flatmap(lambda n: st.lists(values, min_size=n, max_size=n)))
def test_the_leaders_probability_is_numpys_max_of_the_belief(paper, belief: list[float]) -> None:
    session = session_of(paper, "disambiguation")
    array = np.array(belief)
    session._set_belief(array)
    expected = float(array.max())
    assert np.array([session.leader_probability]).tobytes() == np.array([expected]).tobytes()


floats = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)
triples = st.tuples(floats, floats, floats)


@settings(max_examples=300, deadline=None)
@given(triples, triples)
def test_an_additive_assistance_of_float_tuples_is_numpys_sum(u_h, u_a) -> None:
    command = Assistance.additive(u_h, u_a, 1).command
    assert type(command) is tuple
    with np.errstate(over="ignore", invalid="ignore"):  # inf - inf, and sums past the largest float
        expected = np.add(u_h, u_a)
    assert np.array(command).tobytes() == expected.tobytes()


@pytest.mark.parametrize(("u_h", "u_a"), [
    ((np.float32(0.1), 0.0, 0.0), (0.2, 0.0, 0.0)),
    ((0.1, 0.0, 0.0), (np.float32(0.2), np.float32(0.3), np.float32(0.4))),
    (np.array([0.1, 0.2, 0.3], dtype=np.float32), np.array([0.2, 0.1, 0.0], dtype=np.float32)),
    ((1, 2, 3), (4, 5, 6)),
    ([0.1, 0.2, 0.3], (0.3, 0.2, 0.1)),
])
def test_an_additive_assistance_of_anything_else_is_numpys_sum_in_its_dtype(u_h, u_a) -> None:
    command = Assistance.additive(u_h, u_a, 0).command
    expected = np.add(u_h, u_a)
    assert isinstance(command, np.ndarray) and command.dtype == expected.dtype
    assert command.tobytes() == expected.tobytes()
