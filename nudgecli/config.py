"""Experiment files: pydantic models, preset lookup, ``--set`` overrides.

An experiment file is TOML with the sections below; every key has a default, unknown keys
fail with a "did you mean", and values are range-checked. Precedence: command-line flag >
``--set section.key=value`` > file > defaults. The presets (``paper``, ``study-code``,
``smoke``, ``ciaa-teleop``) live in the top-level ``experiments/`` folder and are shipped inside the wheel.
"""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from nudgecli.errors import ConfigError, did_you_mean
from nudgecli.model.disambiguation import DisambiguationSettings
from nudgecli.model.interface import (
    DEFAULT_TABLE_NOISE,
    HARD_THRESHOLD_EARLY,
    SOFT_THRESHOLD_EARLY,
    ZERO_THRESHOLD,
)
from nudgecli.model.mdp import DEFAULT_GAMMA, DEFAULT_HUMAN_EPSILON, MDPRewards
from nudgecli.model.path_world import HEADING_TOLERANCE, SNAP_TOLERANCE, SUCCESS_DISTANCE

PositiveFloat = Annotated[float, Field(gt=0)]
Probability = Annotated[float, Field(ge=0, le=1)]
#: A plan as a command holds it: a preset name, a path or a loaded plan (:func:`resolve_plan`).
PlanT = TypeVar("PlanT")


