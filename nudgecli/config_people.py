"""The simulated people's sections of an experiment: ``[population]`` (the ranges each
participant's physiology and habits are drawn from, with where they come from), ``[behaviour]``
(how a person acts in their turn) and ``[calibration]`` (the simulated Phases 1-2).

Part of :class:`nudgecli.config.ExperimentConfig`; import them from :mod:`nudgecli.config`.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, PrivateAttr, field_validator, model_validator
from pydantic_core import PydanticCustomError

from nudgecli.config_base import (
    MAX_RATE_HZ,
    MAX_TIME_LIMIT_S,
    Discount,
    PositiveFloat,
    Reward,
    Seconds,
    Section,
    check_range,
)
from nudgecli.model.mdp import DEFAULT_GAMMA, MDPRewards

#: The most blocks or prompts per label of a simulated calibration: the study's are 6 and 12; 1e8 filled
#: memory (the logs are arrays of every sample).
MAX_CALIBRATION_REPEATS = 1000
#: The most pressure samples one simulated distortion session (Phase 2) may record: its stream at
#: ``rate_hz`` over ``4 * prompts_per_label`` prompts of ``prompt_s + blank_s`` each. Each key within
#: its bound, all at their bounds ask for 2.9e10 samples (a simulated sample took about 230 bytes at its
#: peak: 1.6e6 of them 370 MB); the study's are 3,600, 1000 Hz with its prompts 360,000.
MAX_CALIBRATION_SAMPLES = 1_000_000
#: A duration of more than zero, up to :data:`MAX_TIME_LIMIT_S` seconds (finite: inf gave arrays of
#: negative size, an overflow, or a hold that never ends).
PositiveSeconds = Annotated[float, Field(gt=0, le=MAX_TIME_LIMIT_S, allow_inf_nan=False)]

#: The limits ``[population]`` checks each range against (``lo <= low <= high <= hi``): the one
#: place they are written (a people file's value is checked, and its message named, by them too).
POPULATION_RANGES: dict[str, tuple[float, float]] = {
    "soft_puff_level": (0.0, 1.5), "soft_sip_level": (0.0, 1.5), "hard_puff_level": (0.0, 1.5),
    "hard_sip_level": (0.0, 1.5), "soft_spread": (0.0, 1.0), "hard_spread": (0.0, 1.0),
    "onset_ramp_samples": (0, 20), "mapping_error": (0.0, 0.75), "epsilon": (0.0, 1.0),
    "rest_s": (0.0, 60.0), "operate_s": (0.1, 120.0), "action_pause_s": (0.0, 10.0),
    "hard_blow_s": (0.1, 5.0), "reaction_s": (0.0, 10.0), "handover_idle_s": (0.1, 30.0),
    "drift_correlation": (0.0, 0.99), "planning_s": (0.0, 60.0), "event_reaction_s": (0.0, 10.0),
    "event_reaction_log_sd": (0.0, 2.0), "hold_on_s": (0.0, 5.0), "hard_peak_s": (0.0, 5.0),
    "offset_ramp_samples": (0, 20), "deadband_share": (0.0, 0.9), "deadband_stray_s": (0.0, 5.0),
}


class PopulationSection(Section):
    """``[population]``: the ranges each simulated participant's true physiology and habits are drawn from.

    Every ``[low, high]`` pair is a uniform draw per participant (``onset_ramp_samples`` an integer
    draw, in 10 Hz samples like ``offset_ramp_samples``: the same durations at another
    ``study.rate_hz``); ``reaction_log_sd`` is one value for everyone. Pressure levels are magnitudes on the
    device's scale (sip positive, puff negative in the stream); a level above 1 means the person
    blows harder than the sensor reads, so most samples saturate at 1 the way real hard blows do.
    A blow's per-sample pressure is ``level + spread * z`` (after an onset ramp), clipped to [0, 1]
    on the intended side; ``z`` is N(0, 1) at every sample and drifts within a blow with lag-1
    correlation ``drift_correlation`` (``nudgecli.sim.pressure_model``).

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
    these ends are moved to cover eleven real people's calibrations (below).

    ``drift_correlation`` is ``log_drift_correlation``: the lag-1 correlation of the plateau
    samples' deviations from their label's fitted level, over consecutive pairs of one blow that
    are both unsaturated. The real pressure wanders slowly: from one 10 Hz tick to the next it
    moves 0.01-0.05 on average, three to six times less than independent draws with the same
    spread would. No pilot data exist for the task-level habits: ``epsilon`` brackets the study's
    0.1; ``operate_s`` the paper's 3-4 s border reminder; ``rest_s``, ``action_pause_s`` and
    ``hard_blow_s`` are short against the ~1 s idle handover, and a mode-switch blow outlasts the
    onset ramp so it reaches the hard band.

    Checked against eleven real people (issue 14; ``nudgecli.sim.real_population``,
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
        "deviation from its level (0: independent samples; rho ** (dt / 0.1) per sample at another "
        "study.rate_hz). Does not change the per-sample label "
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
        "(HABITS.md: 0.10-0.30 s), offset 0. The pulse's ramp samples read Hard too where their fraction "
        "of a high level passes the hard threshold: the measured time in the hard band is the peak + 0.09 s "
        "on average (docs/people.md, known limitations).")
    offset_ramp_samples: tuple[int, int] = Field(
        default=(0, 2),
        description="Samples a hard pulse takes to fall from its peak. The pilots' hard blows fell in a "
        "median "
        "1 (andrewtest) and 0 (deepaktest) samples; the upper end extended to 2 so a pulse (onset 1-3 + peak "
        "+ offset) reaches the real people's longest hard blows (HABITS.md: 0.30-0.80 s whole).")
    deadband_share: tuple[float, float] = Field(
        default=(0.045, 0.21),
        description="Share of a soft blow's time the pressure strays into the Soft-Hard deadband "
        "(behaviour.deadband_strays). The pilots' prompts had no robot to stop, so nothing there: the "
        "real people's share (HABITS.md, inside a soft blow: 0.045-0.21), the habit it produces one for "
        "one (nudgecli.sim.habit_ranges).")
    deadband_stray_s: tuple[float, float] = Field(
        default=(0.10, 0.30),
        description="Median time a stray stays in the deadband before the pressure is back in the soft "
        "band, s (behaviour.deadband_strays): the real people's deadband runs inside a soft blow "
        "(HABITS.md: medians 0.10-0.30 s), a stray of n samples being a run of n cells.")
    physiology_logs: tuple[str, ...] = Field(
        default=(),
        description="Calibration folders with a p(phi_m | phi_i) session (study export or tidy format): "
        "participant k takes the pressure physiology recorded in the k-th, the others are drawn; "
        "habits are always drawn. Relative paths are relative to the working directory.")

    #: where ``physiology_logs`` was written: the experiment file, or the ``--set`` that gave it
    #: (:meth:`logs_written_in`), for the line that refuses a folder that is not there; not a key
    _logs_source: str | None = PrivateAttr(default=None)

    def logs_written_in(self, source: str) -> None:
        """Record where ``physiology_logs`` was written (``experiments/x.toml``, ``--set KEY=VALUE``):
        :func:`nudgecli.config.load_experiment` does, once it has validated the experiment."""
        self._logs_source = source

    def logs_source(self) -> str | None:
        """Where ``physiology_logs`` was written (:meth:`logs_written_in`); ``None`` if unknown."""
        return self._logs_source

    def __eq__(self, other: object) -> bool:
        # where the list was written is not part of the experiment: pydantic's own equality
        # compares private attributes too, so a run folder's config.toml read back was unequal
        if not isinstance(other, PopulationSection):
            return NotImplemented
        return type(self) is type(other) and self.__dict__ == other.__dict__

    @field_validator("physiology_logs", mode="before")
    @classmethod
    def _folders(cls, value: object) -> object:
        # one folder's path, not a list of them: a list_type problem, whose example (the list the text
        # names, ["a", "b"] of "a,b") is config_files.format_validation_error's
        if isinstance(value, str):
            raise PydanticCustomError("list_type", "should be a list of folders of calibration logs (one per "
                                      "participant)")
        # an empty name is the working directory to a path (Path("").is_dir()), so it passed the check
        # that the folder is there and was read as a recording, refused naming no folder at all
        for position, folder in enumerate(value if isinstance(value, list | tuple) else ()):
            if folder == "":
                raise ValueError(f"entry [{position}] is empty (\"\"); name a participant's folder of "
                                 "calibration logs there, or remove the entry")
        return value

    @model_validator(mode="after")
    def _check(self) -> PopulationSection:
        for name, (lo, hi) in POPULATION_RANGES.items():
            check_range(name, getattr(self, name), lo, hi)
        return self


