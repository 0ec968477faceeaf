"""The assistance policy interface: what a policy sees each 10 Hz step and what it returns.

Every condition of a study runs one policy through the same protocol
(:class:`nudgecli.sim.protocol.TrialSession`), world and simulated people. The built-in policies
(:mod:`nudgecli.sim.builtin_policies`) and a researcher's own (named in an experiment file by import
path, :mod:`nudgecli.sim.policy_registry`) implement the same :class:`Policy` protocol, so the
protocol never branches on a policy's name.

A policy object lives for one trial: the protocol makes a fresh one (``factory(**params)``) when a
trial starts. Each step of the human's turn it calls :meth:`Policy.assist`; when the person hands
the turn over (only for a policy whose ``takes_turns`` is true) it calls :meth:`Policy.start_turn`
once, and drives the robot to the returned target at the autonomy's speeds, then hands back.

A minimal policy (assist only when the leading goal's probability passes a threshold)::

    from nudgecli.sim.policy_interface import Assistance, AutonomyTurn, StepView, drive_towards

    class Threshold:
        infers = True           # the protocol runs Eq. 7 for it: view.belief is the posterior
        takes_turns = False     # the person's turn is the whole trial

        def __init__(self, threshold: float = 0.6, weight: float = 0.5) -> None:
            self.threshold, self.weight = threshold, weight

        def assist(self, view: StepView) -> Assistance:
            goal = view.leader
            if goal < 0 or view.leader_probability < self.threshold or not any(view.u_h):
                return Assistance(view.u_h)
            u_a = drive_towards(view, view.goal_poses[goal])
            return Assistance.convex(view.u_h, u_a, self.weight, goal)

        def start_turn(self, view: StepView) -> AutonomyTurn:
            return AutonomyTurn.stay()
"""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol, TypeVar, runtime_checkable

import numpy as np

from nudgecli.model import assistance
from nudgecli.model.interface import NO_COMMAND
from nudgecli.model.read_only import read_only_array as read_only_array  # the policies' owner
from nudgecli.steplog import MODE_SELECT, NO_GOAL, NUDGE, STEP

if TYPE_CHECKING:
    from nudgecli.model.disambiguation import DisambiguationModel
    from nudgecli.model.world import World
    from nudgecli.sim.protocol import ProtocolSettings

#: An object a policy's view shows (:func:`read_only_view`).
SourceT = TypeVar("SourceT")

#: A command ``(vx, vy, omega)``: units/s along x and y, rad/s (a tuple or a ``(3,)`` array).
Command = tuple[float, float, float] | np.ndarray


class StepView(Protocol):
    """What a policy sees at a step: the trial's session, live, through a :class:`ReadOnlyView`
    (assigning or deleting an attribute raises, and its arrays are read-only).

    Attributes
    ----------
    x, y, theta
        The robot's pose at the start of the step (world units, rad).
    mode
        The active mode: 0 x, 1 y, 2 theta.
    state
        The discrete state of the pose and mode (the world's; the grid world's 2400 states).
    step
        Steps since the trial started (``step * settings.dt`` seconds).
    turn
        Always ``"human"`` as a policy sees it: :meth:`Policy.assist` and the hooks run in the
        person's turn, and :meth:`Policy.start_turn` is called as the person hands over, before the
        turn passes to the autonomy (whose steps the step log's ``turn`` column records).
    goal_poses
        ``(G, 3)`` the layout's goal poses.
    belief
        ``(G,)`` the agent's belief over the goals (Eq. 7; uniform for a policy that does not infer).
    leader
        The goal with the unique highest belief, or -1 when two or more tie (no ``g'``).
    leader_probability
        The highest belief.
    entropy
        The belief's normalised entropy ``H(b) / log G``.
    measured
        This step's measured label (0 Hard Puff, 1 Hard Sip, 2 Soft Puff, 3 Soft Sip, -1 none;
        the deadbands are -2 and -3).
    u_h
        This step's human command ``(vx, vy, omega)`` (zero without a soft label).
    initiated_at
        The step of the turn's first measured input, -1 before it.
    model
        The agent's model of this participant in this layout (``p(phi_m | g, s)``), whether the
        policy infers or not (a criterion may read it); ``None`` where the trial has none.
    goal_transition
        ``(G, G)`` ``p(g_t | g_{t-1})`` of Eq. 6, or ``None`` for the identity (the paper's).
    rng
        The agent's random stream (draw from it only: a run is a pure function of its seed).
    settings
        The protocol's knobs (``dt``, the autonomy's ``autonomy_speed`` and ``autonomy_turn_rate``,
        the person's ``human_speed`` and ``human_turn_rate``, ...).
    world
        The trial's world, read-only (:class:`WorldView`): its goals, start and pure queries.
    """

    x: float
    y: float
    theta: float
    mode: int
    step: int
    turn: str
    goal_poses: np.ndarray
    belief: np.ndarray
    leader: int
    leader_probability: float
    entropy: float
    measured: int
    u_h: Command
    initiated_at: int
    model: DisambiguationModel | None
    goal_transition: np.ndarray | None
    rng: np.random.Generator
    settings: ProtocolSettings
    world: Any  # a WorldView (the view of a session shows the session's world through one)

    @property
    def state(self) -> int: ...


