"""A coordinator's account of the storm latch: what to report, when to decide, when to look."""

import pytest

from flectofold_model.scheduling.scheduler import Scheduler, SchedulerParameters
from flectofold_model.scheduling.storm import (StormChange, StormEvents, StormStatus,
                                               StormUpdate)

DEFAULTS = SchedulerParameters()  # trips above 10 m/s for 5 s, releases below 7 m/s for 900 s
T0 = 1_000_000.0
JUST = 1e-6  # [s]: well above the float spacing at T0 (about 1e-10 s)


def events(stale_s=60.0, latched=False):
    return StormEvents(Scheduler(4, 16.0, DEFAULTS, storm_latched=latched, start_s=T0,
                                 wind_timeout_s=stale_s))


def tripped(stale_s=60.0):
    """Events whose latch tripped at T0 + 5 s on a 12 m/s sample at T0, reported."""
    storm = events(stale_s)
    storm.observe_wind(12.0, T0)
    assert storm.advance(T0 + DEFAULTS.storm_on_delay_s).change is not None
    return storm


def test_a_trip_is_reported_at_its_instant_once_and_asks_for_one_decision():
    storm = events()
    assert storm.observe_wind(12.0, T0) == StormUpdate(None, False)
    assert storm.advance(T0 + DEFAULTS.storm_on_delay_s - JUST) == StormUpdate(None, False)
    assert storm.advance(T0 + DEFAULTS.storm_on_delay_s) == StormUpdate(
        StormChange(True, T0 + DEFAULTS.storm_on_delay_s), True)
    assert storm.advance(T0 + DEFAULTS.storm_on_delay_s + JUST) == StormUpdate(None, False)


def test_a_sample_that_trips_the_latch_late_reports_the_trip_at_the_end_of_its_hold():
    storm = events()
    storm.observe_wind(12.0, T0)
    update = storm.observe_wind(13.0, T0 + 40.0)
    assert update.decide and update.change == StormChange(True, T0 + 5.0)


def test_the_release_is_reported_at_the_end_of_the_calm_that_lasted_the_whole_hold():
    storm = tripped(stale_s=2000.0)
    calm_s = T0 + 10.0
    assert storm.observe_wind(5.0, calm_s) == StormUpdate(None, False)
    hold_s = calm_s + DEFAULTS.storm_off_delay_s
    assert storm.advance(hold_s - JUST) == StormUpdate(None, False)
    assert storm.advance(hold_s) == StormUpdate(StormChange(False, hold_s), True)


def test_a_change_a_step_reached_first_is_reported_after_the_step_and_not_again():
    storm = events()
    storm.observe_wind(12.0, T0)
    storm.scheduler.step(T0 + DEFAULTS.storm_on_delay_s, 1.0)
    assert storm.report() == StormChange(True, T0 + DEFAULTS.storm_on_delay_s)
    assert storm.report() is None
    assert storm.advance(T0 + 6.0) == StormUpdate(None, False)


def test_nothing_is_reported_while_the_latch_stays_as_last_reported():
    storm = events()
    assert storm.report() is None
    storm.observe_wind(10.0, T0)  # at the threshold is not above it
    assert storm.advance(T0 + 100.0) == StormUpdate(None, False)


def test_a_latch_restored_set_is_not_reported_as_a_trip_but_asks_for_decisions():
    storm = events(latched=True)
    assert storm.report() is None
    assert storm.decision_due


def test_a_sample_at_the_latest_evaluation_is_taken_and_one_just_before_it_is_not():
    storm = events()
    storm.advance(T0 + 10.0)
    assert storm.behind(T0 + 10.0 - JUST) and not storm.behind(T0 + 10.0)
    assert storm.observe_wind(12.0, T0 + 10.0 - JUST) is None
    assert storm.due_s is None  # not taken: no trip timer
    assert storm.observe_wind(12.0, T0 + 10.0) == StormUpdate(None, False)
    assert storm.due_s == T0 + 10.0 + DEFAULTS.storm_on_delay_s


def test_an_evaluation_just_before_the_latest_one_is_not_made_and_one_at_it_is():
    storm = events()
    storm.observe_wind(12.0, T0 + 10.0)
    assert storm.advance(T0 + 10.0 - JUST) is None
    assert storm.advance(T0 + 10.0) == StormUpdate(None, False)


def test_a_decision_is_due_without_the_sun_while_latched_and_once_after_the_release():
    storm = tripped(stale_s=2000.0)
    assert storm.decision_due
    storm.stepped()
    assert storm.decision_due  # latched: every decision moves the storm panels
    storm.observe_wind(5.0, T0 + 10.0)
    storm.advance(T0 + 10.0 + DEFAULTS.storm_off_delay_s)
    assert not storm.latched and storm.decision_due  # the release is not decided yet
    storm.stepped()
    assert not storm.decision_due


def test_no_decision_is_due_without_the_sun_before_any_storm():
    storm = events()
    assert not storm.decision_due
    storm.observe_wind(12.0, T0)
    assert not storm.decision_due  # a trip pending is not a trip


def test_the_latch_needs_a_timer_only_while_a_trip_or_release_is_due():
    storm = events()
    assert storm.due_s is None
    storm.observe_wind(12.0, T0)
    assert storm.due_s == T0 + DEFAULTS.storm_on_delay_s
    storm.observe_wind(10.0, T0 + 1.0)
    assert storm.due_s is None
    storm.observe_wind(12.0, T0 + 2.0)
    storm.advance(T0 + 2.0 + DEFAULTS.storm_on_delay_s)
    assert storm.latched and storm.due_s is None  # 12 m/s holds the latch: nothing due


def test_the_status_shows_the_held_wind_up_to_its_timeout_and_not_beyond():
    storm = events(stale_s=60.0)
    storm.observe_wind(12.0, T0)
    assert storm.status(T0 + 60.0).wind_m_s == 12.0
    assert storm.status(T0 + 60.0 + JUST).wind_m_s is None


def test_the_status_shows_no_wind_just_before_the_latest_evaluation():
    storm = events()
    storm.observe_wind(12.0, T0 + 10.0)
    assert storm.status(T0 + 10.0).wind_m_s == 12.0
    assert storm.status(T0 + 10.0 - JUST).wind_m_s is None


def test_the_status_counts_down_to_the_pending_change():
    storm = events()
    assert storm.status(T0) == StormStatus(False, None, None)
    storm.observe_wind(12.0, T0)
    status = storm.status(T0 + 2.0)
    assert status.latched is False and status.wind_m_s == 12.0
    assert status.due_in_s == pytest.approx(3.0, abs=1e-9)
    assert storm.status(T0 + 5.0 + JUST).due_in_s < 0.0  # overdue until evaluated
    storm.advance(T0 + 5.0)
    assert storm.status(T0 + 5.0) == StormStatus(True, 12.0, None)


def test_a_trip_and_a_release_read_as_one_log_line_each_to_the_millisecond():
    assert StormChange(True, 1234.5).describe() == (
        'storm latch tripped at 1234.500 s: panels to the storm position')
    assert StormChange(False, 1234.0004).describe() == (
        'storm latch released at 1234.000 s: panels back to automatic')