#: The ``[behaviour]`` keys of the person's own task costs, which their plan in the grid world is
#: solved with (``[model]``'s keys of the same names but ``plan_``, the agent's assumption of them).
PERSON_PLAN_KEYS = ("plan_gamma", "plan_move_reward", "plan_mode_switch_reward", "plan_bump_reward",
                    "plan_goal_reward")


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
      It sets how long "a soft blow that never moves the robot" lasts, for which HABITS.md has real
      people's figures (0.40 s [0.20, 0.70], people 0.20-1.25); the 1 s, a person's visual reaction
      with room to spare, is not fitted to them (``ciaa-teleop``, 50 people of seed 2020: 0.90 s;
      docs/people.md, "Known limitations of the operating habits").
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
    - ``deadband_strays``: within a soft blow the pressure stays in the soft band but for strays into
      the Soft-Hard deadband (the robot stops), which start at the person's rate (their
      ``population.deadband_share`` of the blow's time), last their ``deadband_stray_s`` and end
      back in the soft band, or, as HABITS.md counts, with the blow's end
      (``nudgecli.sim.behaviour_strays``); ``false``: the drawn pressure as it is, deadband readings
      included.

    The person's own plan: in the grid world they act on the greedy policy of their goal's MDP,
    solved with their own task costs, ``plan_gamma`` and the rewards ``plan_move_reward``,
    ``plan_mode_switch_reward``, ``plan_bump_reward`` and ``plan_goal_reward`` (``[model]``'s keys
    without ``plan_``, which are the agent's assumption of them). Their defaults are ``[model]``'s:
    a person who plans as the agent assumes, solved once. Set them apart from ``[model]`` to study
    an agent that assumes the wrong costs (``[model]`` changes the agent only; a condition without
    an agent, such as ``teleoperation``, does not read it). The CIAA path world's person follows the
    path's legs and refuses these keys.
    """

    decisions: Literal["events", "grid"] = "events"
    lean_on_blending: bool = True
    release_when_dragged: bool = True
    after_autonomy: Literal["replan", "resume"] = "replan"
    stall_s: Seconds = 1.0
    max_hold_s: PositiveSeconds = 3.0
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
    deadband_strays: bool = True
    plan_gamma: Discount = Field(
        default=DEFAULT_GAMMA, description="The discount of the person's own goal MDPs, in (0, 1) (the "
        "agent assumes model.gamma).")
    plan_move_reward: Reward = Field(
        default=MDPRewards.move, description="The person's own reward of a move (the agent assumes "
        "model.move_reward).")
    plan_mode_switch_reward: Reward = Field(
        default=MDPRewards.mode_switch, description="The person's own reward of a mode switch (the agent "
        "assumes model.mode_switch_reward).")
    plan_bump_reward: Reward = Field(
        default=MDPRewards.bump, description="The person's own reward of a move into a wall or another "
        "goal's cell (the agent assumes model.bump_reward).")
    plan_goal_reward: Reward = Field(
        default=MDPRewards.goal, description="The person's own reward of reaching and holding the goal "
        "pose (the agent assumes model.goal_reward).")


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

    ``prompt_s`` and ``blank_s`` are each at least one sample of the stream, ``1 / rate_hz`` (0.1 s at
    the study's 10 Hz): the estimator counts a prompt's samples from the one nearest its showing to
    the one nearest its blank, which a shorter prompt may not hold apart (with no prompt holding a
    sample, the fit failed); under a shorter blank a blow's release (its first sample at or after the
    blank) falls after the next prompt's showing, and is counted for that prompt.
    """

    mapping_blocks: int = Field(default=6, ge=1, le=MAX_CALIBRATION_REPEATS,
                                description="Blocks of the 12 prompted actions.")
    prompts_per_label: int = Field(default=12, ge=1, le=MAX_CALIBRATION_REPEATS)
    prompt_s: PositiveSeconds = 6.0
    blank_s: PositiveSeconds = 1.5
    answer_timeout_s: PositiveSeconds = 10.0
    answer_clear_s: Seconds = 0.5
    block_break_s: Seconds = 10.0
    # the study's own bound of its step rate: 1e9 Hz filled memory
    rate_hz: Annotated[float, Field(gt=0, le=MAX_RATE_HZ, allow_inf_nan=False)] = 10.0
    stream: Literal["fixed_rate", "event_driven"] = "fixed_rate"
    event_step: Annotated[float, Field(gt=0, le=0.1)] = Field(
        default=0.0109, description="Pressure quantisation of the event-driven stream (the sibling study's "
        "device stepped in about 0.0109).")

    @model_validator(mode="after")
    def _check_sample_durations(self) -> CalibrationSection:
        # one sample at least, so that a prompt's window (from the sample nearest its showing up to
        # the one nearest its blank) is never empty, and a blow's release sample (the event-driven
        # stream's "Zero Band" and "input stopped") stays in its own prompt's blank
        rate_hz = self.rate_hz  # the calibration stream's, not the study's (its step: StudySection.dt)
        sample_s = 1.0 / rate_hz
        for key, why in (("prompt_s", "a prompt may hold no sample to count"),
                         ("blank_s", "a blow's release may fall in the next prompt")):
            duration = getattr(self, key)
            # 1e-5: a bound the message prints (6 digits: 0.333333 s at 3 Hz) passes
            if duration * rate_hz < 1 - 1e-5:
                faster = f", or rate_hz >= {1.0 / duration:g}" if 1.0 / duration <= MAX_RATE_HZ else ""
                raise ValueError(
                    f"{key} = {duration:g} s is shorter than one sample of the stream at rate_hz = "
                    f"{rate_hz:g} (1 / rate_hz = {sample_s:g} s), so {why}; give {key} >= "
                    f"{sample_s:g}{faster} (the study's: {type(self).model_fields[key].default:g} s at "
                    "10 Hz)")
        return self

    @model_validator(mode="after")
    def _check_samples(self) -> CalibrationSection:
        samples = self.rate_hz * 4 * self.prompts_per_label * (self.prompt_s + self.blank_s)  # 4 labels
        if samples > MAX_CALIBRATION_SAMPLES:
            raise ValueError(
                f"rate_hz x 4 labels x prompts_per_label x (prompt_s + blank_s) = {self.rate_hz:g} x 4 x "
                f"{self.prompts_per_label} x ({self.prompt_s:g} + {self.blank_s:g}) = {samples:,.0f} "
                f"samples per calibration session, above the limit of {MAX_CALIBRATION_SAMPLES:,} (the "
                "study's is 3,600); lower one of them")
        return self
