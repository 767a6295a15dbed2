"""The panels' pressure loops against a cushion driver, as the panel nodes run them."""

import numpy as np
import pytest

from flectofold_model.actuation import (actuated_like, ActuationModel, CushionMap,
                                        DEMONSTRATOR_PLANT, PneumaticPlant)
from flectofold_model.control import panel_loops
from flectofold_model.control.hardware import CushionDriver, SimulatedCushions
from flectofold_model.control.panel_loops import facade_loops, LoopSample, PanelLoops
from flectofold_model.control.pressure_loop import ControllerParameters, Fault
from flectofold_model.facade.description import load_facade

IDS = ['r00c00', 'r03c02']


@pytest.fixture(scope='module')
def facade():
    return load_facade()


def loops_of(facade, **options):
    return facade_loops(facade, IDS, **options)


@pytest.fixture(scope='module')
def settled(facade):
    loops = loops_of(facade)
    loops.advance_to(1000.0)
    loops.set_setpoints([0.8, 0.3])
    loops.advance_to(1040.0)
    return loops


def test_panels_reach_their_setpoints(settled):
    np.testing.assert_allclose(settled.closure, [0.8, 0.3], atol=0.01)
    assert all(fault is Fault.NONE for fault in settled.fault)
    assert settled.time_s == pytest.approx(1040.0)


def test_fold_angle_follows_the_fold_model(settled):
    exact = [settled.model.fold.state_from_closure(c).apex_fold_angle_rad[i]
             for i, c in enumerate(settled.closure)]
    np.testing.assert_allclose(settled.fold_angle_rad, exact, rtol=1e-3)
    assert settled.fold_angle_rad[0] > settled.fold_angle_rad[1]


def test_measured_pressure_is_absolute_and_matches_the_map(settled):
    gauge = settled.measured_pa - 101325.0
    np.testing.assert_allclose(gauge, settled.map.pressure_for_closure(np.array([0.8, 0.3])),
                               atol=150.0)


def test_free_air_is_counted(settled):
    assert np.all(settled.free_air_used_nl > 1.0)
    assert settled.free_air_used_nl[0] > settled.free_air_used_nl[1]


def test_one_jump_or_many_small_ticks_give_the_same_run(facade):
    jumped, ticked = loops_of(facade), loops_of(facade)
    for loops in (jumped, ticked):
        loops.advance_to(0.0)
        loops.set_setpoints(0.6)
    jumped.advance_to(20.0)
    for now in np.arange(1, 201) * 0.1:
        ticked.advance_to(now)
    np.testing.assert_array_equal(jumped.measured_pa, ticked.measured_pa)
    np.testing.assert_array_equal(jumped.gauge_pa, ticked.gauge_pa)


def test_repeated_and_partial_clock_readings_run_no_extra_period(facade):
    loops = loops_of(facade)
    assert loops.advance_to(5.0).periods == 0
    assert loops.advance_to(5.25).periods == 2
    assert loops.advance_to(5.25).periods == 0
    assert loops.advance_to(5.3).periods == 1
    assert loops.time_s == pytest.approx(5.3)


def test_a_clock_leap_is_capped_and_reported(facade):
    loops = loops_of(facade, control_period_s=0.1)
    loops.max_catch_up_s = 10.0
    loops.advance_to(0.0)
    advance = loops.advance_to(3600.0)
    assert advance.periods == 100
    assert advance.skipped_s == pytest.approx(3590.0)
    assert loops.time_s == pytest.approx(3600.0)


def test_a_clock_going_back_restarts_without_simulating(facade):
    loops = loops_of(facade)
    loops.advance_to(100.0)
    loops.advance_to(110.0)
    assert loops.advance_to(50.0).periods == 0
    assert loops.time_s == 50.0
    assert loops.advance_to(51.0).periods == 10


class RealTimeDriver(CushionDriver):
    """A driver whose time passes by itself: it records what the loop asks of it."""

    def __init__(self, plant):
        self.plant, self.writes = plant, []

    count = property(lambda self: self.plant.count)
    circuit = property(lambda self: self.plant.parameters)

    def read_pressure_pa(self):
        return self.plant.read_sensor()

    def read_supply_pa(self):
        return self.plant.read_supply_sensor()

    def write_valves(self, fill_opening, vent_opening):
        self.writes.append((np.array(fill_opening), np.array(vent_opening)))


