"""The human's action model the agent assumes: ε-greedy around a goal's optimal policy (Eq. 1).

``p(a | s, g) = (1 - ε) onehot(pi_g(s)) + ε / A`` (:func:`action_likelihood`), and the table's
distinct ``(mode, row)`` pairs (:class:`DistinctActionRows`), over which anything computed per row
and mode (``p(phi_m | g, s)``, Eq. 12) is computed once and gathered.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from nudgecli.errors import ProbabilityTableError
from nudgecli.model.interface import N_ACTIONS
from nudgecli.model.world import N_MODES

#: The human's sub-optimality ε of Eq. 1.
DEFAULT_HUMAN_EPSILON = 0.1


def action_likelihood(policy: np.ndarray, epsilon: float = DEFAULT_HUMAN_EPSILON,
                      n_actions: int = N_ACTIONS) -> np.ndarray:
    """ε-greedy ``p(a | s, g) = (1 - eps) onehot(pi_g(s)) + eps / A`` (Eq. 1).

    Parameters
    ----------
    policy
        ``(G, S)`` int greedy actions.
    epsilon
        Probability of a uniformly random action; 0.1 gives 0.925 / 0.025.
    n_actions
        Number of actions ``A``.

    Returns
    -------
    np.ndarray
        ``(G, S, A)``; each row sums to 1.
    """
    if not 0.0 <= epsilon <= 1.0:
        raise ValueError(f"epsilon must be in [0, 1], got {epsilon}")
    # the A possible rows, each the formula of a one-hot row, gathered: the same values as the
    # formula applied to the (G, S, A) one-hot table (0.44 ms a 3-goal layout, against 0.07 ms)
    rows = (1.0 - epsilon) * np.eye(n_actions) + epsilon / n_actions
    return rows[np.asarray(policy, dtype=int)]


@dataclass(frozen=True, eq=False)
class DistinctActionRows:
    """A checked ``p(a | s, g)`` table and its distinct ``(mode, row)`` pairs.

    Anything computed per row and mode (``p(phi_m | g, s)``, Eq. 12) is computed once per pair and
    gathered: an ε-greedy table has one distinct row per action (and mode), against ``G x S`` rows.
    Rows count as the same when their bytes are, so a gathered result is bit for bit what the
    computation gives on every row.

    Attributes
    ----------
    table
        ``(G, S, A)`` the table, checked: every row finite, non-negative and summing to 1.
    rows
        ``(U, A)`` its distinct rows (one per distinct pair).
    row_modes
        ``(U,)`` the mode of each pair.
    index
        ``(G, S)`` the pair of each goal and state: ``table[g, s] == rows[index[g, s]]``.
    """

    table: np.ndarray
    rows: np.ndarray
    row_modes: np.ndarray
    index: np.ndarray

    @classmethod
    def of(cls, p_a_given_sg: np.ndarray, modes: np.ndarray | None = None,
           name: str = "p(a | s, g)") -> DistinctActionRows:
        """Check ``p_a_given_sg`` and find its distinct ``(mode, row)`` pairs.

        Parameters
        ----------
        p_a_given_sg
            ``(G, S, A)`` the human's action model.
        modes
            ``(S,)`` mode of every state (``None``: ``s % 3``, the toolkit's grid).
        name
            The table's name in error messages.

        Raises
        ------
        ProbabilityTableError
            If the table has the wrong shape or a row that is not a distribution (naming the first).
        """
        table = np.asarray(p_a_given_sg, dtype=float)
        if table.ndim != 3 or table.shape[2] != N_ACTIONS:
            raise ProbabilityTableError(f"{name}: expected shape (G, S, {N_ACTIONS}), got {table.shape}")
        n_goals, n_states, n_actions = table.shape
        modes = np.arange(n_states) % N_MODES if modes is None else np.asarray(modes, dtype=int)
        if modes.shape != (n_states,):
            raise ValueError(f"modes must have shape ({n_states},), got {modes.shape}")
        # one record per goal and state: its mode, then its row; unique on the records' bytes
        keyed = np.empty((n_goals, n_states, n_actions + 1))
        keyed[:, :, 0] = modes
        keyed[:, :, 1:] = table
        records = keyed.reshape(-1).view(np.dtype((np.void, keyed.itemsize * (n_actions + 1))))
        distinct, index = np.unique(records, return_inverse=True)
        pairs = distinct.view(float).reshape(-1, n_actions + 1)
        rows = pairs[:, 1:]
        bad = (~np.isfinite(rows).all(axis=-1) | (rows < 0).any(axis=-1)
               | (np.abs(rows.sum(axis=-1) - 1.0) > 1e-6))
        index = index.reshape(n_goals, n_states)
        if bad.any():
            g, s = (int(k) for k in np.argwhere(bad[index])[0])  # the first bad row in table order
            raise ProbabilityTableError(f"{name}: row (goal {g}, state {s}) = {table[g, s].tolist()} "
                                        "is not a probability distribution")
        return cls(table=table, rows=np.ascontiguousarray(rows), row_modes=pairs[:, 0].astype(int),
                   index=index)

    @classmethod
    def of_policy(cls, policy: np.ndarray, epsilon: float,
                  modes: np.ndarray | None = None) -> DistinctActionRows:
        """:meth:`of` the ε-greedy table of ``policy`` (:func:`action_likelihood`), the same arrays.

        An ε-greedy row is fixed by its greedy action, so the table's distinct ``(mode, row)`` pairs
        are those of the ``(mode, action)`` pairs that occur (at most 12): :meth:`of` sorts those
        few instead of the ``G x S`` rows.

        Parameters
        ----------
        policy
            ``(G, S)`` int greedy actions.
        epsilon
            The ε of Eq. 1.
        modes
            ``(S,)`` mode of every state (``None``: ``s % 3``, the toolkit's grid).
        """
        policy = np.asarray(policy, dtype=int)
        table = action_likelihood(policy, epsilon)
        modes = np.arange(policy.shape[1]) % N_MODES if modes is None else np.asarray(modes, dtype=int)
        pair = modes * N_ACTIONS + policy  # (G, S): mode-major pair codes
        present = np.flatnonzero(np.bincount(pair.ravel()))
        # the occurring pairs' rows, computed as the whole table's are (elementwise, the same bytes)
        pairs = cls.of(action_likelihood(present % N_ACTIONS, epsilon)[None], modes=present // N_ACTIONS)
        index_of_pair = np.zeros(present[-1] + 1, dtype=pairs.index.dtype)
        index_of_pair[present] = pairs.index[0]
        return cls(table=table, rows=pairs.rows, row_modes=pairs.row_modes, index=index_of_pair[pair])
