"""Experiment files: the pydantic models of an experiment and how a file becomes one.

An experiment file is TOML with the sections below; every key has a default, unknown keys
fail with a "did you mean", and values are range-checked. Precedence: command-line flag >
``--set section.key=value`` > file > defaults. The presets (``paper``, ``study-code``,
``smoke``, ``ciaa-teleop``) live in the top-level ``experiments/`` folder and are shipped inside the wheel.

This module is the experiment's face: :class:`ExperimentConfig`, every section (the simulated
people's are written in :mod:`nudgecli.config_people`), :func:`load_experiment`,
:func:`experiment_from_toml` and :func:`section_defaults`. Presets, plans, TOML and ``--set`` parsing are
:mod:`nudgecli.config_files`; the sections' base and value types :mod:`nudgecli.config_base`.
"""

from __future__ import annotations

import functools
import json
import math
import tomllib
from typing import Annotated, Any, Literal, TypeVar, cast

from pydantic import (
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    ValidationError,
    field_validator,
    model_serializer,
    model_validator,
)

from nudgecli.config_base import (
    MAX_RATE_HZ,
    MAX_REWARD,
    MAX_TIME_LIMIT_S,
    MAX_TRIAL_STEPS,
    Discount,
    Distance,
    PositiveFloat,
    Probability,
    Reward,
    Seconds,
    Section,
    Speed,
)
from nudgecli.config_files import (
    dump_toml,
    format_validation_error,
    parse_override,
    read_toml,
    resolve_preset,
    validate_overridden,
)
from nudgecli.config_people import BehaviourSection, CalibrationSection, PopulationSection
from nudgecli.config_policies import CustomPolicySection
from nudgecli.config_switches import dependents_off_with_their_switch, switches_checked
from nudgecli.config_world import WorldSection, check_world_keys
from nudgecli.errors import ConfigError, did_you_mean
from nudgecli.model.conditions import PAPER_CONDITIONS, POLICIES
from nudgecli.model.disambiguation_settings import DisambiguationSettings
from nudgecli.model.hindsight import BLEND_PROB_DIFF_REQUIRED
from nudgecli.model.human_actions import DEFAULT_HUMAN_EPSILON
from nudgecli.model.interface import (
    DEFAULT_TABLE_NOISE,
    HARD_THRESHOLD_EARLY,
    SOFT_THRESHOLD_EARLY,
    ZERO_THRESHOLD,
)
from nudgecli.model.mdp import DEFAULT_GAMMA, MDPRewards

__all__ = [
    "CONDITION_NAMES", "CONDITION_SECTIONS", "MAX_REWARD", "AssistanceSection", "BehaviourSection",
    "BlendingPolicySection",
    "CalibrationSection", "DisambiguationSection", "ExperimentConfig", "ExperimentMeta", "HindsightSection",
    "InferenceSection", "InterfaceSection", "ModeSwitchSection", "ModelSection", "PopulationSection",
    "StudySection", "WorldSection", "experiment_from_toml", "load_experiment",
]


#: The most samples the Monte Carlo estimator of I(s) may draw (the study software's: 250): its draws
#: are held at once, so 1e9 asked for 805 GiB; 100,000 is about 80 MiB.
MAX_MI_SAMPLES = 100_000
#: The longest experiment name, in UTF-8 bytes: it names the run folder ``results/<name>-<UTC time>``,
#: and a file name past 255 bytes (most file systems' limit) failed only when the folder was made.
MAX_NAME_BYTES = 100


class ExperimentMeta(Section):
    """``[experiment]``: name and description of the experiment, and its default seed.

    ``name`` names the run folder (``results/<name>-<UTC time>``), so it must be a plain name:
    no path separator, not ``.`` or ``..``, no NUL, at most :data:`MAX_NAME_BYTES` bytes.
    """

    name: str = "experiment"
    description: str = ""
    seed: int = Field(default=2022, ge=0)

    @field_validator("name")
    @classmethod
    def _plain_name(cls, name: str) -> str:
        # a name such as "../../x" would put the default run folder outside results/
        if not name or name in (".", "..") or any(c in name for c in "/\\\0"):
            raise ValueError("must be a plain name (no / or \\, not . or .., not empty): it names the run "
                             "folder results/<name>-<time>; e.g. \"pilot-2\"")
        if (size := len(name.encode())) > MAX_NAME_BYTES:
            raise ValueError(f"{size} bytes is too long for a name; give at most {MAX_NAME_BYTES} (a plain "
                             "letter is one byte): it names the run folder results/<name>-<time>, and the "
                             "file system refuses a longer file name; e.g. \"pilot-2\"")
        return name