def test_a_real_time_driver_gets_one_period_per_call_and_is_never_advanced(facade):
    model = ActuationModel([actuated_like(facade.panels[0])])
    driver = RealTimeDriver(PneumaticPlant(DEMONSTRATOR_PLANT, CushionMap(model), 1))
    loops = PanelLoops(model, driver, control_period_s=0.1)
    loops.set_setpoints(1.0)
    loops.advance_to(0.0)
    assert loops.advance_to(0.02).periods == 0  # too early for a period
    assert loops.advance_to(2.0).periods == 1  # late: one period, not twenty
    assert len(driver.writes) == 1 and driver.writes[0][0][0] > 0.0
    with pytest.raises(NotImplementedError):
        driver.advance(0.1)


def test_close_shuts_the_valves(facade):
    loops = loops_of(facade)
    loops.set_setpoints(1.0)
    loops.advance_to(0.0)
    loops.advance_to(1.0)
    assert np.all(loops.driver._fill > 0.0)
    loops.close()
    assert not np.any(loops.driver._fill) and not np.any(loops.driver._vent)


def test_bad_construction_is_refused(facade):
    model = ActuationModel([actuated_like(facade.panels[0])])
    driver = SimulatedCushions(PneumaticPlant(DEMONSTRATOR_PLANT, CushionMap(model), 2))
    with pytest.raises(ValueError, match='2 channels for 1 panels'):
        PanelLoops(model, driver)
    one = SimulatedCushions(PneumaticPlant(DEMONSTRATOR_PLANT, CushionMap(model), 1))
    with pytest.raises(ValueError, match='at least twice the period'):
        PanelLoops(model, one, 0.5, ControllerParameters(time_constant_s=0.4))
    with pytest.raises(ValueError, match='control_period_s'):
        PanelLoops(model, one, 0.0)
    with pytest.raises(ValueError, match='unknown panel id.*r09c09'):
        facade_loops(facade, ['r09c09'])
    with pytest.raises(ValueError, match='twice'):
        facade_loops(facade, ['r00c00', 'r00c00'])
    with pytest.raises(ValueError, match='fill_opening'):
        one.write_valves(np.array([1.5]), np.array([0.0]))


def test_a_catch_up_keeps_a_state_per_sample_period_at_its_own_time(facade):
    sampled, ticked = loops_of(facade), loops_of(facade)
    sampled.request_sample_period(0, 5.0)
    for loops in (sampled, ticked):
        loops.advance_to(0.0)
        loops.set_setpoints(0.6)
    sampled.advance_to(30.0)  # one call: a loop that fell behind the clock
    samples = list(sampled.samples)
    assert [s.sequence for s in samples] == list(range(1, len(samples) + 1))
    times = np.array([s.time_s for s in samples])
    assert times[0] == pytest.approx(0.1) and np.all(np.diff(times) >= 5.0 - 1e-9)
    assert np.all(np.diff(times) < 5.0 + 0.1 + 1e-9) and times[-1] > 25.0
    for sample in samples:  # each is the state the loop had at that time
        ticked.advance_to(sample.time_s)
        np.testing.assert_array_equal(sample.closure, ticked.closure)
        np.testing.assert_array_equal(sample.measured_pa, ticked.measured_pa)
        np.testing.assert_array_equal(sample.fold_angle_rad, ticked.fold_angle_rad)


def test_no_samples_unless_asked(facade):
    loops = loops_of(facade)
    loops.advance_to(0.0)
    loops.advance_to(10.0)
    assert not loops.samples


# -- what a panel process does with the loops --------------------------------------------------

def test_a_setpoint_for_one_panel_changes_that_panel_only_and_bad_ones_are_refused(facade):
    loops = loops_of(facade)
    loops.set_setpoints(0.7, 1)
    np.testing.assert_array_equal(loops.setpoint, [0.0, 0.7])
    for bad in (1.5, -0.1, float('nan'), float('inf')):
        with pytest.raises(ValueError, match='closure'):
            loops.set_setpoints(bad, 1)
    np.testing.assert_array_equal(loops.setpoint, [0.0, 0.7])
    with pytest.raises(ValueError):
        loops.setpoint[0] = 1.0  # read-only: setpoints go through set_setpoints