class ReadOnlyView:
    """A live view of an object that a policy may read but not change (its trial's ``view``).

    Made by :func:`read_only_view`: it shares its source's attribute dictionary (one ``__dict__``
    for both), so each read sees the source as it is now at a plain attribute read's cost (the trial
    loop is hot: no copy per step, no property per attribute), while assigning or deleting any
    attribute raises :class:`AttributeError` naming it: a policy acts only through what it returns.
    """

    __slots__ = ()

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(_read_only_message(name))

    def __delattr__(self, name: str) -> None:
        raise AttributeError(_read_only_message(name))


def _read_only_message(name: str) -> str:
    return (f"the view is read-only: a policy cannot set view.{name} (it acts only through the "
            "Assistance or AutonomyTurn it returns)")


#: What a view never hands a policy, beside its source's methods: the records the source keeps of
#: the trial (a list a policy could append to or clear).
HIDDEN_RECORDS = ("rows", "pending_events", "columns")

#: Nor the policy itself, or its hooks, as the source holds them (a policy is ``self`` to itself).
HIDDEN_POLICY = ("policy", "choose_mode", "assist_quiet")

#: Nor the trial's specification: it holds the person's true goal, which the agent never observes
#: (a policy that read it would be told the answer its inference is there to find).
HIDDEN_ANSWERS = ("spec",)


class _Hidden:
    """A name of the source that its view does not hand out: reading it raises AttributeError
    (a data descriptor on the view's class, so it comes before the shared ``__dict__``)."""

    def __init__(self, name: str) -> None:
        self.name = name

    def __get__(self, view: object, owner: type | None = None) -> Any:
        raise AttributeError(f"a policy's view has no {self.name}: it reads the trial's state "
                             "(docs/policies.md, 'What a policy sees') and acts only through the "
                             "Assistance or AutonomyTurn it returns")

    def __set__(self, view: object, value: Any) -> None:
        raise AttributeError(_read_only_message(self.name))


class WorldView(ReadOnlyView):
    """What a policy sees of its trial's world (``view.world``): the goals, the start and the
    world's pure queries (:class:`~nudgecli.model.world.World`), read-only.

    Not :meth:`~nudgecli.model.world.World.move` (a path world keeps per-trial state that its moves
    update: the waypoint reached, whether the turn is done) nor the world's own attributes (its
    layout, which trials share): reading any other name raises :class:`AttributeError` naming it,
    and so does assigning one.
    """

    __slots__ = ("_world",)

    def __init__(self, world: World) -> None:
        object.__setattr__(self, "_world", world)

    @property
    def n_goals(self) -> int:
        """Number of goals of the trial."""
        return int(self._world.n_goals)

    @property
    def goal_poses(self) -> np.ndarray:
        """``(G, 3)`` the goals' poses (read-only)."""
        return read_only_array(self._world.goal_poses)

    @property
    def start_pose(self) -> np.ndarray:
        """``(3,)`` the robot's start pose (read-only)."""
        return read_only_array(self._world.start_pose)

    @property
    def start_mode(self) -> int:
        """The mode the trial starts in."""
        return int(self._world.start_mode)

    def state(self, x: float, y: float, theta: float, mode: int) -> int:
        """The discrete state of a pose and mode (``view.state`` is the robot's)."""
        return self._world.state(x, y, theta, mode)

    def cells(self, state: int) -> tuple[int, int, int]:
        """``(cell_x, cell_y, heading)`` of a discrete state, as the step log records them."""
        return self._world.cells(state)

    def goal_reached(self, x: float, y: float, theta: float) -> int:
        """The goal whose success rule a pose meets, or -1."""
        return self._world.goal_reached(x, y, theta)

    def next_mark(self, coordinate: float, direction: float, axis: int) -> float:
        """The next mark a person sees along ``axis`` strictly beyond ``coordinate`` in ``direction``."""
        return self._world.next_mark(coordinate, direction, axis)

    def holds_still(self, x: float, y: float, theta: float, velocity: Command) -> bool:
        """Whether a command ``velocity`` leaves the robot at the pose (moves nothing)."""
        return self._world.holds_still(x, y, theta, velocity)

    def __getattr__(self, name: str) -> Any:
        raise AttributeError(f"a policy's view of the world has no {name}: it shows the goals, the "
                             "start and the pure queries (state, cells, goal_reached, next_mark, "
                             "holds_still; docs/policies.md, 'What a policy sees'), and a policy acts "
                             "only through the Assistance or AutonomyTurn it returns")

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(_read_only_message(f"world.{name}"))

    def __delattr__(self, name: str) -> None:
        raise AttributeError(_read_only_message(f"world.{name}"))