class Section(BaseModel):
    """Base of every section: unknown keys are errors, values are validated on assignment."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=True)


def plain(value: Any) -> Any:
    """``value`` with numpy scalars and arrays made plain Python (lists, tuples, dicts recursively),
    so a message shows ``150.0``, not ``np.float64(150.0)``."""
    if isinstance(value, dict):
        return {plain(k): plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return type(value)(plain(v) for v in value)
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):
        return value.tolist()
    return value


def check_range(name: str, value: tuple[float, float], lo: float, hi: float) -> None:
    """Raise ``ValueError`` unless ``lo <= value[0] <= value[1] <= hi``."""
    if not (lo <= value[0] <= value[1] <= hi):
        raise ValueError(f"{name} must be [low, high] with {plain(lo)} <= low <= high <= {plain(hi)}, "
                         f"got {list(plain(tuple(value)))}")


class ExperimentMeta(Section):
    """``[experiment]``: name and description of the experiment, and its default seed."""

    name: str = "experiment"
    description: str = ""
    seed: int = Field(default=2022, ge=0)


#: The assistance policies a ``[study] conditions`` list may name (``nudgecli.sim.policies``).
CONDITION_NAMES = ("disambiguation", "control", "teleoperation", "blending", "mode-switch", "hindsight")
#: Conditions that need their own settings section (``[blending]``, ``[mode-switch]``,
#: ``[hindsight]``); ``disambiguation`` and ``control`` use ``[disambiguation]`` and
#: ``[assistance]``, which every experiment has, and ``teleoperation`` has no settings.
CONDITION_SECTIONS = {"blending": "blending", "mode-switch": "mode_switch", "hindsight": "hindsight"}


class StudySection(Section):
    """``[study]``: the design of DESIGN.md section 2.7 and the trial's stopping rules.

    ``conditions`` lists two or more of :data:`CONDITION_NAMES`. ``counterbalancing`` orders the
    conditions per participant (``nudgecli.sim.counterbalance``): ``williams`` is one balanced
    Latin square (Williams design: every condition precedes every other once), which exists for
    an even number of conditions only; ``williams-pair`` is the Williams square and its mirror
    (2k orders), which balances an odd number too; ``rotation`` is the cyclic rotation. With two
    conditions all three give the same two orders. Participant ``i`` takes order ``i`` mod the
    number of orders, so a participant count that is not a multiple of it leaves the design
    unbalanced (recorded in the manifest, not refused: the paper's 9 participants did so).
    ``shared_layouts``: 0 draws each condition its own layouts (the paper); ``n > 0`` has every
    condition run the same ``n`` sets of the design's layouts, the ones a study of ``n``
    conditions draws (``2``: the paper's 48 layouts).
    """

    participants: int = Field(default=9, ge=1, le=10_000)
    conditions: tuple[str, ...] = ("disambiguation", "control")
    counterbalancing: Literal["williams", "williams-pair", "rotation"] = "williams"
    shared_layouts: int = Field(default=0, ge=0, le=100)
    goal_counts: tuple[int, ...] = (3, 4)
    corners: tuple[Literal["tr", "tl", "bl", "br"], ...] = ("tr", "tl", "bl", "br")
    start_modes: tuple[Literal["x", "y", "theta"], ...] = ("x", "y", "theta")
    blocks_per_condition: int = Field(default=3, ge=1)
    rate_hz: PositiveFloat = 10.0
    time_limit_s: PositiveFloat = 120.0
    success_distance: PositiveFloat = 1.0
    success_angle: PositiveFloat = 0.2

    @field_validator("conditions")
    @classmethod
    def _known_conditions(cls, conditions: tuple[str, ...]) -> tuple[str, ...]:
        for name in conditions:
            if name not in CONDITION_NAMES:
                raise ValueError(f"unknown condition {name!r}{did_you_mean(name, CONDITION_NAMES)}; "
                                 f"known: {', '.join(CONDITION_NAMES)}")
        if len(conditions) == 1:
            raise ValueError(f"only one condition ({conditions[0]!r}); a study compares two or more, "
                             "e.g. conditions = [\"disambiguation\", \"control\"]")
        return conditions

    @model_validator(mode="after")
    def _check(self) -> StudySection:
        if len(set(self.conditions)) != len(self.conditions) or not self.conditions:
            raise ValueError("conditions must be a non-empty list without repeats")
        if self.counterbalancing == "williams" and len(self.conditions) % 2:
            k = len(self.conditions)
            raise ValueError(f"counterbalancing = 'williams' cannot balance {k} conditions "
                             "(one Williams square needs an even count); use 'williams-pair' (the square and "
                             "its mirror) or list an even number of conditions")
        for g in self.goal_counts:
            if not 2 <= g <= 8:
                raise ValueError(f"goal_counts: {g} goals do not fit the goal regions; use 2 to 8")
        if not self.goal_counts or not self.corners or not self.start_modes:
            raise ValueError("goal_counts, corners and start_modes must not be empty")
        trials = self.trials_per_condition
        if trials % self.blocks_per_condition:
            raise ValueError(
                f"blocks_per_condition={self.blocks_per_condition} does not divide the {trials} trials "
                "of each condition")
        return self

    @property
    def trials_per_condition(self) -> int:
        design = len(self.goal_counts) * len(self.corners) * len(self.start_modes)
        return design * max(1, self.shared_layouts)


class InterfaceSection(Section):
    """``[interface]``: the sip-and-puff driver's label bands and the human's command speeds."""

    # the pilots' bands (nudgecli.model.interface), which the paper's study used
    soft_threshold: Probability = SOFT_THRESHOLD_EARLY
    hard_threshold: Probability = HARD_THRESHOLD_EARLY
    zero_threshold: Probability = ZERO_THRESHOLD
    human_speed: PositiveFloat = 3.0
    human_turn_rate: PositiveFloat = 1.95

    @model_validator(mode="after")
    def _check(self) -> InterfaceSection:
        if not self.zero_threshold < self.soft_threshold <= self.hard_threshold:
            raise ValueError("thresholds must satisfy zero_threshold < soft_threshold <= hard_threshold")
        return self


class ModelSection(Section):
    """``[model]``: the human model the agent assumes (goal MDPs, epsilon-greedy policy, tables)."""

    # the study's values, where the goal MDPs are defined (nudgecli.model.mdp)
    epsilon: Annotated[float, Field(ge=0, lt=1)] = DEFAULT_HUMAN_EPSILON
    gamma: Annotated[float, Field(gt=0, lt=1)] = DEFAULT_GAMMA
    move_reward: float = MDPRewards.move
    mode_switch_reward: float = MDPRewards.mode_switch
    bump_reward: float = MDPRewards.bump
    goal_reward: float = MDPRewards.goal
    tables: Literal["fitted", "default"] = Field(
        default="fitted",
        description="fitted: tables estimated from each participant's (simulated) calibration; "
        "default: 0.8 one-hot + 0.2 uniform for everyone.")
    default_table_noise: Probability = DEFAULT_TABLE_NOISE


class InferenceSection(Section):
    """``[inference]``: the goal-transition model, the study's forgetting and the confidence threshold."""

    goal_stay: Annotated[float, Field(gt=0, le=1)] = Field(
        default=1.0,
        description="p(g_t = g_{t-1}); 1 is the identity of Eq. 7, else the rest is spread evenly.")
    decay: bool = False
    decay_delay: int = Field(default=10, ge=0)
    decay_rate: Annotated[float, Field(ge=0)] = 0.008
    decay_cap: int = Field(default=1000, ge=1)
    kappa: Annotated[float, Field(gt=0, le=1)] = 0.65
    update: Literal["action", "sample"] = Field(
        default="action",
        description="action: one Bayesian update per task-level input event (a new blow, or a change of "
        "measured label within a blow), as Algorithm 1 draws one a^t per update; sample: one update per "
        "labelled 10 Hz sample (the study software).")


#: The model's defaults of D(s), which ``[disambiguation]`` takes.
_DISAMBIGUATION = DisambiguationSettings()


class DisambiguationSection(Section):
    """``[disambiguation]``: D(s) = mi_weight * I(s) - distance_weight * R(s) and its search domain."""

    # the defaults are the model's (nudgecli.model.disambiguation.DisambiguationSettings)
    estimator: Literal["exact", "monte_carlo"] = _DISAMBIGUATION.estimator
    samples: int = Field(default=_DISAMBIGUATION.samples, ge=1)
    weighting: Literal["belief", "unweighted"] = _DISAMBIGUATION.weighting
    mi_weight: Annotated[float, Field(ge=0)] = _DISAMBIGUATION.mi_weight
    distance_weight: Annotated[float, Field(ge=0)] = _DISAMBIGUATION.distance_weight
    distance: Literal["expected", "to_mean"] = _DISAMBIGUATION.distance
    distance_unit: Literal["cells", "world"] = _DISAMBIGUATION.distance_unit
    window: Literal[3, 5] = _DISAMBIGUATION.window  # type: ignore[assignment]  # 3, an int to mypy
    domain: Literal["window", "global"] = _DISAMBIGUATION.domain
    rotation_gate: Annotated[float, Field(ge=0)] | None = Field(
        default=_DISAMBIGUATION.rotation_gate,
        description="Drop theta-mode candidates farther than this from the mean goal.")
    scope: Literal["domain", "mode-only"] = Field(
        default=_DISAMBIGUATION.scope,
        description="domain: the states of `domain`; mode-only: the states that "
        "differ from the current one in mode alone (the mode-switch policy always uses these).")


class AssistanceSection(Section):
    """``[assistance]``: blending during the human's turn and the autonomy's motion."""

    rho1_factor: PositiveFloat = 1.1
    rho2_factor: PositiveFloat = 1.2
    rho3: Probability = 0.8
    entropy_gate: bool = False
    startup_delay_s: Annotated[float, Field(ge=0)] = 0.0
    distance_weighting: bool = False
    distance_knee: PositiveFloat = Field(
        default=35.0, description="Distance weight: 1 - drop d / knee up to the knee (world units), then "
        "(1 - drop) exp(-(d - knee)) (the study software's values).")
    distance_drop: Annotated[float, Field(ge=0, lt=1)] = 0.4
    autonomy_speed: PositiveFloat = 5.0
    autonomy_turn_rate: PositiveFloat = 1.5
    arrival_tolerance: PositiveFloat = 0.1

    @model_validator(mode="after")
    def _check(self) -> AssistanceSection:
        if self.rho2_factor <= self.rho1_factor:
            raise ValueError("rho2_factor must be greater than rho1_factor")
        return self


class BlendingPolicySection(Section):
    """``[blending]``: the ``blending`` condition, policy blending without turn-taking.

    alpha is the paper's piecewise rule of ``[assistance]`` (``rho1_factor``, ``rho2_factor``,
    ``rho3`` and its gates); ``gate = "gap"`` also zeroes it unless the two highest beliefs differ
    by more than ``gap`` (the open hindsight-optimisation code's confidence gate, 0.4).
    """

    gate: Literal["none", "gap"] = "none"
    gap: Annotated[float, Field(ge=0, lt=1)] = 0.4


class ModeSwitchSection(Section):
    """``[mode-switch]``: the ``mode-switch`` condition (the autonomy's turn only changes the mode).

    ``criterion`` ranks the states that differ from the current one in mode alone: ``disamb`` by
    D(s) of ``[disambiguation]`` (Eq. 15), ``entropy`` by the expected entropy of the belief after
    the next measured label (lowest wins), ``kl`` by the belief-weighted KL divergence between the
    goals' label distributions (highest wins). With the exact estimator ``entropy`` picks the mode
    ``disamb`` picks: ``I(s) = H(b) - E H(b')`` and ``R(s)`` is the same for every mode-only
    state; they part with the Monte-Carlo estimator. ``kl`` is a different ranking.
    """

    criterion: Literal["disamb", "entropy", "kl"] = "disamb"


class HindsightSection(Section):
    """``[hindsight]``: the ``hindsight`` condition (first-order hindsight optimisation).

    ``gain`` scales the belief-weighted sum of the per-goal autonomous commands added to the
    person's command every step (1: the sum itself).
    """

    gain: Annotated[float, Field(ge=0)] = 1.0


class PopulationSection(Section):
    """``[population]``: the ranges each simulated participant's true physiology and habits are drawn from.

    Every ``[low, high]`` pair is a uniform draw per participant (``onset_ramp_samples`` an integer
    draw); ``reaction_log_sd`` is one value for everyone. Pressure levels are magnitudes on the
    device's scale (sip positive, puff negative in the stream); a level above 1 means the person
    blows harder than the sensor reads, so most samples saturate at 1 the way real hard blows do.
    A blow's per-sample pressure is ``level + spread * z`` (after an onset ramp), clipped to [0, 1]
    on the intended side; ``z`` is N(0, 1) at every sample and drifts within a blow with lag-1
    correlation ``drift_correlation`` (``nudgecli.sim.participants``).

    Where the defaults come from -- the real pilot logs in ``shared/data/calibration/`` (recorded
    with soft/hard thresholds 0.3/0.5). Per prompted label, the samples of each prompt window with
    non-zero pressure, without each blow's first two and last sample (its ramps), fitted by the
    censored-normal quantile fit of ``nudgecli.sim.participants.participant_from_log``
    (magnitudes; "sat." = share of samples at the sensor's limit 1.0):

    ===================  ===============================  ========================  ==============
    field                andrewtest                       deepaktest                default range
    ===================  ===============================  ========================  ==============
    hard_puff_level      1.04 (61% sat.)                  0.60                      [0.55, 1.10]
    hard_sip_level       1.10 (98% sat.)                  1.12 (100% sat.)          [0.60, 1.20] *
    soft_puff_level      0.088                            0.103                     [0.05, 0.17] *
    soft_sip_level       0.222 (31% of samples > 0.3:     1.08: never produced a    [0.05, 0.42] *
                         the 28% Soft Sip -> Hard Sip)    soft sip (outside the
                                                          population; simulate him
                                                          with participant_from_log)
    hard_spread          0.196 (puff; sip saturated)      0.149 (puff)              [0.05, 0.20]
    soft_spread          0.088 (puff), 0.153 (sip)        0.024 (puff)              [0.02, 0.15]
    drift_correlation    0.94 (per label: 0.85 Hard       0.99 (per label: 0.99     [0.56, 0.99] *
                         Puff, 0.94 Soft Puff, 0.98       Hard Puff, 0.97 Soft
                         Soft Sip)                        Puff)
    onset_ramp_samples   hard blows reach their level in 2-3 samples (+0.06 +0.69 +1.00;
                         -0.28 -0.67 -0.95; -0.13 -0.33 -0.44), soft ones in 1-4    [1, 3]
    reaction_s           blow onset median 1.44 s         1.32 s                    [0.9, 2.0]
                         (key-press latency medians 1.43, 1.51, 1.50 s in the mapping sessions)
    reaction_log_sd      blow onsets 0.31, 0.27; key presses 0.42 (10-90%: 0.9-2.8 s)  0.35
    mapping_error        0/72 wrong (andrewtest), 0/72 (deepak), 3/24 (deepaktest)  [0.0, 0.12]
    ===================  ==========================================================  ==============

    (*) The pilots' logs alone give hard_sip_level [0.80, 1.20], soft_puff_level [0.05, 0.16],
    soft_sip_level [0.05, 0.24] and drift_correlation [0.94, 0.99] (the two people's estimates);
    these ends are moved to cover twelve real people's calibrations (below).

    ``drift_correlation`` is ``log_drift_correlation``: the lag-1 correlation of the plateau
    samples' deviations from their label's fitted level, over consecutive pairs of one blow that
    are both unsaturated. The real pressure wanders slowly: from one 10 Hz tick to the next it
    moves 0.01-0.05 on average, three to six times less than independent draws with the same
    spread would. No pilot data exist for the task-level habits: ``epsilon`` brackets the study's
    0.1; ``operate_s`` the paper's 3-4 s border reminder; ``rest_s``, ``action_pause_s`` and
    ``hard_blow_s`` are short against the ~1 s idle handover, and a mode-switch blow outlasts the
    onset ramp so it reaches the hard band.

    Checked against twelve real people (issue 14; ``nudgecli.sim.real_population``,
    ``nudge plot-population``). Their fitted ``p(phi_m | phi_i)`` diagonals: the pilots' (fixed
    10 Hz stream, fitted by ``nudge fit``) Hard Puff 0.90-0.93, Hard Sip 0.95-0.97, Soft Puff
    0.97, Soft Sip 0.70 and 0.01 (deepaktest, who never produced a soft sip); nine sibling-study
    participants (event-driven stream, prompts 4 s + 1 s blank) Hard Puff 0.53-0.84, Hard Sip
    0.54-0.78, Soft Puff 0.80-0.97, Soft Sip 0.31-0.97. A fixed-rate stream counts time and an
    event-driven one counts pressure *changes*: a saturated blow is silent, its ramps through the
    soft band and the deadband are not, and a slowly drifting plateau changes little. So each
    real value is compared with the diagonal the estimator converges to in its own format:
    ``expected_diagonal`` (exact label probabilities of a 25-tick blow for 10 Hz, which do not
    depend on the drift; the expected message counts of the device's 0.0109 quantisation,
    averaged over 400 seeded blows, for event-driven), over the corners and midpoints of each
    label's (level, spread, ramp, drift) box (``diagonal_image``).

    The derivation: every range starts where the pilots' logs put it; where the image of the
    ranges misses an end of a real span, the parameter that moves that end is extended by the
    least amount (0.01 grid) at which a participant of the population reaches it.

    1. The top of the hard spans (``drift_range_covering``). Less drift means more pressure
       changes on an unsaturated plateau, where a hard blow's changes count as hard, so the
       highest hard diagonal rises as the drift falls. The pilots' drift (0.94-0.99) tops out
       at 0.76 against the real 0.84 (Hard Puff) and 0.78 (Hard Sip): the lower end goes down
       to **0.56**, where Hard Puff reaches 0.84 (``highest_diagonal``: over the level range's
       ends and midpoint, the spread ends and the ramps). The pilots are two people with
       strongly drifting blows; some of the sibling study's nine blew more unsteadily.
    2. The bottom of every span (``level_range_covering``, then with the drift range of 1). A
       soft label's diagonal falls as its level rises towards the soft threshold, so its upper
       end is raised: **Soft Sip 0.42** (for 0.31), **Soft Puff 0.17** (for 0.80). A hard
       label's falls as its level drops towards the hard threshold (an unsaturated, slowly
       drifting blow spends most of its changes on the way up and down through the soft band),
       so its lower end is lowered: **Hard Sip 0.60** (for 0.54); Hard Puff's 0.55 reaches 0.53
       already (``lowest_diagonal``: over the ends of the spread and drift ranges and the
       ramps).

    The image of the defaults:

    ===========  ==================  ====================  ====================================
    label        fixed 10 Hz         event-driven          against the real people
    ===========  ==================  ====================  ====================================
    Hard Puff    0.81-0.97           0.50-0.84             all covered
    Hard Sip     0.85-0.97           0.54-0.83             all covered
    Soft Puff    0.77-0.97           0.79-0.97             all covered
    Soft Sip     0.05-0.97           0.30-0.97             all covered but deepaktest's 0.01
    ===========  ==================  ====================  ====================================

    The extremes are reached at the corners of the ranges (for the lowest hard values: a low
    level, a small spread and the strongest drift together), so few drawn participants come
    near them. deepaktest's soft-sip level of 1.08 lies outside any "soft" range (simulate him
    with ``physiology_logs``); counted as the event-driven device would, his soft sips give
    0.28, near the sibling study's lowest 0.31. The ``paper`` and ``study-code`` presets use
    these defaults. Drawing each parameter uniformly over a range whose end is set by the most
    extreme real person is an assumption: it makes such people more common than they may be.
    """

    soft_puff_level: tuple[float, float] = (0.05, 0.17)
    soft_sip_level: tuple[float, float] = (0.05, 0.42)
    hard_puff_level: tuple[float, float] = (0.55, 1.10)
    hard_sip_level: tuple[float, float] = (0.60, 1.20)
    soft_spread: tuple[float, float] = (0.02, 0.15)
    hard_spread: tuple[float, float] = (0.05, 0.20)
    onset_ramp_samples: tuple[int, int] = (1, 3)
    mapping_error: tuple[float, float] = (0.0, 0.12)
    epsilon: tuple[float, float] = (0.02, 0.15)
    rest_s: tuple[float, float] = (0.3, 1.5)
    operate_s: tuple[float, float] = (2.5, 5.0)
    action_pause_s: tuple[float, float] = (0.1, 0.4)
    hard_blow_s: tuple[float, float] = (0.4, 0.8)
    handover_idle_s: tuple[float, float] = Field(
        default=(1.5, 2.0),
        description="Idle time after the first input of a turn that hands the turn to the autonomy, drawn "
        "per participant (the paper: 'not issuing any commands for ~1.5-2 s'); a live session uses the "
        "middle of the range.")
    reaction_s: tuple[float, float] = (0.9, 2.0)
    reaction_log_sd: Annotated[float, Field(ge=0, le=2)] = 0.35
    drift_correlation: tuple[float, float] = Field(
        default=(0.56, 0.99),
        description="Lag-1 correlation, from one 10 Hz sample to the next within a blow, of the pressure's "
        "deviation from its level (0: independent samples). Does not change the per-sample label "
        "probabilities; it sets how often the pressure changes, which an event-driven device counts.")
    planning_s: tuple[float, float] = Field(
        default=(1.32, 2.75),
        description="Looking at the layout and the mode before a trial's first command, s "
        "(behaviour.planning). "
        "From the pilots' prompt -> blow onset medians (1.32, 1.45 s), the upper end extended to the "
        "real people's highest first-command latency (HABITS.md: 1.80-2.75 s).")
    event_reaction_s: tuple[float, float] = Field(
        default=(0.49, 1.70),
        description="Median delay from a visible event (the robot stopped, the mode changed, the turn came "
        "back, a surprise) to acting on it, s (behaviour.event_reactions). From the pilots' 1.32-1.45 s, "
        "extended to cover the real reactions (HABITS.md: stop -> switch 0.59-1.80, switch -> motion "
        "0.83-1.59, each a reaction plus a ramp of about 0.1 s).")
    event_reaction_log_sd: tuple[float, float] = Field(
        default=(0.27, 0.42),
        description="Per-person log-sd of those delays: the tail of their pauses (behaviour.pause_tail). The "
        "pilots' blow onsets (0.27, 0.31) and key presses (0.42).")
    hold_on_s: tuple[float, float] = Field(
        default=(0.10, 0.32),
        description="Blowing on after the robot stopped under a soft command, s (behaviour.hold_on). The "
        "pilot still blowing when a prompt cleared released after a median 0.32 s; the lower end extended "
        "to the real people's 0.1 s per stop (HABITS.md).")
    hard_peak_s: tuple[float, float] = Field(
        default=(0.10, 0.30),
        description="A mode-switch pulse's time at its peak, s (behaviour.hard_pulses). The pilots held "
        "prompted hard blows for seconds, so nothing there: the real time in the hard band per excursion "
        "(HABITS.md: 0.10-0.30 s).")
    offset_ramp_samples: tuple[int, int] = Field(
        default=(0, 2),
        description="Samples a hard pulse takes to fall from its peak. The pilots' hard blows fell in a "
        "median "
        "1 (andrewtest) and 0 (deepaktest) samples; the upper end extended to 2 so a pulse (onset 1-3 + peak "
        "+ offset) reaches the real people's longest hard blows (HABITS.md: 0.30-0.80 s whole).")
    physiology_logs: tuple[str, ...] = Field(
        default=(),
        description="Calibration folders with a p(phi_m | phi_i) session (study export or tidy format): "
        "participant k takes the pressure physiology recorded in the k-th, the others are drawn; "
        "habits are always drawn. Relative paths are relative to the working directory.")

    @model_validator(mode="after")
    def _check(self) -> PopulationSection:
        for name, (lo, hi) in {
            "soft_puff_level": (0.0, 1.5), "soft_sip_level": (0.0, 1.5), "hard_puff_level": (0.0, 1.5),
            "hard_sip_level": (0.0, 1.5), "soft_spread": (0.0, 1.0), "hard_spread": (0.0, 1.0),
            "onset_ramp_samples": (0, 20), "mapping_error": (0.0, 0.75), "epsilon": (0.0, 1.0),
            "rest_s": (0.0, 60.0), "operate_s": (0.1, 120.0), "action_pause_s": (0.0, 10.0),
            "hard_blow_s": (0.1, 5.0), "reaction_s": (0.0, 10.0), "handover_idle_s": (0.1, 30.0),
            "drift_correlation": (0.0, 0.99), "planning_s": (0.0, 60.0), "event_reaction_s": (0.0, 10.0),
            "event_reaction_log_sd": (0.0, 2.0), "hold_on_s": (0.0, 5.0), "hard_peak_s": (0.0, 5.0),
            "offset_ramp_samples": (0, 20),
        }.items():
            check_range(name, getattr(self, name), lo, hi)
        return self


class BehaviourSection(Section):
    """``[behaviour]``: how the simulated person acts in their turn (:mod:`nudgecli.sim.behaviour`).

    The participant's own habits (rest, operating time, pauses, handover idle time) are drawn
    per participant from ``[population]``; these keys say how they decide.

    - ``decisions``: ``events`` decides at what a person can see (the robot reached the next cell
      centre along the commanded axis, the mode changed, a new turn began); ``grid`` re-plans
      whenever the robot crosses into another discrete state (a boundary a person cannot see).
    - ``lean_on_blending``: while blending carries the robot towards their goal (the last step
      reduced the remaining error), a person whose policy says "switch mode" keeps their current
      soft command instead (paper, Section 6: manual switches become unnecessary once blending
      is active).
    - ``release_when_dragged``: when blending moves the robot away from their goal, they let go
      (blending acts only on a non-zero command, so the robot stops) and decide again with a new
      blow.
    - ``after_autonomy``: ``replan`` acts from the state and mode the autonomy left (its mode
      change is kept unless the policy says otherwise); ``resume`` first repeats the task action
      they were doing before the autonomy's turn, as a person who ignores it would.
    - ``stall_s``: how long the robot may stand still under a held soft command before the person
      notices, lets go and decides again with a new blow (a deadband reading, a dip to no input,
      a move the world does not allow, a wall); 0: never, the command is held to ``max_hold_s``.
      No data pin it: one second is a person's visual reaction with room to spare.
    - ``max_hold_s``: the longest one command is held before deciding again (blending that never
      lets the robot reach the next cell centre).
    - ``fine_position_tolerance`` / ``fine_heading_tolerance``: the per-axis error (units) and
      heading error (rad) a person accepts when fine positioning inside the goal's cell (inside
      the success tolerance).
    - ``*_jitter``: per-turn or per-action variation of the participant's habits: a duration ``d``
      is drawn as ``d * U(1 - jitter, 1 + jitter)``.

    The operating habits measured from real sip-and-puff users (``shared/data/ciaa-task/HABITS.md``;
    ``nudge habits``), each one key; ``false`` restores the earlier person:

    - ``event_reactions``: a visible event (the robot stopped at a mark where the plan changes, the
      mode changed, a hard pulse that switched nothing ended, the turn came back from the autonomy,
      the robot stood still for ``stall_s``) is acted on after a reaction delay drawn per event
      from the person's own log-normal (``population.event_reaction_s``); the next blow starts
      then, or after their release pause if that ends later. ``false``: the same step, and turns
      after the autonomy start after ``rest_s``.
    - ``planning``: before a trial's first command the person looks at the layout and the mode for
      their ``planning_s`` (``planning_jitter`` per trial); ``false``: ``rest_s``.
    - ``hard_pulses``: a mode switch is a short pulse: their onset ramp, ``hard_peak_s`` at the
      level, their offset ramp, then a full release; ``false``: a plateau of ``hard_blow_s`` with no
      offset ramp.
    - ``hold_on``: when the robot stops under their soft command at a mark where the plan changes
      (a waypoint of a path), they keep blowing for ``hold_on_s`` (``hold_on_jitter`` per stop)
      before they let go; ``false``: they let go in the step it stops.
    - ``pause_tail``: reaction delays spread log-normally with the person's own
      ``event_reaction_log_sd`` (a long tail of pauses that differs by person); ``false``: always
      their median.
    - ``notice_mode_errors``: an unintended mode switch or a motion the other way than meant under a
      soft blow is noticed after a reaction delay (the blow goes on until then), then corrected by
      their own plan; ``false``: noticed in the same step.
    """

    decisions: Literal["events", "grid"] = "events"
    lean_on_blending: bool = True
    release_when_dragged: bool = True
    after_autonomy: Literal["replan", "resume"] = "replan"
    stall_s: Annotated[float, Field(ge=0)] = 1.0
    max_hold_s: PositiveFloat = 3.0
    fine_position_tolerance: PositiveFloat = 0.5
    fine_heading_tolerance: PositiveFloat = 0.15
    rest_jitter: Annotated[float, Field(ge=0, lt=1)] = 0.5
    operate_jitter: Annotated[float, Field(ge=0, lt=1)] = 0.3
    pause_jitter: Annotated[float, Field(ge=0, lt=1)] = 0.5
    hard_blow_jitter: Annotated[float, Field(ge=0, lt=1)] = 0.2
    event_reactions: bool = True
    planning: bool = True
    hard_pulses: bool = True
    hold_on: bool = True
    pause_tail: bool = True
    notice_mode_errors: bool = True
    planning_jitter: Annotated[float, Field(ge=0, lt=1)] = 0.2
    hold_on_jitter: Annotated[float, Field(ge=0, lt=1)] = 0.5


class CalibrationSection(Section):
    """``[calibration]``: the simulated Phases 1-2, following the study's prompting protocol.

    ``p(phi_i | a)``: ``mapping_blocks`` blocks of the 12 action images in random order; an answer
    clears the prompt ``answer_clear_s`` later (0.50-0.52 s in the pilot logs), no answer within
    ``answer_timeout_s`` (the study's 10 s) clears it as missed, and blocks are separated by the
    hard-puff refresher (``block_break_s``; 10-18 s in the logs). ``p(phi_m | phi_i)``:
    ``prompts_per_label`` rounds of the 4 labels in random order, each shown ``prompt_s`` then
    ``blank_s`` blank, with the stream labelled at ``rate_hz``.

    ``stream`` is the device's label stream: ``fixed_rate`` (the pilots' logs: one labelled
    sample per tick) or ``event_driven`` (the sibling study's logs: a message each time the
    pressure, quantised in steps of ``event_step``, changes, none while it is steady, and
    ``Zero Band`` + ``input stopped`` at the end of each blow; ``nudgecli.sim.calibration.
    event_driven_stream``). The sibling study prompted 4 s with 1 s blank (``prompt_s = 4``,
    ``blank_s = 1``).
    """

    mapping_blocks: int = Field(default=6, ge=1, description="Blocks of the 12 prompted actions.")
    prompts_per_label: int = Field(default=12, ge=1)
    prompt_s: PositiveFloat = 6.0
    blank_s: PositiveFloat = 1.5
    answer_timeout_s: PositiveFloat = 10.0
    answer_clear_s: Annotated[float, Field(ge=0)] = 0.5
    block_break_s: Annotated[float, Field(ge=0)] = 10.0
    rate_hz: PositiveFloat = 10.0
    stream: Literal["fixed_rate", "event_driven"] = "fixed_rate"
    event_step: Annotated[float, Field(gt=0, le=0.1)] = Field(
        default=0.0109, description="Pressure quantisation of the event-driven stream (the sibling study's "
        "device stepped in about 0.0109).")


class WorldSection(Section):
    """``[world]``: which world the trials run in, and the CIAA path world's constants.

    - ``kind``: ``grid`` is the paper's open workspace with its 10 x 10 x 8 x 3 grid (DESIGN.md
      section 2.1; the ``[study]`` design of layouts, goals and blocks); ``ciaa`` is the
      path-constrained teleoperation task of the sibling CIAA study (2020, "Customized Handling
      of Unintended Interface Operation in Assistive Robots"; its ``TASK.md`` and
      ``layouts.json``): one known goal, waypoints, one allowed mode and direction per leg, the
      rotation at the turn waypoint only. In ``ciaa`` the layouts, their order and the
      conditions come from the task file's ``subject_blocks`` (participant ``i`` runs as subject
      ``i mod 10`` did), and ``[study]`` keeps ``rate_hz`` and ``time_limit_s`` (the study's 50 s).

    The keys below apply to ``ciaa`` only; their defaults are TASK.md's values:

    - ``ciaa_conditions``: the study's conditions whose blocks are run. Only ``no_assistance``
      (no inference, no blending, no autonomy) is implemented: 12 trials per participant.
    - ``linear_speed`` / ``angular_speed``: full speed of a soft command in wall-clock time,
      1.6 units/s and 0.64 rad/s (TASK.md section 6: 3.9 units and 1.56 rad per simulated second,
      with the simulator's loop running at about 41 steps of 0.01 s per wall-clock second).
      They replace ``[interface]`` ``human_speed`` / ``human_turn_rate`` in this world.
    - ``snap_tolerance``: the robot snaps onto the next waypoint within 0.1 units on both axes;
      ``heading_tolerance``: onto the goal heading within 0.1 rad (section 4).
    - ``success_distance``: a success ends within this Manhattan distance of the goal (0.1) and
      within ``study.time_limit_s`` (section 7).
    """

    kind: Literal["grid", "ciaa"] = "grid"
    ciaa_conditions: tuple[Literal["no_assistance"], ...] = ("no_assistance",)
    linear_speed: PositiveFloat = 1.6
    angular_speed: PositiveFloat = 0.64
    snap_tolerance: PositiveFloat = SNAP_TOLERANCE  # TASK.md's (nudgecli.model.path_world)
    heading_tolerance: PositiveFloat = HEADING_TOLERANCE
    success_distance: PositiveFloat = SUCCESS_DISTANCE

    @model_validator(mode="after")
    def _check(self) -> WorldSection:
        if not self.ciaa_conditions or len(set(self.ciaa_conditions)) != len(self.ciaa_conditions):
            raise ValueError("ciaa_conditions must be a non-empty list without repeats")
        return self


class ExperimentConfig(Section):
    """A whole experiment file."""

    experiment: ExperimentMeta = ExperimentMeta()
    study: StudySection = StudySection()
    interface: InterfaceSection = InterfaceSection()
    model: ModelSection = ModelSection()
    inference: InferenceSection = InferenceSection()
    disambiguation: DisambiguationSection = DisambiguationSection()
    assistance: AssistanceSection = AssistanceSection()
    population: PopulationSection = PopulationSection()
    behaviour: BehaviourSection = BehaviourSection()
    calibration: CalibrationSection = CalibrationSection()
    world: WorldSection = WorldSection()
    # the policies' own sections: absent unless the experiment lists their condition
    blending: BlendingPolicySection | None = None
    mode_switch: ModeSwitchSection | None = Field(default=None, alias="mode-switch")
    hindsight: HindsightSection | None = None

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=True, populate_by_name=True)

    @model_validator(mode="after")
    def _check_policy_sections(self) -> ExperimentConfig:
        if self.world.kind != "grid":
            return self
        for condition in self.study.conditions:
            field_name = CONDITION_SECTIONS.get(condition)
            if field_name is not None and getattr(self, field_name) is None:
                example = {"blending": 'gate = "gap"', "mode-switch": 'criterion = "disamb"',
                           "hindsight": "gain = 1.0"}[condition]
                key, value = example.split(" = ")
                raise ValueError(f"study.conditions lists {condition!r} but there is no [{condition}] "
                                 f"section with its settings; add one, e.g. [{condition}] {example} (or "
                                 f"--set {condition}.{key}={value.strip(chr(34))} before the conditions)")
        return self

    @model_validator(mode="after")
    def _check_tolerances(self) -> ExperimentConfig:
        if self.world.kind == "ciaa":
            # one step must not carry the robot across a snapping window (2 tolerances wide)
            w, rate = self.world, self.study.rate_hz
            if w.linear_speed / rate >= 2 * w.snap_tolerance:
                raise ValueError(f"world.linear_speed / study.rate_hz = {w.linear_speed / rate:.3g} units "
                                 "per step "
                                 f"would skip waypoints; keep it below 2 * world.snap_tolerance")
            if w.angular_speed / rate >= 2 * w.heading_tolerance:
                raise ValueError(f"world.angular_speed / study.rate_hz = {w.angular_speed / rate:.3g} rad "
                                 "per step "
                                 f"would skip the goal heading; keep it below 2 * world.heading_tolerance")
            return self
        if self.behaviour.fine_position_tolerance >= self.study.success_distance:
            raise ValueError("behaviour.fine_position_tolerance must be below study.success_distance")
        if self.behaviour.fine_heading_tolerance >= self.study.success_angle:
            raise ValueError("behaviour.fine_heading_tolerance must be below study.success_angle")
        return self

    def to_toml(self) -> str:
        """The resolved experiment as TOML (every key, so a run folder documents itself)."""
        return dump_toml(self.model_dump(mode="json", exclude_none=True, by_alias=True))


# --- presets, loading, overrides --------------------------------------------------------------

def preset_dir(kind: Literal["experiments", "analysis"]) -> Path:
    """The folder holding the shipped presets of ``kind``.

    Installed, they sit in ``nudgecli/presets/<kind>/`` (pyproject maps the top-level folders
    there); in a source tree without an install, in the top-level ``<kind>/`` folder.
    """
    installed = Path(__file__).resolve().parent / "presets" / kind
    if any(installed.glob("*.toml")):
        return installed
    return Path(__file__).resolve().parents[1] / kind


def list_presets(kind: Literal["experiments", "analysis"]) -> dict[str, Path]:
    """Preset name -> file, sorted by name."""
    return {p.stem: p for p in sorted(preset_dir(kind).glob("*.toml"))}


def default_plan_name(experiment: str) -> str:
    """The analysis plan a run of ``experiment`` is analysed with by default: the plan preset of
    the same name (``study-code``), else ``paper``."""
    return experiment if experiment in list_presets("analysis") else "paper"


def resolve_plan(plan: PlanT | None, *, recorded: str | None = None,
                 experiment: str | None = None) -> PlanT | str:
    """The analysis plan a command uses: the one rule of ``analyze``, ``plot``, ``run``,
    ``replicate`` and ``power``.

    Parameters
    ----------
    plan
        The plan given (``--plan``: a preset name, a path or a loaded plan); wins when not None.
    recorded
        The plan recorded in the run folder's manifest (what the run was simulated or analysed
        with), if any.
    experiment
        The experiment's name (the run's manifest, or the experiment file's ``[experiment] name``).

    Returns
    -------
    The plan given, else the recorded one, else the plan named like the experiment
    (:func:`default_plan_name`), else ``paper``.
    """
    if plan is not None:
        return plan
    if recorded:
        return recorded
    return default_plan_name(experiment) if experiment else "paper"


def resolve_preset(name_or_path: str, kind: Literal["experiments", "analysis"]) -> Path:
    """A preset name or a TOML path -> an existing file, or a ``ConfigError`` with suggestions."""
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.exists():
        if not candidate.is_file():
            raise ConfigError(f"{name_or_path}: no such file; give a preset name or a path to a .toml file")
        return candidate
    presets = list_presets(kind)
    if name_or_path in presets:
        return presets[name_or_path]
    what = "an experiment" if kind == "experiments" else "an analysis plan"
    raise ConfigError(
        f"{name_or_path!r} is neither {what} preset nor a file{did_you_mean(name_or_path, presets)}; "
        f"presets: {', '.join(presets)} (see `nudge presets`)")


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file, turning syntax errors into a ``ConfigError`` naming the file."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc.strerror})") from exc
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: invalid TOML: {exc}") from exc


