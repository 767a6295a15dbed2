"""Sun vector in, closures out: the coordinator's per-period decision for a whole facade."""

import math

import numpy as np
import pytest

from flectofold_model.environment import sun_vector_enu
from flectofold_model.facade.description import build_facade
from flectofold_model.scheduling.facade_schedule import (FacadeSchedule, full_close_air_nl,
                                                         look_ahead_steps, look_ahead_times,
                                                         representative_panel)
from flectofold_model.scheduling.scheduler import Reason
from flectofold_model.shading.table import ShadingTable


@pytest.fixture(scope='module')
def facade(small_facade_text):
    return build_facade(small_facade_text(
        'shading_target: 0.9, default_closure: 1.0, min_dwell_s: 0, deadband: 0.0, '
        'rate_per_s: 1.0, max_parallel_fills: 4, capacity_nl: 1000'))


@pytest.fixture(scope='module')
def table(facade):
    return ShadingTable(representative_panel(facade), step_deg=10.0, samples=12)


@pytest.fixture
def schedule(facade, table):
    return FacadeSchedule(facade, table=table)


def sun(azimuth_deg, elevation_deg):
    azimuth, elevation = math.radians(azimuth_deg), math.radians(elevation_deg)
    return np.array([math.sin(azimuth) * math.cos(elevation),
                     math.cos(azimuth) * math.cos(elevation), math.sin(elevation)])


def test_sun_in_front_flattens_panels_and_sun_behind_folds_them(schedule):
    facing = schedule.desired_closure(sun(180.0, 10.0))  # low sun, straight at the facade
    behind = schedule.desired_closure(sun(0.0, 30.0))    # north sun: no direct sun here
    assert np.all(facing < 0.5)
    np.testing.assert_array_equal(behind, 1.0)


def test_the_chosen_closures_meet_the_target_where_they_can(schedule, facade):
    direction = sun(200.0, 40.0)
    chosen = schedule.desired_closure(direction)
    in_panels = facade.sun_in_panel_frames(direction)
    blocked = schedule.table.blocked_fractions(in_panels)
    rows = np.arange(len(facade))
    columns = np.searchsorted(schedule.table.closures, chosen)
    assert np.all(blocked[rows, columns] >= 0.9 - 1e-9)


def test_step_schedules_with_the_facade_control_and_a_storm_wins(schedule):
    first = schedule.step(60.0, sun(180.0, 10.0), dni_w_m2=700.0)
    assert set(first.reason) <= {Reason.AUTO, Reason.RATE_LIMITED, Reason.WAITING_FOR_AIR}
    for t in range(2, 12):
        storm = schedule.step(60.0 * t, sun(180.0, 10.0), dni_w_m2=700.0, wind_m_s=25.0)
    assert schedule.scheduler.storm_latched
    assert set(storm.reason) == {Reason.STORM}
    np.testing.assert_array_equal(storm.closure, schedule.parameters.storm_position)


def test_look_ahead_window_is_at_least_as_protective(schedule):
    window = np.stack([sun(150.0, 20.0), sun(180.0, 10.0)])
    ahead = schedule.desired_closure(window)
    assert np.all(ahead <= np.minimum(schedule.desired_closure(window[0]),
                                      schedule.desired_closure(window[1])) + 1e-12)


def test_full_close_costs_about_the_plant_simulation(facade):
    air = full_close_air_nl(facade)
    assert air.shape == (len(facade),)
    assert np.all((air > 12.0) & (air < 20.0))  # the plant fills 16.4 NL for one module


@pytest.mark.parametrize('bad', [[0.0, 0.0, 2.0], [np.nan, 0.0, 1.0], [[1.0, 0.0]]])
def test_bad_sun_vectors_are_refused(schedule, bad):
    with pytest.raises(ValueError, match='sun_enu'):
        schedule.desired_closure(bad)