class _ShownAsWorld:
    """The source's ``world``, as its view shows it: a :class:`WorldView`, made at the first read
    and kept in the view's own slot while the source's world stays the same object."""

    def __get__(self, view: Any, owner: type | None = None) -> Any:
        if view is None:
            return self
        world, shown = view.__dict__.get("world"), view._shown_world
        if shown is None or shown._world is not world:
            shown = None if world is None else WorldView(world)
            object.__setattr__(view, "_shown_world", shown)
        return shown

    def __set__(self, view: object, value: Any) -> None:
        raise AttributeError(_read_only_message("world"))


@functools.cache
def _read_only_class(source_class: type) -> type:
    """``source_class`` with :class:`ReadOnlyView`'s assignment rule first (its properties kept),
    neither its methods (a method called through the view would act on the source) nor
    :data:`HIDDEN_RECORDS`, :data:`HIDDEN_POLICY` and :data:`HIDDEN_ANSWERS` reachable, and its
    ``world`` a :class:`WorldView`."""
    hidden = {name for name in dir(source_class) if not name.startswith("__")
              and callable(getattr(source_class, name)) and not isinstance(getattr(source_class, name), type)}
    hidden.update(HIDDEN_RECORDS + HIDDEN_POLICY + HIDDEN_ANSWERS)
    namespace: dict[str, Any] = {"__slots__": ("_shown_world",), "world": _ShownAsWorld(),
                                 **{name: _Hidden(name) for name in sorted(hidden)}}
    return type(f"ReadOnly{source_class.__name__}", (ReadOnlyView, source_class), namespace)


def read_only_view(source: SourceT) -> SourceT:
    """A :class:`ReadOnlyView` of ``source``: its attributes and properties, live, none assignable.

    ``source`` keeps its own attributes in a ``__dict__``; the view holds that dictionary, so it
    lives as long as the view does. Keep the view outside that dictionary (a slot of ``source``):
    inside it, the two would be a reference cycle only the garbage collector frees.
    """
    source_class: type = type(source)
    view: SourceT = object.__new__(_read_only_class(source_class))
    object.__setattr__(view, "__dict__", source.__dict__)
    object.__setattr__(view, "_shown_world", None)
    return view


