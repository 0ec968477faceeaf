"""Upper bounds of the experiment's keys that had none: a duration, a count of a trial's samples, a
speed, a turn rate, a distance, an angle and the experiment's name each refused past a generous bound
in one ``Error:`` line naming the key (they hung the run, crashed a worker with an ``OverflowError``,
ran with meaningless values, or failed only when the run folder was made), and the start-up gate's
end found without a walk of single steps."""

from __future__ import annotations

import math
import threading

import pytest
from cli_helpers import nudge, one_error_line
from hypothesis import given, settings
from hypothesis import strategies as st

from nudgecli.config import MAX_NAME_BYTES, load_experiment
from nudgecli.config_base import MAX_DISTANCE, MAX_SPEED, MAX_TIME_LIMIT_S, MAX_TRIAL_STEPS
from nudgecli.errors import ConfigError
from nudgecli.model import assistance
from nudgecli.model.inference import decay_weight

# --- the start-up gate's end --------------------------------------------------------------------


def _gate_end_by_single_steps(initiated_at: int, dt: float, startup_delay: float) -> int:
    """The gate's end as it was computed before: the estimate, then single steps down and up."""
    count = max(0, math.ceil(startup_delay / dt))
    while count > 0 and (count - 1) * dt >= startup_delay:
        count -= 1
    while count * dt < startup_delay:
        count += 1
    return initiated_at + count


#: Step lengths of the rates the presets and tests use, and the bounds' (1 Hz and 1000 Hz).
STEPS_USED = [0.1, 0.05, 0.01, 0.001, 1.0, 1 / 30, 0.2, 0.3]
#: Delays the presets and tests use (``study-code``'s 1 s), and the bound's.
DELAYS_USED = [0.0, 0.1, 0.3, 0.35, 0.7, 1.0, 0.6000000000000001, 2.9999999999999996, MAX_TIME_LIMIT_S]


@settings(max_examples=400, deadline=None)
@given(initiated_at=st.integers(0, 100_000),
       dt=st.sampled_from(STEPS_USED) | st.floats(1e-3, 1.0),
       delay=st.sampled_from(DELAYS_USED) | st.floats(-1.0, MAX_TIME_LIMIT_S))
def test_the_gate_end_is_what_the_single_steps_gave_over_the_bounded_range(initiated_at, dt, delay):
    assert assistance.startup_delay_end(initiated_at, dt, delay) == \
        _gate_end_by_single_steps(initiated_at, dt, delay)


@pytest.mark.parametrize(("dt", "delay"), [(0.1, 1e30), (0.001, 1e300), (1 / 30, 1e20), (0.1, 3e15)])
def test_a_huge_delay_ends_at_once_at_the_first_step_its_test_passes(dt, delay):
    # the single steps hung here (a step moved no product where the floats are 2^70 apart): run in a
    # thread so that the old computation fails the test instead of hanging it
    found: list[int] = []
    worker = threading.Thread(target=lambda: found.append(assistance.startup_delay_end(0, dt, delay)),
                              daemon=True)
    worker.start()
    worker.join(timeout=5.0)
    assert found, "startup_delay_end did not return within 5 s"
    end = found[0]
    assert end * dt >= delay and (end - 1) * dt < delay


def test_a_delay_of_more_steps_than_a_float_holds_is_refused():
    with pytest.raises(ValueError, match="more steps than a float holds"):
        assistance.startup_delay_end(0, 1e-300, 1e300)


# --- the keys' bounds ---------------------------------------------------------------------------

DECAY = "inference.decay=true"
KNEE = "assistance.distance_weighting=true"


@pytest.mark.parametrize(("settings_", "key"), [
    (["assistance.startup_delay_s=1e30"], "assistance.startup_delay_s"),
    ([f"assistance.startup_delay_s={MAX_TIME_LIMIT_S + 1}"], "assistance.startup_delay_s"),
    ([DECAY, "inference.decay_cap=1000000000000000000000000000000"], "inference.decay_cap"),
    ([DECAY, f"inference.decay_delay={MAX_TRIAL_STEPS + 1}"], "inference.decay_delay"),
    (["interface.human_speed=1e300"], "interface.human_speed"),
    ([f"interface.human_turn_rate={MAX_SPEED * 2}"], "interface.human_turn_rate"),
    (["assistance.autonomy_speed=1e9"], "assistance.autonomy_speed"),
    (["assistance.autonomy_turn_rate=1e9"], "assistance.autonomy_turn_rate"),
    (["assistance.arrival_tolerance=1e9"], "assistance.arrival_tolerance"),
    ([KNEE, "assistance.distance_knee=1e300"], "assistance.distance_knee"),
    ([f"study.success_distance={MAX_DISTANCE + 1}"], "study.success_distance"),
    (["study.success_angle=4.0"], "study.success_angle"),
])
def test_a_value_past_its_new_bound_is_one_line_naming_the_key(settings_, key):
    with pytest.raises(ConfigError) as error:
        load_experiment("smoke", settings_)
    message = str(error.value)
    assert "\n" not in message and f"{key}: must be at most" in message, message


def test_the_new_bounds_themselves_are_taken():
    config = load_experiment("smoke", [
        f"assistance.startup_delay_s={MAX_TIME_LIMIT_S}", DECAY, f"inference.decay_cap={MAX_TRIAL_STEPS}",
        f"inference.decay_delay={MAX_TRIAL_STEPS}", f"interface.human_speed={MAX_SPEED}",
        f"assistance.autonomy_turn_rate={MAX_SPEED}", f"study.success_distance={MAX_DISTANCE}",
        f"assistance.arrival_tolerance={MAX_DISTANCE}", f"study.success_angle={math.pi}"])
    assert config.assistance.startup_delay_s == MAX_TIME_LIMIT_S
    assert config.inference.decay_cap == MAX_TRIAL_STEPS and config.study.success_angle == math.pi
    # a cap at its bound is within numpy's integers (1e30 overflowed them in the worker)
    assert decay_weight(MAX_TRIAL_STEPS * 2, config.inference.decay_rate, config.inference.decay_cap) == \
        pytest.approx(1.0)


# --- the experiment's name ----------------------------------------------------------------------

@pytest.mark.parametrize("name", ["x" * (MAX_NAME_BYTES + 1), "x" * 250, "名" * 34])
def test_a_name_too_long_for_a_file_name_is_refused_naming_the_key(name):
    with pytest.raises(ConfigError) as error:
        load_experiment("smoke", [f'experiment.name="{name}"'])
    message = str(error.value)
    assert "\n" not in message and "experiment.name: " in message
    assert f"give at most {MAX_NAME_BYTES}" in message and "check that the folder exists" not in message


def test_a_name_at_the_limit_is_taken():
    name = "x" * MAX_NAME_BYTES
    assert load_experiment("smoke", [f'experiment.name="{name}"']).experiment.name == name


def test_simulate_with_a_long_name_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = nudge("simulate", "smoke", "--participants", "1", "--set", f"experiment.name={'x' * 250}")
    line = one_error_line(result.output)
    assert result.exit_code == 1 and "experiment.name" in line and "bytes is too long" in line
    assert list(tmp_path.iterdir()) == []