#: The assistance policies a ``[study] conditions`` list may name (``nudgecli.sim.policies``).
CONDITION_NAMES = POLICIES
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
    conditions: tuple[str, ...] = PAPER_CONDITIONS
    counterbalancing: Literal["williams", "williams-pair", "rotation"] = "williams"
    shared_layouts: int = Field(default=0, ge=0, le=100)
    goal_counts: tuple[int, ...] = (3, 4)
    corners: tuple[Literal["tr", "tl", "bl", "br"], ...] = ("tr", "tl", "bl", "br")
    start_modes: tuple[Literal["x", "y", "theta"], ...] = ("x", "y", "theta")
    blocks_per_condition: int = Field(default=3, ge=1)
    # finite and bounded: inf made a step of 0 s, and 1e6 Hz filled memory a trial at a time
    rate_hz: float = Field(default=10.0, ge=1.0, le=MAX_RATE_HZ, allow_inf_nan=False)
    time_limit_s: float = Field(default=120.0, gt=0.0, le=MAX_TIME_LIMIT_S, allow_inf_nan=False)
    success_distance: Distance = 1.0
    # a heading differs from the goal's by at most pi: a larger angle is every heading
    success_angle: Annotated[float, Field(gt=0, le=math.pi)] = 0.2

    @field_validator("conditions")
    @classmethod
    def _known_conditions(cls, conditions: tuple[str, ...]) -> tuple[str, ...]:
        # a name that is no built-in policy must be one of the experiment's [policies.NAME]:
        # ExperimentConfig checks it, where the sections are known
        if len(conditions) == 1:
            raise ValueError(f"only one condition ({conditions[0]!r}); a study compares two or more, "
                             "e.g. conditions = [\"disambiguation\", \"control\"]")
        return conditions

    @model_validator(mode="after")
    def _check(self) -> StudySection:
        if len(set(self.conditions)) != len(self.conditions) or not self.conditions:
            raise ValueError("conditions must be a non-empty list without repeats")
        for name in ("goal_counts", "corners", "start_modes"):
            # a repeat ran its layouts twice, unsaid: the design is each value once
            values = getattr(self, name)
            if len(set(values)) != len(values):
                raise ValueError(f"{name} must be a list without repeats (got {json.dumps(list(values))})")
        if self.counterbalancing == "williams" and len(self.conditions) % 2:
            k = len(self.conditions)
            raise ValueError(f"counterbalancing = 'williams' cannot balance {k} conditions "
                             "(one Williams square needs an even count); use 'williams-pair' (the square and "
                             "its mirror), 'rotation' (k cyclic shifts) or list an even number of conditions")
        for g in self.goal_counts:
            if g < 2:
                # one goal fits the goal regions; what a study of it lacks is a choice: the belief is
                # certain from the start, and at the paper's rho1 = 1.1 / 1 goal alpha stays 0
                one = ("leaves the agent nothing to infer (its belief is certain from the start, and at the "
                       "paper's assistance.rho1_factor = 1.1 blending never acts, alpha = 0)")
                none = "make no layout (a layout has at least one goal, and the agent needs two)"
                what = one if g == 1 else none
                raise ValueError(f"goal_counts: {g} goal{'' if g == 1 else 's'} {what}; use 2 to 8")
            if g > 8:
                raise ValueError(f"goal_counts: {g} goals do not fit the goal regions; use 2 to 8")
        if not self.goal_counts or not self.corners or not self.start_modes:
            raise ValueError("goal_counts, corners and start_modes must not be empty")
        if self.time_limit_steps < 1:  # the protocol's count of a trial's steps
            steps = self.time_limit_s * self.rate_hz
            raise ValueError(f"study.time_limit_s * study.rate_hz = {steps:g} gives "
                             "no step a trial; give a time limit of at least one step (1 / rate_hz s)")
        trials = self.trials_per_condition
        if trials % self.blocks_per_condition:
            raise ValueError(
                f"blocks_per_condition={self.blocks_per_condition} does not divide the {trials} trials "
                "of each condition")
        return self

    @property
    def dt(self) -> float:
        """The length of one step, s (``1 / rate_hz``): the protocol's and the person's clock."""
        return 1.0 / self.rate_hz

    @property
    def time_limit_steps(self) -> int:
        """The most steps a trial runs: the whole steps within ``time_limit_s``, rounded down (50.06 s
        at 10 Hz runs 500, never to 50.1 s); the 1e-9 keeps 120 / 0.1 = 1199.99... whole."""
        return int(self.time_limit_s / self.dt + 1e-9)  # int() is floor: the limit is positive

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
    human_speed: Speed = 3.0  # world units/s, at most MAX_SPEED (nudgecli.config_base)
    human_turn_rate: Speed = 1.95  # rad/s

    @model_validator(mode="after")
    def _check(self) -> InterfaceSection:
        if not self.zero_threshold < self.soft_threshold <= self.hard_threshold:
            raise ValueError("thresholds must satisfy zero_threshold < soft_threshold <= hard_threshold")
        return self