class Assistance(NamedTuple):
    """What a policy does in one step of the human's turn.

    Attributes
    ----------
    command
        ``(3,)`` the command executed this step, ``u_f``: for a researcher's policy at most
        ``human_speed + autonomy_speed`` units/s (``hypot(vx, vy)``) and ``human_turn_rate +
        autonomy_turn_rate`` rad/s (:func:`nudgecli.sim.policy_registry.command_limits`).
    u_a
        ``(3,)`` the assistance's own command (the step log's ``u_a``).
    alpha
        The assistance's weight in ``command``, from 0 to 1: ``u_f = alpha u_a + (1 - alpha) u_h``
        for a convex blend, ``u_f = u_h + alpha u_a`` for an additive one; 0 when it does not act. The
        engagement and strength metrics read it (a step is engaged when alpha > 0 and ``goal`` is
        the true goal).
    goal
        The goal the assistance acts for (the step log's ``inferred_goal``), -1 for none.
    """

    command: Command
    u_a: Command = NO_COMMAND
    alpha: float = 0.0
    goal: int = NO_GOAL

    @classmethod
    def convex(cls, u_h: Command, u_a: Command, alpha: float, goal: int) -> Assistance:
        """``u_f = alpha u_a + (1 - alpha) u_h`` (the paper's blending, Algorithm 1 line 8)."""
        return cls(assistance.blend_command(checked_command(u_a, "u_a"), checked_command(u_h, "u_h"), alpha),
                   u_a, alpha, goal)

    @classmethod
    def additive(cls, u_h: Command, u_a: Command, goal: int) -> Assistance:
        """``u_f = u_h + u_a`` (alpha 1: the whole assistance is added to the person's command).

        Two tuples of three numbers whose sums are Python floats (the built-in policies' commands,
        every step of hindsight) give a tuple: numpy's float64 sum bit for bit without the array;
        anything else (numpy scalars or arrays among them) is numpy's sum, an array in its dtype."""
        if type(u_h) is tuple and type(u_a) is tuple and len(u_h) == 3 == len(u_a):
            vx, vy, omega = u_h[0] + u_a[0], u_h[1] + u_a[1], u_h[2] + u_a[2]
            if type(vx) is float and type(vy) is float and type(omega) is float:
                return cls((vx, vy, omega), u_a, 1.0, goal)
        return cls(np.add(u_h, u_a), u_a, 1.0, goal)


#: A stretch of a quiet run (:meth:`Policy` ``assist_quiet``): ``(count, assistance)``, the
#: assistance of each of ``count`` consecutive steps.
QuietRun = tuple[int, Assistance]


class AtStep(ReadOnlyView):
    """``view`` as it would be at ``step`` of a quiet run (every other attribute is the view's own):
    what a policy's ``assist_quiet`` passes to :meth:`Policy.assist` for a later step of the run;
    read-only as the view is."""

    def __init__(self, view: StepView, step: int) -> None:
        object.__setattr__(self, "_view", view)
        object.__setattr__(self, "step", step)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._view, name)


#: The step log's events a policy's :class:`AutonomyTurn` may name (the protocol writes the others).
TURN_EVENTS = (NUDGE, STEP, MODE_SELECT)


@dataclass(frozen=True)
class AutonomyTurn:
    """What the autonomy does in its turn, chosen once when the person hands the turn over.

    Attributes
    ----------
    target
        ``(3,)`` the pose the autonomy drives to at its own speeds (the turn ends within
        ``arrival_tolerance`` of its position, so it must be inside the workspace less the robot's
        radius), or ``None``: the turn is one step that does not move.
    mode
        The mode to switch to at the turn's start, or ``None`` to keep the mode.
    events
        The step log's events of the turn's first step, of :data:`TURN_EVENTS` (``nudge``,
        ``step``, ``mode_select``; the protocol adds ``mode_switch_autonomy`` when ``mode`` changes
        the mode).
    goal
        The goal the turn acts for (the step log's ``inferred_goal``), -1 for none.
    nudge
        Whether the turn is a nudge (counted in the trial table's ``nudges``): True or False.
    """

    target: np.ndarray | None
    mode: int | None = None
    events: tuple[str, ...] = field(default=())
    goal: int = NO_GOAL
    nudge: bool = False

    @classmethod
    def stay(cls, events: Sequence[str] = ()) -> AutonomyTurn:
        """A turn that does nothing: one step without motion, then the person's turn again."""
        return cls(None, None, tuple(events))