def test_a_table_of_the_wrong_kind_is_refused(facade):
    with pytest.raises(TypeError, match='ShadingTable'):
        FacadeSchedule(facade, table='table')


#: 2026-06-21 10:00 UTC, on the 60 s grid [s].
NOON_S = 1_782_036_000.0


def target_schedule(small_facade_text, table, look_ahead_s):
    facade = build_facade(small_facade_text(
        f'controller: target, period_s: 60, look_ahead_s: {look_ahead_s}'))
    return FacadeSchedule(facade, start_s=NOON_S, table=table)


@pytest.mark.parametrize('look_ahead_s, steps', [(180.0, 3), (180.0 - 1e-6, 2), (60.0, 1),
                                                 (60.0 - 1e-6, 0), (0.0, 0), (-60.0, 0)])
def test_a_window_counts_the_whole_periods_it_reaches(look_ahead_s, steps):
    assert look_ahead_steps(60.0, look_ahead_s) == steps


def test_a_window_of_a_whole_number_of_periods_counts_all_of_them_despite_rounding():
    assert 0.3 / 0.1 < 3.0  # 2.9999999999999996
    assert look_ahead_steps(0.1, 0.3) == 3


def test_the_window_takes_the_grid_instants_after_a_decision_on_the_grid():
    assert look_ahead_times(NOON_S, 60.0, 180.0) == [NOON_S + 60.0, NOON_S + 120.0,
                                                     NOON_S + 180.0]


def test_the_window_of_a_decision_just_before_the_grid_starts_at_that_grid_instant():
    assert look_ahead_times(NOON_S - 1e-6, 60.0, 180.0) == [NOON_S, NOON_S + 60.0,
                                                            NOON_S + 120.0]


def test_a_window_shorter_than_a_period_has_no_instant_ahead():
    assert look_ahead_times(NOON_S, 60.0, 60.0 - 1e-6) == []
    assert look_ahead_times(NOON_S, 60.0, 60.0) == [NOON_S + 60.0]


def test_the_target_rule_judges_the_sun_now_then_the_ephemeris_on_the_grid(small_facade_text,
                                                                           table):
    schedule = target_schedule(small_facade_text, table, 180)
    now_s = NOON_S + 30.0
    window = schedule.sun_window(now_s, sun(180.0, 40.0))
    assert window.shape == (4, 3)
    np.testing.assert_array_equal(window[0], sun(180.0, 40.0))
    ahead = sun_vector_enu(np.array([NOON_S + 60.0, NOON_S + 120.0, NOON_S + 180.0]),
                           schedule.facade.site)
    np.testing.assert_allclose(window[1:], ahead, atol=1e-12)


def test_the_target_rule_with_a_window_shorter_than_a_period_judges_the_sun_now_alone(
        small_facade_text, table):
    schedule = target_schedule(small_facade_text, table, 59)
    window = schedule.sun_window(NOON_S, sun(180.0, 40.0))
    np.testing.assert_array_equal(window, [sun(180.0, 40.0)])


def test_the_predictive_controller_gets_the_sun_now_as_given(schedule):
    now = sun(180.0, 40.0)
    assert schedule.sun_window(NOON_S, now) is now


def test_each_step_is_noted_as_a_decision_on_the_storm_latch(facade, table):
    schedule = FacadeSchedule(facade, table=table, wind_timeout_s=2000.0)
    parameters = schedule.parameters
    schedule.scheduler.observe_wind(25.0, 60.0)
    schedule.scheduler.advance_storm(60.0 + parameters.storm_on_delay_s)
    assert schedule.storm.report() is not None
    schedule.step(120.0, None)
    schedule.scheduler.observe_wind(0.0, 130.0)
    release_s = 130.0 + parameters.storm_off_delay_s
    schedule.scheduler.advance_storm(release_s)
    assert not schedule.storm.latched and schedule.storm.decision_due  # released, not decided
    schedule.step(release_s, None)
    assert not schedule.storm.decision_due
