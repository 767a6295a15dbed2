"""The simulated clock: mapping, the stop at the end, and bad input."""

import math
import re

import pytest

from flectofold_model.environment.sim_clock import SimulatedClock
from flectofold_model.environment.sun import epoch_from_iso

START = epoch_from_iso('2026-06-21T04:00:00+02:00')
END = epoch_from_iso('2026-06-21T22:00:00+02:00')


def test_iso_times_with_offset_are_posix_seconds():
    assert START == 1782007200.0  # 02:00:00 UTC
    assert END - START == 18 * 3600.0


def test_runs_speedup_times_the_wall_clock():
    clock = SimulatedClock(START, END, 360.0)
    assert clock.sim_epoch_s(0.0) == START
    assert clock.sim_epoch_s(10.0) == START + 3600.0
    assert clock.sim_epoch_s(0.5) == START + 180.0
    assert clock.wall_duration_s == 180.0
    assert not clock.finished(179.9)


def test_stops_exactly_at_the_end():
    clock = SimulatedClock(START, START + 600.0, 600.0)
    assert clock.sim_epoch_s(0.999) == pytest.approx(START + 599.4, abs=1e-6)
    assert not clock.finished(0.999)
    for elapsed in (1.0, 1.0001, 5.0, 1e9):
        assert clock.sim_epoch_s(elapsed) == START + 600.0
        assert clock.finished(elapsed)


def test_integer_arguments_become_floats():
    clock = SimulatedClock(0, 100, 2)
    assert clock == SimulatedClock(0.0, 100.0, 2.0)
    assert isinstance(clock.sim_epoch_s(3), float)
    assert clock.sim_epoch_s(3) == 6.0


@pytest.mark.parametrize('start, end, speedup, message', [
    (START, START, 360.0, 'end_epoch_s must be after start_epoch_s'),
    (END, START, 360.0, 'end_epoch_s must be after start_epoch_s'),
    (START, END, 0.0, 'speedup must lie in (0, 100000]'),
    (START, END, -1.0, 'speedup must lie in (0, 100000]'),
    (START, END, 1e5 + 1.0, 'speedup must lie in (0, 100000]'),
    (math.nan, END, 360.0, 'start_epoch_s must be finite'),
    (START, math.inf, 360.0, 'end_epoch_s must be finite'),
    (START, END, math.nan, 'speedup must be finite'),
])
def test_bad_construction_is_refused_naming_the_field(start, end, speedup, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        SimulatedClock(start, end, speedup)


def test_the_largest_speedup_is_allowed():
    assert SimulatedClock(START, END, 1e5).sim_epoch_s(0.01) == START + 1000.0


@pytest.mark.parametrize('start, speedup', [('2026-06-21', 360.0), (START, True)])
def test_non_numbers_are_refused(start, speedup):
    with pytest.raises(TypeError):
        SimulatedClock(start, END, speedup)


@pytest.mark.parametrize('elapsed', [-0.001, math.nan, math.inf])
def test_bad_elapsed_time_is_refused(elapsed):
    clock = SimulatedClock(START, END, 360.0)
    with pytest.raises(ValueError, match='wall_elapsed_s'):
        clock.sim_epoch_s(elapsed)
    with pytest.raises(ValueError, match='wall_elapsed_s'):
        clock.finished(elapsed)