class ModelSection(Section):
    """``[model]``: the human model the agent assumes (goal MDPs, epsilon-greedy policy, tables).

    The agent's assumption only: the simulated person plans with their own task costs
    (``[behaviour]`` ``plan_gamma`` and the ``plan_*_reward`` keys, whose defaults are these
    defaults) and slips with their own epsilon (``[population]``), so an agent that assumes other
    costs than the person's is a setting, and a condition without an agent never reads ``[model]``.
    """

    # the study's values, where the goal MDPs are defined (nudgecli.model.mdp)
    epsilon: float = Field(default=DEFAULT_HUMAN_EPSILON, description="Eq. 1's epsilon, in (0, 1).")
    gamma: Discount = DEFAULT_GAMMA
    move_reward: Reward = MDPRewards.move
    mode_switch_reward: Reward = MDPRewards.mode_switch
    bump_reward: Reward = MDPRewards.bump
    goal_reward: Reward = MDPRewards.goal
    tables: Literal["fitted", "default"] = Field(
        default="fitted",
        description="fitted: tables estimated from each participant's (simulated) calibration; "
        "default: 0.8 one-hot + 0.2 uniform for everyone.")
    default_table_noise: Probability = DEFAULT_TABLE_NOISE

    @field_validator("epsilon")
    @classmethod
    def _epsilon_in_open_interval(cls, epsilon: float) -> float:
        # at 0 a label that no goal's optimal action gives (with noiseless tables) is impossible
        # under every goal and the Bayesian update cannot normalise; NaN fails the comparison too.
        # Any epsilon > 0 keeps every label possible whatever default_table_noise is (tests pin it)
        if not 0.0 < epsilon < 1.0:
            raise ValueError("must lie in (0, 1), both ends excluded (the paper's Eq. 1): at 0 the assumed "
                             "person takes only each goal's optimal action, so an input no goal's optimal "
                             "action gives has zero probability under every goal and goal inference stops; "
                             "at 1 the inputs say nothing about the goal; e.g. 0.1")
        return epsilon


class InferenceSection(Section):
    """``[inference]``: the goal-transition model, the study's forgetting and the confidence threshold."""

    goal_stay: Annotated[float, Field(gt=0, le=1)] = Field(
        default=1.0,
        description="p(g_t = g_{t-1}); 1 is the identity of Eq. 7, else the rest is spread evenly.")
    decay: bool = False
    # counts of a trial's samples, so at most the most a trial has (1e30 overflowed numpy's integers)
    decay_delay: int = Field(default=10, ge=0, le=MAX_TRIAL_STEPS)
    decay_rate: Annotated[float, Field(ge=0)] = 0.008
    decay_cap: int = Field(default=1000, ge=1, le=MAX_TRIAL_STEPS)
    kappa: Annotated[float, Field(gt=0, le=1)] = 0.65
    update: Literal["action", "sample"] = Field(
        default="action",
        description="action: one Bayesian update per task-level input event (a new blow, or a change of "
        "measured label within a blow), as Algorithm 1 draws one a^t per update; sample: one update per "
        "labelled 10 Hz sample (the study software).")
    # a key its switch turns off is refused, never ignored (nudgecli.config_switches)
    _keys_of_its_switches = switches_checked("inference")


#: The model's defaults of D(s), which ``[disambiguation]`` takes.
_DISAMBIGUATION = DisambiguationSettings()


class DisambiguationSection(Section):
    """``[disambiguation]``: D(s) = mi_weight * I(s) - distance_weight * R(s) and its search domain."""

    # the defaults are the model's (nudgecli.model.disambiguation.DisambiguationSettings)
    estimator: Literal["exact", "monte_carlo"] = _DISAMBIGUATION.estimator
    samples: int = Field(default=_DISAMBIGUATION.samples, ge=1, le=MAX_MI_SAMPLES)
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
    # a key its switch turns off is refused, never ignored (nudgecli.config_switches)
    _keys_of_its_switches = switches_checked("disambiguation")


