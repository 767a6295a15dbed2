"""The setpoint guard: validation, last-valid hold, watchdog and safe behaviour."""

import math

import numpy as np
import pytest

from flectofold_model.control.setpoint_guard import (
    SafeBehaviour, SetpointGuard, SetpointGuards, SetpointState)


@pytest.mark.parametrize('value, reason', [
    (math.nan, 'NaN'), (math.inf, 'inf'), (-math.inf, '-inf'), (1.5, 'outside [0, 1]'),
    (-0.01, 'outside [0, 1]'), ('0.5', 'must be a number'), (True, 'must be a number'),
    (None, 'must be a number')])
def test_bad_setpoints_are_refused_and_the_last_valid_one_holds(value, reason):
    guard = SetpointGuard(timeout_s=10.0)
    assert guard.offer(0.4, now_s=1.0) is None
    assert reason in guard.offer(value, now_s=2.0)
    assert guard.rejected == 1 and reason in guard.last_rejection
    assert guard.command(3.0) == (0.4, SetpointState.TRACKING)


@pytest.mark.parametrize('value', [0.0, -0.0, 1.0, np.float64(1.0), np.nextafter(0.0, 1.0),
                                   np.nextafter(1.0, 0.0)])
def test_each_end_of_the_range_is_taken(value):
    guard = SetpointGuard(timeout_s=10.0)
    assert guard.offer(value, now_s=1.0) is None
    assert guard.command(1.0) == (float(value), SetpointState.TRACKING)


@pytest.mark.parametrize('value', [np.nextafter(1.0, 2.0), np.nextafter(0.0, -1.0),
                                   1.0000000001])
def test_one_step_beyond_either_end_is_refused(value):
    """The smallest double past 1 (or below 0): a guard widened by any margin fails here."""
    guard = SetpointGuard(timeout_s=10.0)
    assert 'outside [0, 1]' in guard.offer(value, now_s=1.0)
    assert guard.command(1.0)[1] is SetpointState.WAITING


def test_numpy_and_integer_setpoints_are_numbers():
    guard = SetpointGuard(timeout_s=10.0)
    assert guard.offer(np.float64(0.25), 0.0) is None
    assert guard.offer(1, 0.0) is None
    assert guard.command(0.0)[0] == 1.0


def test_waiting_holds_the_initial_closure_until_the_timeout():
    guard = SetpointGuard(timeout_s=5.0, safe_behaviour=SafeBehaviour.HOLD, initial_closure=0.3)
    assert guard.command(100.0) == (0.3, SetpointState.WAITING)
    assert guard.command(105.0) == (0.3, SetpointState.WAITING)
    assert guard.command(105.1) == (0.3, SetpointState.TIMED_OUT)


@pytest.mark.parametrize('behaviour, expected', [(SafeBehaviour.VENT, 0.0),
                                                 (SafeBehaviour.HOLD, 0.8)])
def test_timeout_starts_the_safe_behaviour_and_a_fresh_setpoint_ends_it(behaviour, expected):
    guard = SetpointGuard(timeout_s=5.0, safe_behaviour=behaviour)
    guard.offer(0.8, 10.0)
    assert guard.command(15.0) == (0.8, SetpointState.TRACKING)
    assert guard.command(15.5) == (expected, SetpointState.TIMED_OUT)
    guard.offer(math.nan, 16.0)  # a bad setpoint is no sign of life
    assert guard.command(16.0) == (expected, SetpointState.TIMED_OUT)
    guard.offer(0.6, 17.0)
    assert guard.command(17.0) == (0.6, SetpointState.TRACKING)


def test_a_clock_that_goes_back_restarts_the_watchdog():
    guard = SetpointGuard(timeout_s=5.0)
    guard.offer(0.5, 1000.0)
    assert guard.command(900.0) == (0.5, SetpointState.TRACKING)
    assert guard.command(906.0)[1] is SetpointState.TIMED_OUT


@pytest.mark.parametrize('options, message', [
    ({'timeout_s': 0.0}, 'timeout_s must be positive'),
    ({'timeout_s': math.nan}, 'timeout_s'),
    ({'timeout_s': 1.0, 'safe_behaviour': 'explode'}, 'explode'),
    ({'timeout_s': 1.0, 'initial_closure': 2.0}, 'initial_closure')])
def test_bad_configuration_is_refused(options, message):
    with pytest.raises(ValueError, match=message):
        SetpointGuard(**options)


def test_each_panel_of_a_process_is_guarded_on_its_own():
    guards = SetpointGuards(3, timeout_s=5.0)
    assert guards.offer(1, 0.7, now_s=10.0) is None
    assert 'NaN' in guards.offer(2, math.nan, now_s=10.0)
    closures, states = guards.command(12.0)
    assert closures.tolist() == [0.0, 0.7, 0.0]
    assert [SetpointGuards.STATES[s] for s in states] == [
        SetpointState.WAITING, SetpointState.TRACKING, SetpointState.WAITING]
    assert guards.rejected.tolist() == [0, 0, 1] and 'NaN' in guards.last_rejection[2]
    # the watchdog runs from the last valid setpoint, or from the first reading of the clock
    guards.offer(0, 0.2, now_s=14.0)
    closures, states = guards.command(15.0)  # at 1's bound (10 s + 5 s): not yet timed out
    assert closures.tolist() == [0.2, 0.7, 0.0]
    assert states.tolist() == [1, 1, 0]
    closures, states = guards.command(15.001)  # just beyond it: 1 vents
    assert closures.tolist() == [0.2, 0.0, 0.0]
    assert [SetpointGuards.STATES[s] for s in states] == [
        SetpointState.TRACKING, SetpointState.TIMED_OUT, SetpointState.WAITING]
    assert guards.command(17.0)[1].tolist() == [1, 2, 0]  # 2: at its bound (12 s + 5 s)
    assert guards.command(17.001)[1].tolist() == [1, 2, 2]


def test_hold_keeps_each_panels_last_setpoint_after_the_timeout():
    guards = SetpointGuards(2, timeout_s=1.0, safe_behaviour=SafeBehaviour.HOLD,
                            initial_closure=0.1)
    guards.offer(0, 0.9, 0.0)
    guards.command(0.0)
    closures, states = guards.command(5.0)
    assert closures.tolist() == [0.9, 0.1] and states.tolist() == [2, 2]
    closures[0] = 0.5  # the caller's copy, not the guard's
    assert guards.command(5.0)[0].tolist() == [0.9, 0.1]


@pytest.mark.parametrize('count', [0, -1, 1.5, True, '2'])
def test_a_count_that_is_no_whole_positive_number_is_refused(count):
    with pytest.raises(ValueError, match='count'):
        SetpointGuards(count, timeout_s=1.0)


def test_one_guard_is_a_count_of_one():
    assert SetpointGuards(1, timeout_s=1.0).command(0.0)[0].tolist() == [0.0]