def parse_override(text: str) -> tuple[list[str], Any]:
    """``section.key=value`` -> (path, value); the value is read as a TOML literal, else a string."""
    if "=" not in text:
        raise ConfigError(f"--set {text!r}: expected section.key=value, e.g. --set study.participants=4")
    key, raw = text.split("=", 1)
    path = [p.strip() for p in key.strip().split(".") if p.strip()]
    if len(path) < 2:
        raise ConfigError(f"--set {text!r}: name the section and the key, e.g. disambiguation.window=5")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    return path, value


def _apply(data: dict[str, Any], path: list[str], value: Any) -> None:
    node = data
    for part in path[:-1]:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(f"--set {'.'.join(path)}: {part!r} is not a section")
        node = child
    node[path[-1]] = value


def _field_names(model: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """The field names of the (nested) model at ``loc`` (for "did you mean")."""
    current: Any = model
    for part in loc:
        field = current.model_fields.get(part) if isinstance(part, str) else None
        annotation = field.annotation if field is not None else None
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
            break
        current = annotation
    return [field.alias or name for name, field in current.model_fields.items()]


def format_validation_error(exc: ValidationError, source: str, model: type[BaseModel]) -> str:
    """One readable line naming the file, the field and the fix."""
    first = exc.errors()[0]
    loc = tuple(first["loc"])
    where = ".".join(str(p) for p in loc)
    if first["type"] == "extra_forbidden":
        names = _field_names(model, loc[:-1])
        hint = did_you_mean(str(loc[-1]), names)
        return f"{source}: unknown key {where!r}{hint or '; known keys: ' + ', '.join(names)}"
    message = first["msg"].removeprefix("Value error, ")
    value = first.get("input")
    if first["type"] in ("tuple_type", "list_type"):  # TOML has lists; "tuple" is pydantic's word
        message = "should be a list, e.g. [0.5, 1.0]"
    elif first["type"] == "missing" and loc and isinstance(loc[-1], int):
        where = ".".join(str(p) for p in loc[:-1])  # "rest_s.1: Field required": a value too few
        message = "too few values"
    shown = "" if isinstance(value, dict) else f" (got {as_written(value)})"
    more = f" (and {len(exc.errors()) - 1} more problem(s))" if len(exc.errors()) > 1 else ""
    return f"{source}: {where + ': ' if where else ''}{message}{shown}{more}"


def as_written(value: Any) -> str:
    """``value`` as a user writes it in TOML or ``--set``: ``150.0``, ``"abc"``, ``[0.5, 1.0]``,
    ``true`` (JSON's spelling, which TOML shares for these), not ``np.float64(150.0)`` or ``True``."""
    try:
        return json.dumps(plain(value), ensure_ascii=False)
    except (TypeError, ValueError):  # not JSON (e.g. a date): Python's spelling is the best there is
        return repr(plain(value))


def load_experiment(name_or_path: str, overrides: list[str] | tuple[str, ...] = ()) -> ExperimentConfig:
    """Read an experiment preset or file, apply ``--set`` overrides, validate.

    Raises
    ------
    ConfigError
        With one line naming the file (or ``--set``), the field and the fix.
    """
    path = resolve_preset(name_or_path, "experiments")
    data = read_toml(path)
    try:
        ExperimentConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, str(path), ExperimentConfig)) from None
    for text in overrides:
        key, value = parse_override(text)
        _apply(data, key, value)
        try:
            ExperimentConfig.model_validate(data)
        except ValidationError as exc:
            raise ConfigError(format_validation_error(exc, f"--set {text}", ExperimentConfig)) from None
    return ExperimentConfig.model_validate(data)


def experiment_from_toml(text: str, source: str = "config.toml") -> ExperimentConfig:
    """Validate an experiment given as TOML text (e.g. a run folder's ``config.toml``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: invalid TOML: {exc}") from exc
    try:
        return ExperimentConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source, ExperimentConfig)) from None


def dump_toml(data: dict[str, Any]) -> str:
    """A small TOML writer for nested dicts of scalars and lists (what our configs hold)."""
    lines: list[str] = []
    scalars = {k: v for k, v in data.items() if not isinstance(v, dict)}
    for key, value in scalars.items():
        lines.append(f"{key} = {_toml_value(value)}")
    for key, value in data.items():
        if isinstance(value, dict):
            if lines:
                lines.append("")
            lines.append(f"[{key}]")
            for k, v in value.items():
                if isinstance(v, dict):
                    raise ValueError("dump_toml supports two levels of nesting")
                lines.append(f"{k} = {_toml_value(v)}")
    return "\n".join(lines) + "\n"


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        escaped = value.replace("\\", "\\\\").replace('"', '\\"')
        return f'"{escaped}"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")