class AssistanceSection(Section):
    """``[assistance]``: blending during the human's turn and the autonomy's motion."""

    rho1_factor: PositiveFloat = 1.1
    rho2_factor: PositiveFloat = 1.2
    rho3: Probability = 0.8
    entropy_gate: bool = False
    startup_delay_s: Seconds = 0.0  # at most an hour, the longest trial (1e30 hung the run)
    distance_weighting: bool = False
    distance_knee: Distance = Field(
        default=35.0, description="Distance weight: 1 - drop d / knee up to the knee (world units), then "
        "(1 - drop) exp(-(d - knee)) (the study software's values).")
    distance_drop: Annotated[float, Field(ge=0, lt=1)] = 0.4
    autonomy_speed: Speed = 5.0
    autonomy_turn_rate: Speed = 1.5
    arrival_tolerance: Distance = 0.1

    # a key its switch turns off is refused, never ignored (nudgecli.config_switches)
    _keys_of_its_switches = switches_checked("assistance")

    @model_validator(mode="after")
    def _check(self) -> AssistanceSection:
        if self.rho2_factor <= self.rho1_factor:
            raise ValueError("rho2_factor must be greater than rho1_factor")
        return self


class BlendingPolicySection(Section):
    """``[blending]``: the ``blending`` condition, policy blending without turn-taking.

    ``kind = "convex"``: alpha is the paper's piecewise rule of ``[assistance]`` (``rho1_factor``,
    ``rho2_factor``, ``rho3`` and its gates); ``kind = "additive"``: ADA's blend, the leading goal's
    whole Huber-cost assistance, with ``[hindsight]``'s ``strength`` and ``zone`` (set or derived):
    ADA's blend and its hindsight policy add one and the same assistance per goal, so those two
    keys change this condition too. ``gate = "gap"`` (the default, as ADA's code always gates) assists
    only while the two highest beliefs differ by more than ``gap`` (unset: ADA's
    ``BLEND_PROB_DIFF_REQUIRED``, 0.4); ``gate = "none"`` never gates (a ``gap`` beside it is
    refused, not ignored; the additive blend then assists a unique leader only).
    """

    kind: Literal["convex", "additive"] = "convex"
    gate: Literal["none", "gap"] = "gap"
    gap: Annotated[float, Field(ge=0, lt=1)] = BLEND_PROB_DIFF_REQUIRED

    @model_validator(mode="before")
    @classmethod
    def _gap_of_gate(cls, data: Any) -> Any:
        # the gap belongs to the gate: given without it, it was silently ignored
        if isinstance(data, dict) and data.get("gate", "gap") == "none" and "gap" in data:
            raise ValueError(f"gap: {data['gap']} is not used with gate = \"none\" (no gate); remove gap, "
                             "or set gate = \"gap\" to assist only while the top goal leads by more than gap")
        return data

    @model_serializer(mode="wrap")
    def _no_gap_without_gate(self, handler: SerializerFunctionWrapHandler) -> dict[str, Any]:
        # a run folder's config.toml must load again: without the gate its gap is no setting
        data = cast(dict[str, Any], handler(self))
        if self.gate == "none":
            data.pop("gap", None)
        return data


class ModeSwitchSection(Section):
    """``[mode-switch]``: the ``mode-switch`` condition (the autonomy's turn only changes the mode).

    ``criterion`` names the rule that chooses the mode, over the states that differ from the
    current one in mode alone: ``paper-mi`` the seed paper's D(s) of ``[disambiguation]`` (its
    mutual information: the distance term is equal for these states); ``gopinath2017`` Gopinath &
    Argall's (2017) disambiguation metric of projected beliefs; ``gopinath2017-kl`` its KL variant;
    ``herlant2016`` Herlant et al.'s (2016) time-optimal mode for the most likely goal
    (docs/baselines.md cites each source). ``trigger``: ``handover`` selects the mode in the
    autonomy's turn after the person's idle handover (the paper's turn-taking); ``request`` has no
    turns and answers each mode switch the person makes with the criterion's best other mode (the
    sources' user request, here the person's own mode-switch blow).
    """

    criterion: Literal["paper-mi", "gopinath2017", "gopinath2017-kl", "herlant2016"] = "paper-mi"
    trigger: Literal["handover", "request"] = "handover"


