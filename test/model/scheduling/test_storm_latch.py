"""The storm latch on sparse, timestamped wind samples, and what it does to overrides."""

import numpy as np
import pytest

from flectofold_model.scheduling.scheduler import (OverrideRefused, Scheduler,
                                                   SchedulerParameters)
from flectofold_model.scheduling.storm import StormLatch

DEFAULTS = SchedulerParameters()
T0 = 1_000_000.0


def latch(stale_s=60.0, latched=False, **options):
    return StormLatch(SchedulerParameters(**options), stale_s, latched, start_s=T0)


def test_the_trip_timer_starts_on_arrival_and_trips_at_its_instant_without_a_new_sample():
    storm = latch()
    assert not storm.sample(12.0, T0 + 0.3)
    assert storm.run_start_s == T0 + 0.3
    assert storm.due_s == pytest.approx(T0 + 0.3 + DEFAULTS.storm_on_delay_s)
    assert not storm.advance(T0 + 5.29)
    assert storm.advance(T0 + 5.3) and storm.latched
    assert storm.changed_s == pytest.approx(T0 + 5.3)
    assert storm.due_s is None  # the held 12 m/s does not run the release timer


def test_a_late_evaluation_dates_the_trip_at_its_instant():
    storm = latch()
    storm.sample(12.0, T0)
    storm.sample(13.0, T0 + 2.0)  # still above: the timer from T0 runs on
    assert storm.advance(T0 + 40.0)
    assert storm.changed_s == T0 + 5.0


def test_a_gust_sampled_once_then_a_lull_does_not_trip_and_the_next_gust_starts_afresh():
    storm = latch()
    storm.sample(15.0, T0)
    storm.sample(10.0, T0 + 1.0)  # at the threshold is not above it
    assert storm.run_start_s is None and storm.due_s is None
    storm.sample(15.0, T0 + 2.0)
    assert not storm.advance(T0 + 6.9) and not storm.latched
    assert storm.advance(T0 + 7.0)


@pytest.mark.parametrize('stale_s, interval_s, trips', [(60.0, 30.0, True), (3.0, 1.0, True),
                                                        (3.0, 4.0, False), (4.0, 4.5, False)])
def test_stale_wind_breaks_the_run(stale_s, interval_s, trips):
    """Samples closer than the timeout hold the wind between them; farther ones do not.

    A sample is held at most ``stale_s``: with samples farther apart than that, the wind
    above is never known for the 5 s on-delay when ``stale_s`` is shorter than it.
    """
    storm = latch(stale_s=stale_s, storm_on_delay_s=5.0)
    for k in range(4):
        storm.sample(20.0, T0 + k * interval_s)
    storm.advance(T0 + 3 * interval_s + stale_s)
    assert storm.latched == trips


def test_a_single_sample_that_goes_stale_before_the_delay_never_trips():
    storm = latch(stale_s=3.0)
    storm.sample(30.0, T0)
    assert storm.due_s is None
    assert not storm.advance(T0 + 100.0) and not storm.latched
    assert storm.wind_m_s(T0 + 3.0) == 30.0 and storm.wind_m_s(T0 + 3.01) is None


def test_release_needs_the_whole_calm_and_a_sample_between_the_thresholds_restarts_it():
    storm = latch(latched=True, storm_off_delay_s=900.0)
    for k in range(90):
        storm.sample(5.0, T0 + 10.0 * k)  # calm from T0 to T0 + 890 s
    storm.sample(8.0, T0 + 895.0)  # under the trip speed, over the release speed
    assert storm.latched and storm.run_start_s is None
    storm.sample(6.0, T0 + 900.0)
    assert storm.run_start_s == T0 + 900.0
    for k in range(1, 90):
        storm.sample(6.0, T0 + 900.0 + 10.0 * k)
        assert storm.latched
    assert storm.advance(T0 + 1800.0) and not storm.latched


def test_stale_wind_never_releases():
    storm = latch(latched=True, storm_off_delay_s=100.0)
    storm.sample(2.0, T0)
    assert storm.due_s is None  # 100 s of calm cannot be known from a sample held 60 s
    storm.sample(2.0, T0 + 50.0)
    assert storm.due_s == T0 + 100.0
    assert storm.advance(T0 + 100.0) and not storm.latched


def test_bad_samples_and_times_going_back_are_refused():
    storm = latch()
    storm.sample(3.0, T0 + 10.0)
    with pytest.raises(ValueError, match='at_s must not go backwards'):
        storm.sample(3.0, T0 + 9.0)
    with pytest.raises(ValueError, match='now_s must not go backwards'):
        storm.advance(T0 + 9.0)
    with pytest.raises(ValueError, match='wind_m_s must lie in'):
        storm.sample(-1.0, T0 + 11.0)
    with pytest.raises(ValueError, match='wind_m_s must be finite'):
        storm.sample(float('nan'), T0 + 11.0)
    with pytest.raises(ValueError, match='stale_s must be positive'):
        latch(stale_s=0.0)


def make_scheduler(count=2, **options):
    free = {'deadband': 0.0, 'min_dwell_s': 0.0, 'rate_per_s': 10.0, 'capacity_nl': 1e6}
    return Scheduler(count, 1.0, SchedulerParameters(**{**free, **options}), start_s=T0)


def test_the_scheduler_trips_between_steps_on_a_sample_and_a_later_evaluation():
    scheduler = make_scheduler()
    scheduler.step(T0 + 1.0, 0.8)
    scheduler.observe_wind(14.0, T0 + 1.5)
    assert scheduler.storm_due_s == T0 + 6.5
    assert not scheduler.advance_storm(T0 + 6.4)
    assert scheduler.advance_storm(T0 + 6.5)
    result = scheduler.step(T0 + 6.5, 0.8)
    np.testing.assert_array_equal(result.closure, DEFAULTS.storm_position)
    with pytest.raises(ValueError, match='now_s must not go backwards'):
        scheduler.step(T0 + 6.0, 0.8)


def test_overrides_end_at_the_trip_are_refused_in_the_storm_and_auto_resumes_after():
    scheduler = make_scheduler(storm_on_delay_s=5.0, storm_off_delay_s=60.0)
    scheduler.set_override(0.9, T0, panels=[0])
    assert scheduler.step(T0 + 1.0, 0.3).closure.tolist() == [0.9, 0.3]
    scheduler.observe_wind(20.0, T0 + 2.0)
    scheduler.advance_storm(T0 + 7.0)
    with pytest.raises(OverrideRefused, match='storm latch set'):
        scheduler.set_override(0.5, T0 + 8.0, panels=[1])
    scheduler.clear_override()  # clearing is always fine
    assert scheduler.step(T0 + 8.0, 0.3).closure.tolist() == [0.0, 0.0]
    for k in range(61):
        scheduler.observe_wind(3.0, T0 + 10.0 + k)
    assert not scheduler.storm_latched and scheduler.storm_changed_s == T0 + 70.0
    result = scheduler.step(T0 + 71.0, 0.3)
    assert result.closure.tolist() == [0.3, 0.3]  # neither override came back
    assert {reason.name for reason in result.reason} == {'AUTO'}


def test_an_override_refused_in_the_storm_is_refused_before_a_step_sees_the_trip():
    scheduler = make_scheduler()
    scheduler.observe_wind(20.0, T0 + 1.0)
    with pytest.raises(OverrideRefused):
        scheduler.set_override(0.5, T0 + 6.0, panels=[0])  # the trip instant has passed
    assert scheduler.storm_latched
