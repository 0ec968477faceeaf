"""The validation's settings: the reading, the simulation counts, the world sizes and the
Monte-Carlo convergence study's sample counts, checked when made."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from nudgecli import command_defaults as defaults
from nudgecli.errors import ConfigError
from nudgecli.model.information import Weighting
from nudgecli.model.mdp import DEFAULT_GAMMA
from nudgecli.model.world import N_CELLS_X, N_CELLS_Y, N_HEADINGS, N_MODES, N_STATES
from nudgecli.rng import check_seed
from nudgecli.sim.validation.readings import READINGS, TWO_GOAL_REST, TWO_GOAL_SPLIT, get_reading
from nudgecli.sim.validation.world import N_VALIDATION_MODES

#: Default Monte-Carlo sample counts of the convergence study.
DEFAULT_MC_SAMPLES: tuple[int, ...] = (10, 30, 100, 300, 1000, 3000, 10000)
#: Largest sample count accepted (the cost is linear in it).
MAX_MC_SAMPLES = 100_000
#: ``--belief-concentration`` range. At 1e-3 (three goals) 95 % of Dirichlet beliefs give every goal
#: but one less than 1e-10, at 1e6 they lie within 1.3e-3 of uniform: beyond, the reading says
#: nothing new, and 1e308 overflowed the draw's sum (all-zero beliefs, a traceback).
MIN_BELIEF_CONCENTRATION = 1e-3
MAX_BELIEF_CONCENTRATION = 1e6
#: Variants of the Monte-Carlo estimate: the study's unweighted KL mean and the belief-weighted one.
MC_VARIANTS: tuple[Weighting, ...] = ("unweighted", "belief")


@dataclass(frozen=True)
class ValidationSettings:
    """Everything a validation run depends on (with the seed, it determines the result).

    Attributes
    ----------
    simulations
        Number of random worlds.
    min_goals, max_goals
        Range of ``|G|`` (inclusive), stepped cyclically over the simulations.
    states
        ``|S| = 2 W H`` of the two-mode world (the three-mode world has the study's 2400).
    seed
        Master seed; simulation ``k`` uses ``generator(seed, "validation", k)``.
    window
        Half-width of the neighbourhood in cells (1: a 3 x 3 window).
    epsilon
        Epsilon of the epsilon-greedy human model (paper Eq. 1).
    regularisation
        lambda of the regularised variant reported beside every reading (distance in cells).
    tie_tolerance
        Relative tolerance under which the best two candidates count as a near-tie.
    mc_queries
        Queries (in total, spread over the simulations) used for the Monte-Carlo convergence
        study; 0 skips it.
    mc_samples
        Sample counts per state of the convergence study.
    belief_concentration
        ``c`` of the ``Dirichlet(c, ..., c)`` query beliefs.
    reading
        Which reading of the paper's paragraph (:data:`~nudgecli.sim.validation.readings.READINGS`).
    """

    simulations: int = defaults.VALIDATION_SIMULATIONS
    min_goals: int = defaults.VALIDATION_MIN_GOALS
    max_goals: int = defaults.VALIDATION_MAX_GOALS
    states: int = defaults.VALIDATION_STATES
    seed: int = defaults.VALIDATION_SEED
    window: int = 1
    epsilon: float = 0.1
    regularisation: float = 1.0
    tie_tolerance: float = 1e-9
    mc_queries: int = defaults.VALIDATION_MC_QUERIES
    mc_samples: tuple[int, ...] = DEFAULT_MC_SAMPLES
    belief_concentration: float = defaults.VALIDATION_BELIEF_CONCENTRATION
    reading: str = defaults.VALIDATION_READING

    @property
    def grid_shape(self) -> tuple[int, int]:
        """``(W, H)`` of the reading's world (two-mode: the most square factorisation of ``states / 2``)."""
        if READINGS.get(self.reading, READINGS["dirichlet"]).world == "three-mode":
            return N_CELLS_X, N_CELLS_Y
        cells = self.states // N_VALIDATION_MODES
        width = max(d for d in range(1, math.isqrt(max(cells, 1)) + 1) if cells % d == 0)
        return width, cells // width

    @property
    def n_cells(self) -> int:
        width, height = self.grid_shape
        return width * height

    def goal_counts(self) -> np.ndarray:
        """``(simulations,)`` the ``|G|`` of every simulation (stepped cyclically)."""
        span = self.max_goals - self.min_goals + 1
        return self.min_goals + np.arange(self.simulations) % span

    def check(self) -> ValidationSettings:
        """Raise :class:`ConfigError` naming the first option that is out of range."""
        reading = get_reading(self.reading)
        if self.simulations < 1:
            raise ConfigError(f"--simulations must be at least 1 (got {self.simulations})")
        check_seed(self.seed)
        if self.min_goals < 2:
            raise ConfigError(
                f"--min-goals must be at least 2 (got {self.min_goals}): disambiguation needs two goals")
        if self.min_goals > self.max_goals:
            raise ConfigError(
                f"--min-goals ({self.min_goals}) is larger than --max-goals ({self.max_goals}); "
                "lower --min-goals or raise --max-goals")
        if self.window < 1:
            raise ConfigError(f"window half-width must be at least 1 (got {self.window})")
        if reading.world == "two-mode":
            window_states = N_VALIDATION_MODES * (2 * self.window + 1) ** 2
            if self.states < window_states:
                raise ConfigError(
                    f"--states {self.states} is fewer than one neighbourhood ({window_states} states: "
                    f"{2 * self.window + 1} x {2 * self.window + 1} cells x {N_VALIDATION_MODES} modes); "
                    f"use --states {window_states} or more")
            if self.states % N_VALIDATION_MODES:
                raise ConfigError(
                    f"--states must be even (two modes x cells), got {self.states}; e.g. --states 200")
            width, height = self.grid_shape
            side = 2 * self.window + 1
            if width < side:
                raise ConfigError(
                    f"--states {self.states} gives a {width} x {height} grid (2 x {self.n_cells} cells); "
                    f"both sides must be at least {side}: use 2 x W x H states with W, H >= {side}, "
                    "e.g. --states 200 (10 x 10)")
        if self.max_goals > self.n_cells // 2:
            raise ConfigError(
                f"--max-goals {self.max_goals} is too many for the {self.n_cells} cells of this world; "
                f"use at most {self.n_cells // 2} goals (half the cells)"
                + (" or more --states" if reading.world == "two-mode" else ""))
        if not 0.0 <= self.epsilon <= 1.0:
            raise ConfigError(f"epsilon must lie in [0, 1] (got {self.epsilon})")
        if not MIN_BELIEF_CONCENTRATION <= self.belief_concentration <= MAX_BELIEF_CONCENTRATION:  # NaN too
            raise ConfigError(f"--belief-concentration must lie in {MIN_BELIEF_CONCENTRATION:g}.."
                              f"{MAX_BELIEF_CONCENTRATION:g} (got {self.belief_concentration:g}); "
                              "1 spreads beliefs evenly, larger values make them nearly uniform")
        if not self.tie_tolerance >= 0.0:
            raise ConfigError(f"tie tolerance must be non-negative (got {self.tie_tolerance})")
        if self.mc_queries < 0:
            raise ConfigError(f"--mc-queries must be 0 or more (got {self.mc_queries})")
        if self.mc_queries and not self.mc_samples:
            raise ConfigError("the Monte-Carlo sample counts are empty; give at least one or --mc-queries 0")
        for n in self.mc_samples:
            if not 1 <= n <= MAX_MC_SAMPLES:
                raise ConfigError(
                    f"Monte-Carlo sample counts must lie in 1..{MAX_MC_SAMPLES} (got {n})")
        return self

    def describe(self) -> dict[str, Any]:
        """The settings as JSON-ready values, with the derived world description."""
        reading = get_reading(self.reading)
        data = asdict(self)
        data["mc_samples"] = list(self.mc_samples)
        width, height = self.grid_shape
        modes = N_VALIDATION_MODES if reading.world == "two-mode" else 3
        belief = (f"Dirichlet({self.belief_concentration:g}) per query" if reading.belief == "dirichlet" else
                  f"two random goals share {1 - TWO_GOAL_REST:g} (the larger share uniform in "
                  f"{TWO_GOAL_SPLIT[0]:g}..{TWO_GOAL_SPLIT[1]:g}), the others {TWO_GOAL_REST:g}")
        truth = ("E[max1(b') - max2(b')]" if reading.truth == "top-two-gap" else "H(b) - E[H(b')]")
        data.update({
            "reading": reading.describe(),
            "world": reading.world,
            "grid": [width, height], "modes": modes, "window_cells": 2 * self.window + 1,
            "discount": DEFAULT_GAMMA, "goal_counts": "cyclic: min_goals + k mod (max_goals - min_goals + 1)",
            "belief": belief,
            "metric": f"D(s) = I(s) - {reading.regularisation:g} R(s) (Eq. 13, 16)",
            "ground_truth": f"{truth} over one observation drawn from "
                            + ("p(phi_m | s)" if reading.expectation == "belief" else "the true goal"),
            "match": reading.match,
            "mc_scheme": ("per state N samples g ~ b, a ~ p(a|s,g), phi_i ~ p(phi_i|a,m), "
                          "phi_m ~ p(phi_m|phi_i)"),
        })
        return data


def states_note(states: int | None, readings: Sequence[str]) -> str | None:
    """Whether ``--states`` applies to the readings run: it sizes the two-mode world alone
    (:func:`_unused_option_note`; ``states``: ``None`` where it is not given)."""
    world = (f"the study's {N_CELLS_X} x {N_CELLS_Y} cells x {N_HEADINGS} headings x {N_MODES} modes "
             f"({N_STATES} states)")
    return _unused_option_note(
        f"--states {states}", states is not None, readings,
        lambda name: get_reading(name).world == "three-mode",
        f"its world is {world}", "the two-mode readings' world", f"keeps {world}",
        "a two-mode reading (e.g. --reading dirichlet)")


def concentration_note(concentration: float | None, readings: Sequence[str]) -> str | None:
    """Whether ``--belief-concentration`` applies to the readings run: it shapes the Dirichlet
    beliefs alone (:func:`_unused_option_note`; ``None`` where it is not given)."""
    return _unused_option_note(
        f"--belief-concentration {concentration:g}" if concentration is not None else "",
        concentration is not None, readings, lambda name: get_reading(name).belief == "two-goal",
        "its beliefs split between two goals", "the Dirichlet readings' beliefs",
        "keeps its beliefs split between two goals", "a Dirichlet reading (e.g. --reading dirichlet)")


def _unused_option_note(option: str, given: bool, readings: Sequence[str], ignores: Callable[[str], bool],
                        why: str, shapes: str, keeps: str, instead: str) -> str | None:
    """An option that some readings do not use: refused where it is given and no reading run uses
    it; where some do, a note that the others keep their own.

    Parameters
    ----------
    option
        The option as given (``--states 50``).
    given
        Whether it was given (an option left at its default is not).
    readings
        Names of the readings run.
    ignores
        Whether the named reading does not use the option.
    why, shapes, keeps, instead
        The error's reason and advice (``--reading X: <why>; leave it out, or choose <instead>``)
        and the note's words (``<option> sizes <shapes>; the X row <keeps>``).

    Returns
    -------
    str | None
        The note (without its ``Note:``) when some readings ignore the option, else ``None``.

    Raises
    ------
    ConfigError
        The option given and every reading ignores it.
    """
    if not given:
        return None
    own = [name for name in readings if ignores(name)]
    if own and len(own) == len(readings):
        raise ConfigError(f"{option} does not apply to --reading {own[0]}: {why}; leave "
                          f"{option.split()[0]} out, or choose {instead}")
    if own:
        return f"{option} sets {shapes}; the {', '.join(own)} row {keeps}"
    return None


__all__ = ["DEFAULT_MC_SAMPLES", "MAX_MC_SAMPLES", "MC_VARIANTS", "ValidationSettings", "concentration_note",
           "states_note"]