class HindsightSection(Section):
    """``[hindsight]``: the ``hindsight`` condition, first-order hindsight optimisation as the
    authors' open code computes it (personalrobotics/ada_assistance_policy; docs/baselines.md).

    Every step the belief-weighted sum of each goal's Huber-cost assistance is added to the
    person's command. ``strength``: the assistance far from a goal over the person's full command
    (unset: the source's ratio, 0.306, ``nudgecli.model.hindsight.SOURCE_STRENGTH``); ``zone``: the
    Huber zone around each goal inside which it slows (world units; unset: the source's 0.07 m
    scaled by the person's speed over the source user's, 1.05 units); ``assist``: ``always`` (the
    source: every step, input or not) or ``on-command`` (only on steps with a motion command).
    """

    strength: Annotated[float, Field(gt=0, le=10)] | None = None
    zone: Annotated[float, Field(gt=0, le=50)] | None = None
    assist: Literal["always", "on-command"] = "always"


class ExperimentConfig(Section):
    """A whole experiment file."""

    experiment: ExperimentMeta = Field(default_factory=ExperimentMeta)
    study: StudySection = Field(default_factory=StudySection)
    interface: InterfaceSection = Field(default_factory=InterfaceSection)
    model: ModelSection = Field(default_factory=ModelSection)
    inference: InferenceSection = Field(default_factory=InferenceSection)
    disambiguation: DisambiguationSection = Field(default_factory=DisambiguationSection)
    assistance: AssistanceSection = Field(default_factory=AssistanceSection)
    population: PopulationSection = Field(default_factory=PopulationSection)
    behaviour: BehaviourSection = Field(default_factory=BehaviourSection)
    calibration: CalibrationSection = Field(default_factory=CalibrationSection)
    world: WorldSection = Field(default_factory=WorldSection)
    # the policies' own sections: absent unless the experiment lists their condition
    blending: BlendingPolicySection | None = None
    mode_switch: ModeSwitchSection | None = Field(default=None, alias="mode-switch")
    hindsight: HindsightSection | None = None
    # a researcher's own policies, by condition name
    policies: dict[str, CustomPolicySection] | None = None
    # the folder their modules are imported from (the experiment file's; never written out)
    policy_search_path: str | None = Field(default=None, exclude=True)

    model_config = ConfigDict(extra="forbid", validate_assignment=True, frozen=True, populate_by_name=True,
                              defer_build=True)

    @model_validator(mode="before")
    @classmethod
    def _no_search_path(cls, data: Any) -> Any:
        # set by load_experiment from the file's own folder; a file or --set naming another folder
        # would run other code than the experiment's folder holds
        if isinstance(data, dict) and "policy_search_path" in data:
            raise ValueError("unknown key 'policy_search_path': it is internal (a policy module is "
                             "imported from the experiment file's folder, then from sys.path: "
                             "docs/policies.md); remove it")
        return data

    @model_validator(mode="before")
    @classmethod
    def _keys_its_world_reads(cls, data: Any) -> Any:
        # a key the chosen world does not read is refused, never ignored (nudgecli.config_world); before
        # the sections' own checks, which would advise on what that world never reads
        if isinstance(data, dict):
            sections = {"study": StudySection, "interface": InterfaceSection, "world": WorldSection,
                        "model": ModelSection, "inference": InferenceSection,
                        "disambiguation": DisambiguationSection, "assistance": AssistanceSection,
                        "behaviour": BehaviourSection}
            check_world_keys(data, sections)
        return data

    @model_validator(mode="after")
    def _check_policy_sections(self) -> ExperimentConfig:
        own = self.policies or {}
        for name in own:
            if not name.strip() or name != name.strip():
                # a blank name makes a condition no table, plan or figure can name
                raise ValueError(f"policies: [policies.{json.dumps(name)}] has no name a condition can go by "
                                 "(empty, or spaces around it); name it, e.g. [policies.threshold], and list "
                                 "that name in study.conditions")
            if name in CONDITION_NAMES:
                raise ValueError(f"[policies.{name}] reuses the built-in policy's name {name!r}; give your "
                                 "policy a name of its own")
        for name in self.study.conditions:
            if name not in CONDITION_NAMES and name not in own:
                known = (*CONDITION_NAMES, *own)
                raise ValueError(f"study.conditions: unknown condition {name!r}{did_you_mean(name, known)}; "
                                 f"known: {', '.join(known)} (or define your own in a [policies.{name}] "
                                 "section: docs/policies.md)")
        if self.world.kind != "grid":
            return self
        for condition in self.study.conditions:
            field_name = CONDITION_SECTIONS.get(condition)
            if field_name is not None and getattr(self, field_name) is None:
                example = {"blending": 'gate = "gap"', "mode-switch": 'criterion = "paper-mi"',
                           "hindsight": 'assist = "always"'}[condition]
                key, value = example.split(" = ")
                raise ValueError(f"study.conditions lists {condition!r} but there is no [{condition}] "
                                 f"section with its settings; add one, e.g. [{condition}] {example} (or "
                                 f"--set {condition}.{key}={value.strip(chr(34))})")
        return self

    @model_validator(mode="after")
    def _check_alpha_ramp(self) -> ExperimentConfig:
        # the paper's rho_i = rho_i_factor / G are thresholds on the top belief, so lie in [0, 1]:
        # above 1 the ramp never opens (alpha 0 throughout) for that goal count
        if self.world.kind != "grid":
            return self
        ass, fewest = self.assistance, min(self.study.goal_counts)
        if max(ass.rho1_factor, ass.rho2_factor) > fewest:
            raise ValueError(f"assistance.rho1_factor = {ass.rho1_factor:g} and rho2_factor = "
                             f"{ass.rho2_factor:g} over {fewest} goals (study.goal_counts) give rho_1 = "
                             f"{ass.rho1_factor / fewest:.3g} and rho_2 = {ass.rho2_factor / fewest:.3g}, "
                             "thresholds on the top belief, which the paper keeps in [0, 1] (above 1 the "
                             f"ramp never completes or never opens); keep both factors at most {fewest}, the "
                             "fewest goals")
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


