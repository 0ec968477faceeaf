"""The disambiguation metric: p(phi_m | g, s), the distance regulariser, D(s) (Eq. 15) and s*
(Eq. 16), with the settings that choose how they are computed. Mutual information (Eq. 13) is
in :mod:`nudgecli.model.information`, the candidate domains in :mod:`nudgecli.model.candidates`."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Literal

import numpy as np

from nudgecli.model import portable_math
from nudgecli.model.candidates import Candidates, global_candidates, mode_candidates, window_table
from nudgecli.model.disambiguation_settings import DisambiguationSettings
from nudgecli.model.human_actions import DistinctActionRows
from nudgecli.model.inference import predict_belief
from nudgecli.model.information import monte_carlo_mutual_information, normalised_belief
from nudgecli.model.interface import (
    observation_model,
    validate_distortion_table,
    validate_mapping_table,
)
from nudgecli.model.log_terms import xlogy
from nudgecli.model.read_only import read_only_array
from nudgecli.model.ties import first_argmax
from nudgecli.model.world import cell_centre

# --- observation model ------------------------------------------------------------------------

def observation_likelihood(p_a_given_sg: np.ndarray | DistinctActionRows, mapping: np.ndarray,
                           distortion: np.ndarray, modes: np.ndarray | None = None) -> np.ndarray:
    """``p(phi_m | g, s) = sum_a sum_phi_i p(phi_m | phi_i) p(phi_i | a, m(s)) p(a | s, g)``.

    The mode of flat state ``s`` is ``m(s) = s % 3`` on the toolkit's grid, or ``modes[s]``.

    Parameters
    ----------
    p_a_given_sg
        ``(G, S, A)`` the human's action model, or its
        :class:`~nudgecli.model.human_actions.DistinctActionRows` (checked once per layout:
        :attr:`SolvedLayout.actions <nudgecli.model.mdp.SolvedLayout>`).
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)`` (row intended, column measured).
    modes
        ``(S,)`` mode index of every state, for state spaces other than the 2400-state grid
        (``None``: ``s % 3``); only with a table (distinct rows carry their modes).

    Returns
    -------
    np.ndarray
        ``(G, S, F)``; each ``(g, s)`` row sums to 1.

    Raises
    ------
    ProbabilityTableError
        If a table has the wrong shape, a negative entry or a row not summing to 1 (naming it).
    """
    actions = _distinct_rows(p_a_given_sg, modes)
    return _distinct_likelihood(actions, mapping, distortion).take(actions.index, axis=0)


def _distinct_rows(p_a_given_sg: np.ndarray | DistinctActionRows,
                   modes: np.ndarray | None = None) -> DistinctActionRows:
    if isinstance(p_a_given_sg, DistinctActionRows):
        if modes is not None:
            raise ValueError("distinct action rows carry their states' modes; pass modes with a table only")
        return p_a_given_sg
    return DistinctActionRows.of(p_a_given_sg, modes)


def _distinct_likelihood(actions: DistinctActionRows, mapping: np.ndarray,
                         distortion: np.ndarray) -> np.ndarray:
    """``(U, F)`` ``p(phi_m | a-row, mode)`` of each distinct ``(mode, row)`` pair: the rows of
    :func:`observation_likelihood`, each computed once (``actions.index`` spreads them)."""
    return _rows_likelihood(actions.rows, actions.row_modes, mapping, distortion)


def _rows_likelihood(rows: np.ndarray, row_modes: np.ndarray, mapping: np.ndarray,
                     distortion: np.ndarray) -> np.ndarray:
    """``(U, F)`` ``p(phi_m | row, mode)`` of ``(U, A)`` action rows in their ``(U,)`` modes."""
    measured_given_action = _measured_given_action(mapping, distortion)  # (M, A, F)
    # (U, 1, A) @ (U, A, F) -> (U, 1, F): per pair the same (1, A) @ (A, F) product as per state,
    # whichever other rows are stacked with it (DisambiguationModel.of_layouts stacks layouts')
    return portable_math.matmul(rows[:, None, :], measured_given_action[row_modes])[:, 0, :]


def _measured_given_action(mapping: np.ndarray, distortion: np.ndarray) -> np.ndarray:
    """``(M, A, F)`` :func:`observation_model` of the validated tables (read-only): made once per
    process for each pair of tables, which a participant's models of all their layouts share."""
    m, d = np.asarray(mapping, dtype=float), np.asarray(distortion, dtype=float)
    return _measured_given_action_of(m.shape, m.tobytes(), d.shape, d.tobytes())