def test_samples_are_kept_at_the_shortest_period_asked_and_taken_once_each(facade):
    loops = loops_of(facade)
    loops.request_sample_period(0, 0.5)
    loops.request_sample_period(1, 0.2)  # the loop keeps states at the shorter of the two
    loops.set_setpoints([0.5, 0.2])
    loops.advance_to(0.0)
    loops.advance_to(10.0)
    samples = loops.samples_since(0)
    assert [s.sequence for s in samples] == list(range(1, 51))
    np.testing.assert_allclose(np.diff([s.time_s for s in samples]), 0.2, atol=1e-9)
    loops.advance_to(11.0)
    newer = loops.samples_since(samples[-1].sequence)
    assert [s.sequence for s in newer] == list(range(51, 56))
    assert loops.samples_since(newer[-1].sequence) == []
    assert newer[-1] is loops.samples[-1]
    assert loops.samples_since(50)[0] is loops.samples[-5]


def test_taking_samples_costs_what_is_taken_however_long_the_loop_ran(facade, monkeypatch):
    monkeypatch.setattr(panel_loops, 'SAMPLE_HISTORY', 64)
    loops = loops_of(facade)
    loops.request_sample_period(0, 0.1)
    loops.advance_to(0.0)
    loops.advance_to(20.0)  # 200 periods: more than the history keeps
    assert len(loops.samples) == 64
    last = loops.samples[-1].sequence
    assert last == 200
    seen = []
    original = LoopSample.__getattribute__

    def counting(sample, name):
        if name == 'sequence':
            seen.append(sample)
        return original(sample, name)
    monkeypatch.setattr(LoopSample, '__getattribute__', counting)
    assert [s.sequence for s in loops.samples_since(last - 3)] == [last - 2, last - 1, last]
    assert len(seen) <= 6  # the newest three looked at, not the 64 kept


def test_quiet_spans_leave_a_state_at_every_sample_time(facade):
    """At rest the loop runs long quiet periods, but never across a state that is due."""
    loops = facade_loops(facade, IDS, parameters=ControllerParameters(hold_band_pa=60.0),
                         quiet_period_s=2.0)
    loops.request_sample_period(0, 0.5)
    loops.advance_to(1782036000.0)  # a day-scale clock, as ROS time is
    loops.advance_to(1782036000.0 + 120.0)
    assert loops.quiet_periods_run > 0  # the panels rested (vented, open)
    times = np.array([sample.time_s for sample in loops.samples])
    np.testing.assert_allclose(np.diff(times), 0.5, atol=1e-6)


def test_after_a_skipped_jump_the_held_state_is_kept_at_the_new_time(facade):
    loops = loops_of(facade)
    loops.max_catch_up_s = 10.0
    loops.request_sample_period(0, 5.0)
    loops.advance_to(0.0)
    loops.advance_to(3600.0)  # 10 s simulated, 3590 s skipped (the plant held)
    assert loops.samples[-1].time_s == pytest.approx(3600.0)
    loops.advance_to(3605.0)  # and the grid goes on from there
    assert loops.samples[-1].time_s == pytest.approx(3605.0)


def test_a_loop_that_cannot_keep_up_bounds_each_call_and_says_how_far_behind(facade):
    loops = loops_of(facade, control_period_s=0.1)
    loops.max_call_s = 1e-6  # less than any run of periods takes
    loops.request_sample_period(0, 0.5)
    loops.set_setpoints(1.0)  # filling: every period runs
    loops.advance_to(0.0)
    advance = loops.advance_to(600.0)  # 6000 periods: far more than 1 us of work
    assert 0 < advance.periods < 6000 and advance.skipped_s == 0.0
    assert advance.behind_s == pytest.approx(600.0 - loops.time_s) == loops.behind_s
    assert advance.behind_s > 0.0
    calls = 1
    while loops.behind_s > 0.0:  # later calls go on where the last one stopped
        loops.advance_to(600.0)
        calls += 1
    assert calls > 1 and loops.time_s == pytest.approx(600.0)
    times = np.array([sample.time_s for sample in loops.samples])  # the grid is unbroken
    np.testing.assert_allclose(np.diff(times), 0.5, atol=1e-6)
    assert times[-1] > 600.0 - 0.5 - 1e-6