def load_experiment(name_or_path: str, overrides: list[str] | tuple[str, ...] = ()) -> ExperimentConfig:
    """Read an experiment preset or file, check it, apply the ``--set`` overrides together, validate
    (a file refused on its own is taken when the overrides mend it; else the refusal names the file).

    Raises
    ------
    ConfigError
        With one line naming the file (or ``--set``), the field and the fix.
    """
    path = resolve_preset(name_or_path, "experiments")
    data = read_toml(path)
    refused = None
    try:  # the file on its own, but for a condition's section that only the overrides write
        ExperimentConfig.model_validate(_with_sections_set(data, overrides))
    except ValidationError as exc:  # refused unless the overrides mend it (--set blending.gate=gap)
        refused = ConfigError(format_validation_error(exc, str(path), ExperimentConfig, data))
    data = dependents_off_with_their_switch(data, overrides)
    config = validate_overridden(ExperimentConfig, data, overrides, refused, str(path))
    logs_set = [text for text in overrides if parse_override(text)[0] == ["population", "physiology_logs"]]
    config.population.logs_written_in(f"--set {logs_set[-1]}" if logs_set else str(path))  # for its refusal
    if config.policies:  # a researcher's policy modules are imported from beside the experiment file
        config = config.model_copy(update={"policy_search_path": str(path.resolve().parent)})
    return config


def _with_sections_set(data: dict[str, Any], overrides: list[str] | tuple[str, ...]) -> dict[str, Any]:
    """``data`` with an empty table for each condition's section (``[blending]``, ``[mode-switch]``,
    ``[hindsight]``) it lacks and a ``--set`` writes into (``--set blending.gate=gap``): the file's
    only fault is then no fault, and any other is still the file's own."""
    written = {path[0] for path, _ in map(parse_override, overrides)}
    missing: dict[str, Any] = {}
    for spellings in ({condition, field} for condition, field in CONDITION_SECTIONS.items()):
        if spellings & written and not spellings & data.keys():  # [mode-switch] or mode_switch
            missing[min(spellings & written)] = {}
    return {**data, **missing} if missing else data


def experiment_from_toml(text: str, source: str = "config.toml") -> ExperimentConfig:
    """Validate an experiment given as TOML text (e.g. a run folder's ``config.toml``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: invalid TOML: {exc}") from exc
    try:
        return ExperimentConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source, ExperimentConfig, data)) from None


SectionT = TypeVar("SectionT", bound=Section)


def section_defaults(section: type[SectionT]) -> SectionT:
    """``section`` with every default, made once per class and unvalidated: the defaults are the
    fields' own values, and validating them would build the section's validator, which a worker
    (sent its experiment pickled) never needs otherwise."""
    return cast(SectionT, _section_defaults(section))


@functools.cache
def _section_defaults(section: type[Section]) -> Section:
    return section.model_construct()