@lru_cache(maxsize=256)
def _measured_given_action_of(mapping_shape: tuple[int, ...], mapping: bytes,
                              distortion_shape: tuple[int, ...], distortion: bytes) -> np.ndarray:
    table = observation_model(validate_mapping_table(np.frombuffer(mapping).reshape(mapping_shape)),
                              validate_distortion_table(np.frombuffer(distortion).reshape(distortion_shape)))
    table.setflags(write=False)
    return table


def _checked_layout(goal_cells: np.ndarray,
                    p_a_given_sg: np.ndarray | DistinctActionRows) -> tuple[np.ndarray, DistinctActionRows]:
    """A layout's ``(G, 2)`` int goal cells and distinct action rows, of as many goals."""
    cells = np.asarray(goal_cells, dtype=int).reshape(-1, 2)
    actions = _distinct_rows(p_a_given_sg)
    if actions.index.shape[0] != cells.shape[0]:
        raise ValueError(f"{cells.shape[0]} goal cells but p(a | s, g) has {actions.index.shape[0]} goals")
    return cells, actions


# --- distance regulariser and D(s) --------------------------------------------------------------

def _distance(weights: np.ndarray, goals: np.ndarray, positions: np.ndarray, kind: str) -> np.ndarray:
    if kind == "expected":
        dx = positions[:, 0:1] - goals[:, 0]
        dy = positions[:, 1:2] - goals[:, 1]
        return portable_math.matmul(np.sqrt(dx * dx + dy * dy), weights)
    if kind == "to_mean":
        mean = portable_math.matmul(weights, goals)
        dx = positions[:, 0] - mean[0]
        dy = positions[:, 1] - mean[1]
        return np.sqrt(dx * dx + dy * dy)
    raise ValueError(f"distance kind must be 'expected' or 'to_mean', got {kind!r}")


def distance_regulariser(belief: np.ndarray, goal_positions: np.ndarray, positions: np.ndarray,
                         kind: Literal["expected", "to_mean"] = "expected") -> np.ndarray:
    """``R(s)``: how far candidate positions are from the goals under the belief.

    Parameters
    ----------
    belief
        ``(G,)`` belief (normalised here).
    goal_positions
        ``(G, 2)`` goal positions, in the same unit as ``positions``.
    positions
        ``(C, 2)`` candidate positions ``q(s)``.
    kind
        ``"expected"``: ``sum_g b_g ||g - q(s)||``; ``"to_mean"``: ``||q(s) - sum_g b_g g||``.

    Returns
    -------
    np.ndarray
        ``(C,)``.
    """
    b = normalised_belief(belief)
    goals = np.asarray(goal_positions, dtype=float).reshape(-1, 2)
    if goals.shape[0] != b.size:
        raise ValueError(f"{goals.shape[0]} goal positions for a belief over {b.size} goals")
    return _distance(b, goals, np.asarray(positions, dtype=float).reshape(-1, 2), kind)