@runtime_checkable
class Policy(Protocol):
    """An assistance policy (one object per trial).

    Attributes
    ----------
    infers
        Whether the protocol runs goal inference (Eq. 7) for it: ``view.belief`` is then the
        posterior and ``view.model`` the agent's model; otherwise the belief stays uniform.
    takes_turns
        Whether the person hands the turn over (after their handover idle time) and
        :meth:`start_turn` is called; without, the person's turn is the whole trial.

    A policy may also answer the person's mode switches with an optional method
    ``choose_mode(view, requested) -> int | None``, called when a hard blow switches the mode
    (``requested``: the mode the blow asked for): the mode to go to instead (0, 1, 2), or ``None``
    for the person's own (the step log adds ``mode_select`` where it chose). The built-in
    ``mode-switch`` policy has one, for ``[mode-switch] trigger = "request"``.

    And it may answer a quiet run at once with an optional method ``assist_quiet(view, steps) ->
    Sequence[QuietRun]``: where a simulated person certainly gives no input for ``steps`` steps and
    the robot stands, the protocol asks it once, at the run's first step, instead of calling
    :meth:`assist` at each. Over the run only ``view.step`` moves (one a step); the pose, mode,
    belief, ``measured`` (none) and ``u_h`` (zero) stand. It returns ``(count, assistance)`` pairs
    in step order: ``assistance`` is what :meth:`assist` returns at each of those ``count`` steps,
    and the counts add up to ``steps`` (or fewer: the rest are asked again). Where an assistance's
    command moves the robot, the steps from there run one by one. Without it (the default) the
    protocol calls :meth:`assist` at every step of the run, so a policy needs it only for speed;
    every built-in policy has one.
    """

    infers: bool
    takes_turns: bool

    def assist(self, view: StepView) -> Assistance:
        """The command to execute in this step of the human's turn (:class:`Assistance`)."""
        ...

    def start_turn(self, view: StepView) -> AutonomyTurn:
        """What to do in the autonomy's turn that starts now (:class:`AutonomyTurn`)."""
        ...



def drive_towards(view: StepView, target: Sequence[float] | np.ndarray,
                  speed: float | None = None, turn_rate: float | None = None) -> tuple[float, float, float]:
    """The command that drives the robot straight to ``target`` (3,) at the autonomy's speeds (or
    the given ones), turning to its heading, without passing it within one step."""
    s = view.settings
    return assistance.autonomy_command(view.x, view.y, view.theta, float(target[0]), float(target[1]),
                                       float(target[2]), s.autonomy_speed if speed is None else speed,
                                       s.autonomy_turn_rate if turn_rate is None else turn_rate, s.dt)


def checked_command(value: Any, what: str) -> tuple[float, float, float]:
    """``value`` as a finite command ``(vx, vy, omega)`` tuple.

    Raises
    ------
    ValueError
        ``value`` is not three finite real numbers of shape ``(3,)`` (``what`` names it in the
        message).
    """
    return _three_finite(value, what, "vx, vy, omega")


def checked_pose(value: Any, what: str) -> tuple[float, float, float]:
    """``value`` as a finite pose ``(x, y, theta)`` tuple (an :class:`AutonomyTurn`'s target).

    Raises
    ------
    ValueError
        ``value`` is not three finite real numbers of shape ``(3,)`` (``what`` names it in the
        message).
    """
    return _three_finite(value, what, "x, y, theta")


def _three_finite(value: Any, what: str, names: str) -> tuple[float, float, float]:
    """``value``, of shape ``(3,)``, as a tuple of finite floats; ``names`` says what the three are.

    Exactly three real numbers, as a mode or a goal is an integer and not a bool: a ``(3, 1)``
    column or a ``(1, 3)`` row is not flattened (a shape other than the one documented is a
    mistake, not a command), and True or False (numpy's too) is no coordinate.
    """
    if type(value) is tuple and len(value) == 3 and all(type(v) is float for v in value):
        items = value  # the common answer (drive_towards's, the person's u_h), without numpy
    else:
        items = _three_numbers(value, what, names)
    if not all(math.isfinite(v) for v in items):
        raise ValueError(f"{what} must be finite, got {items}")
    return items[0], items[1], items[2]


def _three_numbers(value: Any, what: str, names: str) -> tuple[float, float, float]:
    """``value`` as three floats, refused unless of shape ``(3,)`` and of real numbers, not bools."""
    wanted = f"{what} must be three numbers ({names})"
    try:
        shape = np.shape(value)
    except (TypeError, ValueError):  # a ragged nesting
        raise ValueError(f"{wanted}, got {value!r}") from None
    if not shape:  # a number, None, text
        raise ValueError(f"{wanted}, got {value!r}")
    if len(shape) > 1:
        raise ValueError(f"{wanted} of shape (3,), got shape {shape}")
    if shape[0] != 3:
        raise ValueError(f"{wanted}, got {shape[0]}")
    if not all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) for v in value):
        raise ValueError(f"{wanted}: real numbers, not true/false or text, got {value!r}")
    return float(value[0]), float(value[1]), float(value[2])