@dataclass(frozen=True, eq=False)
class DisambiguationModel:
    """What D(s) needs about one layout and one participant model, computed once per trial.

    Construct it with the four inputs; the tables are validated and the rest is derived.
    ``p_a_given_sg`` may be given as the layout's :class:`~nudgecli.model.human_actions.DistinctActionRows`
    (``SolvedLayout.actions``), checked once per layout rather than once per model.

    Attributes
    ----------
    goal_cells
        ``(G, 2)`` goal cells.
    p_a_given_sg
        ``(G, S, A)`` the human action model (the table, whichever form it was given in).
    mapping
        ``(M, A, F)`` ``p(phi_i | a, m)``.
    distortion
        ``(F, F)`` ``p(phi_m | phi_i)``.
    likelihood
        ``(G, S, F)`` ``p(phi_m | g, s)`` (derived on first use; the protocol reads single states
        through :meth:`label_likelihood` and D(s) its candidates', so a trial never builds it).
    """

    goal_cells: np.ndarray
    p_a_given_sg: np.ndarray | DistinctActionRows
    mapping: np.ndarray
    distortion: np.ndarray
    # Every derived table is a gather of the layout's distinct rows (bit for bit the per-state
    # ones): the (U, F) distinct likelihoods, their (U,) sum_f p log p (the belief-independent half
    # of Eq. 13), and the (G, S) index into them.
    _distinct: np.ndarray = field(init=False, repr=False)
    _xlogx_distinct: np.ndarray = field(init=False, repr=False)
    _index: np.ndarray = field(init=False, repr=False)
    _goal_positions: dict[str, np.ndarray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        cells, actions = _checked_layout(self.goal_cells, self.p_a_given_sg)
        distinct = _distinct_likelihood(actions, self.mapping, self.distortion)  # (U, F)
        self._set(cells, actions, self.mapping, self.distortion, distinct,
                  xlogy(distinct, distinct).sum(axis=-1), cell_centre(cells[:, 0], cells[:, 1]))

    def _set(self, cells: np.ndarray, actions: DistinctActionRows, mapping: np.ndarray,
             distortion: np.ndarray, distinct: np.ndarray, xlogx_distinct: np.ndarray,
             world_goals: np.ndarray) -> None:
        """Set every field: ``(G, 2)`` int cells, ``(U, F)`` distinct likelihoods, their ``(U,)``
        ``sum_f p log p`` and the ``(G, 2)`` goals' cell centres."""
        set_ = object.__setattr__  # frozen dataclass: derived fields are set once, here
        # read-only: a policy's view reaches the model, whose arrays a participant's trials share
        # (and the solved layout's action table, every participant's in the worker)
        fixed = read_only_array
        set_(self, "goal_cells", fixed(cells))
        set_(self, "p_a_given_sg", fixed(actions.table))
        set_(self, "mapping", fixed(np.asarray(mapping, dtype=float)))
        set_(self, "distortion", fixed(np.asarray(distortion, dtype=float)))
        set_(self, "_distinct", fixed(distinct))
        set_(self, "_xlogx_distinct", fixed(xlogx_distinct))
        set_(self, "_index", fixed(actions.index))
        set_(self, "_goal_positions", {"cells": fixed(cells.astype(float)), "world": fixed(world_goals)})

    @classmethod
    def of_layouts(cls, goal_cells: Sequence[np.ndarray],
                   p_a_given_sg: Sequence[np.ndarray | DistinctActionRows], mapping: np.ndarray,
                   distortion: np.ndarray) -> list[DisambiguationModel]:
        """One participant model's :class:`DisambiguationModel` of each of several layouts.

        ``[DisambiguationModel(c, p, mapping, distortion) for c, p in zip(goal_cells, p_a_given_sg)]``,
        the same arrays bit for bit, with each numpy step taken once for all the layouts' rows
        stacked (row by row the same products, logs and sums): a participant's 48 models took
        about 2.4 ms one at a time, interleaved with their trials.

        Parameters
        ----------
        goal_cells
            ``L`` layouts' ``(G_l, 2)`` goal cells.
        p_a_given_sg
            ``L`` layouts' ``(G_l, S, A)`` action models (or their distinct rows).
        mapping, distortion
            The participant model's ``(M, A, F)`` and ``(F, F)`` tables.

        Returns
        -------
        list
            ``L`` models, in the layouts' order.
        """
        if len(goal_cells) != len(p_a_given_sg):
            raise ValueError(f"{len(goal_cells)} layouts' goal cells but {len(p_a_given_sg)} action models")
        layouts = [_checked_layout(cells, actions)
                   for cells, actions in zip(goal_cells, p_a_given_sg, strict=True)]
        if not layouts:
            return []
        rows = np.concatenate([actions.rows for _, actions in layouts])
        distinct = _rows_likelihood(rows, np.concatenate([actions.row_modes for _, actions in layouts]),
                                    mapping, distortion)
        xlogx_distinct = xlogy(distinct, distinct).sum(axis=-1)
        all_cells = np.concatenate([cells for cells, _ in layouts])
        world_goals = cell_centre(all_cells[:, 0], all_cells[:, 1])
        row_ends = np.cumsum([actions.rows.shape[0] for _, actions in layouts]).tolist()
        goal_ends = np.cumsum([cells.shape[0] for cells, _ in layouts]).tolist()
        models = []
        for (cells, actions), row_end, goal_end in zip(layouts, row_ends, goal_ends, strict=True):
            row_start, goal_start = row_end - actions.rows.shape[0], goal_end - cells.shape[0]
            model = cls.__new__(cls)  # the fields set as __post_init__ sets them, of the stacked arrays
            model._set(cells, actions, mapping, distortion, distinct[row_start:row_end],
                       xlogx_distinct[row_start:row_end], world_goals[goal_start:goal_end])
            models.append(model)
        return models

    @cached_property
    def likelihood(self) -> np.ndarray:
        """``(G, S, F)`` ``p(phi_m | g, s)``: every state's table at once (read-only: it is cached
        on the model a participant's trials share, and a policy's view reaches it)."""
        return read_only_array(self._distinct.take(self._index, axis=0))

    def label_likelihood(self, state: int, label: int) -> np.ndarray:
        """``(G,)`` ``p(phi_m = label | g, state)``: ``likelihood[:, state, label]``'s values."""
        return self._distinct[self._index[:, state], label]

    @property
    def n_goals(self) -> int:
        return int(self.goal_cells.shape[0])

    def goal_positions(self, unit: Literal["cells", "world"]) -> np.ndarray:
        """``(G, 2)`` goal positions: cell indices (``"cells"``) or cell centres (``"world"``)."""
        return self._goal_positions[unit]

    def candidates(self, current_state: int, settings: DisambiguationSettings,
                   robot_position: np.ndarray | None = None) -> Candidates:
        """The candidates of ``settings.domain`` for this layout
        (:func:`~nudgecli.model.candidates.window_candidates` or :func:`global_candidates`, or
        :func:`mode_candidates` for the mode-only scope); the layout's window table is built once."""
        if settings.scope == "mode-only":
            return mode_candidates(current_state, robot_position)
        if settings.domain == "global":
            return global_candidates(self.goal_cells, settings.rotation_gate)
        table = window_table(self.goal_cells, settings.window)
        return table.candidates(current_state, robot_position, settings.rotation_gate)

    def mutual_information(self, weights: np.ndarray, states: np.ndarray) -> np.ndarray:
        """Exact Eq. 13 at ``states``: the value of :func:`mutual_information`, from the
        precomputed tables.

        Parameters
        ----------
        weights
            ``(G,)`` normalised goal weights (already propagated through any goal transition).
        states
            ``(C,)`` flat state indices.

        Returns
        -------
        np.ndarray
            ``(C,)`` in nats.
        """
        rows_of = self._index.take(states, axis=1).T  # (C, G) indices into the distinct rows
        # sum_g w_g p(f | g, s), the goals added in turn (numpy's add over a leading axis, as
        # portable_math.matmul's): the product with kron(w, I_F) gave these bits, its other terms
        # exact zeros, at four times the work (tests/test_model_disambiguation.py holds the two equal)
        marginal = (self._distinct.take(rows_of, axis=0) * weights[:, None]).sum(axis=1)  # (C, F)
        conditional = portable_math.matmul(self._xlogx_distinct.take(rows_of), weights)  # (C,)
        return np.maximum(conditional - xlogy(marginal, marginal).sum(axis=-1), 0.0)


@dataclass(frozen=True)
class DisambiguationScores:
    """D(s) and its two terms over a candidate set.

    Attributes
    ----------
    information
        ``(C,)`` ``I(s)`` in nats (exact or estimated).
    distance
        ``(C,)`` ``R(s)``.
    score
        ``(C,)`` ``D(s) = w_I I(s) - lambda R(s)``.
    """

    information: np.ndarray
    distance: np.ndarray
    score: np.ndarray


def disambiguation_scores(belief: np.ndarray, model: DisambiguationModel, candidates: Candidates,
                          settings: DisambiguationSettings | None = None,
                          rng: np.random.Generator | None = None,
                          goal_transition: np.ndarray | None = None) -> DisambiguationScores:
    """``D(s) = w_I I(s) - lambda R(s)`` (Eq. 15 and its study variant) for every candidate.

    Parameters
    ----------
    belief
        ``(G,)`` belief.
    model
        The layout's :class:`DisambiguationModel`.
    candidates
        From :meth:`DisambiguationModel.candidates` (or the functions of :mod:`nudgecli.model.candidates`).
    settings
        Paper defaults when ``None``.
    rng
        Required by the Monte-Carlo estimator.
    goal_transition
        ``(G, G)`` row-stochastic ``p(g_t | g_{t-1})`` of Eq. 13 (``None``: the identity). The
        distance term uses the belief itself, as in Eq. 15.

    Returns
    -------
    DisambiguationScores
    """
    settings = settings or DisambiguationSettings()
    b = normalised_belief(belief)
    if b.size != model.n_goals:
        raise ValueError(f"belief over {b.size} goals for a layout with {model.n_goals}")
    weights = b if goal_transition is None else predict_belief(b, goal_transition)
    if settings.estimator == "exact":
        information = model.mutual_information(weights, candidates.states)
    else:
        if rng is None:
            raise ValueError("the Monte-Carlo estimator needs an rng (np.random.Generator)")
        table = np.asarray(model.p_a_given_sg)  # dense once the model is built
        information = monte_carlo_mutual_information(weights, candidates.states, table,
                                                     model.mapping, model.distortion, rng,
                                                     settings.samples, settings.weighting)
    positions = candidates.cells if settings.distance_unit == "cells" else candidates.positions
    distance = _distance(b, model.goal_positions(settings.distance_unit), positions, settings.distance)
    score = settings.mi_weight * information - settings.distance_weight * distance
    return DisambiguationScores(information=information, distance=distance, score=score)


@dataclass(frozen=True)
class DisambiguationChoice:
    """The maximally disambiguating state and how it was chosen.

    Attributes
    ----------
    state
        Flat index of s*.
    index
        Position of s* in ``candidates``.
    candidates
        The candidate set searched.
    scores
        D(s) and its terms over the candidates.
    """

    state: int
    index: int
    candidates: Candidates
    scores: DisambiguationScores


def maximally_disambiguating_state(belief: np.ndarray, model: DisambiguationModel, current_state: int,
                                   settings: DisambiguationSettings | None = None,
                                   robot_position: np.ndarray | None = None,
                                   rng: np.random.Generator | None = None,
                                   goal_transition: np.ndarray | None = None) -> DisambiguationChoice:
    """``s* = argmax_s D(s)`` over the settings' domain (Eq. 16), first on ties.

    Parameters
    ----------
    belief
        ``(G,)`` belief.
    model
        The layout's :class:`DisambiguationModel`.
    current_state
        Flat index of the robot's discrete state.
    settings
        Paper defaults when ``None``.
    robot_position
        ``(2,)`` continuous robot position (world-unit distances and the rotation gate).
    rng
        Required by the Monte-Carlo estimator.
    goal_transition
        See :func:`disambiguation_scores`.

    Returns
    -------
    DisambiguationChoice

    Raises
    ------
    ValueError
        If the domain holds no candidate.
    """
    settings = settings or DisambiguationSettings()
    candidates = model.candidates(current_state, settings, robot_position)
    if candidates.states.size == 0:
        raise ValueError(f"no candidate state around state {current_state}")
    scores = disambiguation_scores(belief, model, candidates, settings, rng, goal_transition)
    index = int(first_argmax(scores.score))
    return DisambiguationChoice(state=int(candidates.states[index]), index=index, candidates=candidates,
                                scores=scores)
