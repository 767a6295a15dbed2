"""The facade scheduler: each limit holds, each precedence holds, bad input is refused."""

import copy

import numpy as np
import pytest

from flectofold_model.scheduling.scheduler import (OverrideRefused, Reason, Scheduler,
                                                   ScheduleResult, SchedulerParameters)

#: Midnight UTC at the start of a day, so tests can cross into the next one on purpose.
DAY_S = 20000 * 86400.0
#: Limits that never hold a panel back, for tests that look at one limit at a time.
FREE = {'deadband': 0.0, 'min_dwell_s': 0.0, 'rate_per_s': 10.0, 'capacity_nl': 1e6,
        'max_parallel_fills': 1000, 'daily_move_cap': 1000}


def make(count, cost=1.0, zones=None, initial_closure=0.0, storm_latched=False, **options):
    return Scheduler(count, cost, SchedulerParameters(**options), zones=zones,
                     initial_closure=initial_closure, storm_latched=storm_latched,
                     start_s=DAY_S)


def reasons(result):
    return [reason.name for reason in result.reason]


def test_deadband_suppresses_small_changes():
    scheduler = make(3, **{**FREE, 'deadband': 0.03}, initial_closure=0.5)
    result = scheduler.step(DAY_S + 1, [0.52, 0.475, 0.56])
    np.testing.assert_array_equal(result.closure, [0.5, 0.5, 0.56])
    assert reasons(result) == ['DEADBAND', 'DEADBAND', 'AUTO']
    np.testing.assert_array_equal(scheduler.moves_today, [0, 0, 1])
    result = scheduler.step(DAY_S + 2, [0.5, 0.5, 0.56])
    assert reasons(result) == ['AUTO', 'AUTO', 'AUTO']


def test_dwell_blocks_a_second_move_within_min_dwell_but_not_after():
    scheduler = make(1, **{**FREE, 'min_dwell_s': 300.0})
    assert scheduler.step(DAY_S + 1, 0.5).closure[0] == 0.5
    for now in (DAY_S + 100, DAY_S + 300.5):
        result = scheduler.step(now, 0.8)
        assert result.closure[0] == 0.5 and result.reason[0] is Reason.DWELL
    result = scheduler.step(DAY_S + 301, 0.8)
    assert result.closure[0] == 0.8 and result.reason[0] is Reason.AUTO
    np.testing.assert_array_equal(scheduler.moves_today, [2])


def test_rate_limit_bounds_each_change_by_rate_times_dt():
    scheduler = make(4, **{**FREE, 'rate_per_s': 0.02}, initial_closure=[0.0, 1.0, 0.3, 0.9])
    rng = np.random.default_rng(3)
    now, previous, limited = DAY_S, scheduler.commanded_closure, 0
    for _ in range(200):
        dt = rng.choice([0.5, 1.0, 2.5, 10.0])
        now += dt
        result = scheduler.step(now, rng.choice([0.0, 1.0], size=4))
        assert np.all(np.abs(result.closure - previous) <= 0.02 * dt + 1e-12)
        limited += np.count_nonzero(result.reason == Reason.RATE_LIMITED)
        previous = result.closure
    assert limited > 100
    scheduler.step(now + 60.0, 1.0)  # a running move ends on its latched goal first
    result = scheduler.step(now + 120.0, 1.0)  # then one 60 s call covers a full stroke
    np.testing.assert_array_equal(result.closure, 1.0)


def test_daily_cap_stops_the_21st_move_resets_next_day_and_lets_the_storm_through():
    scheduler = make(1, **{**FREE, 'daily_move_cap': 20}, initial_closure=1.0)
    for move in range(20):
        result = scheduler.step(DAY_S + 100 + move, float(move % 2))
        assert result.reason[0] is Reason.AUTO
    assert scheduler.moves_today[0] == 20 and result.closure[0] == 1.0
    result = scheduler.step(DAY_S + 200, 0.0)
    assert result.closure[0] == 1.0 and result.reason[0] is Reason.DAILY_CAP

    storm = copy.deepcopy(scheduler)
    for now in np.arange(DAY_S + 300, DAY_S + 306):
        result = storm.step(now, 0.0, wind_m_s=20.0)
    assert storm.storm_latched
    assert result.closure[0] == 0.0 and result.reason[0] is Reason.STORM

    result = scheduler.step(DAY_S + 86399, 0.0)
    assert result.reason[0] is Reason.DAILY_CAP
    result = scheduler.step(DAY_S + 86400, 0.0)
    assert result.closure[0] == 0.0 and result.reason[0] is Reason.AUTO
    assert scheduler.moves_today[0] == 1


def air_limited(count, **options):
    """Panels whose one-call closing step (0.1 at 1 s calls) costs 0.25 NL."""
    settings = {**FREE, 'rate_per_s': 0.1, 'capacity_nl': 1.0, 'refill_nl_per_s': 0.25,
                **options}
    return make(count, cost=2.5, **settings)


def test_a_tiny_bucket_closes_only_what_its_tokens_pay_for_then_staggers_the_rest():
    scheduler = air_limited(10)
    result = scheduler.step(DAY_S + 1, 1.0)  # the bucket starts full: 1 NL, four steps
    assert np.count_nonzero(result.filling) == 4
    np.testing.assert_array_equal(np.flatnonzero(result.filling), [0, 1, 2, 3])
    assert result.air_used_nl == pytest.approx(1.0)
    assert set(reasons(result)[4:]) == {'WAITING_FOR_AIR'}
    np.testing.assert_array_equal(result.closure[4:], 0.0)
    first_move = np.where(result.filling, 1.0, np.inf)
    for now in np.arange(2.0, 150.0):
        result = scheduler.step(DAY_S + now, 1.0)
        assert result.tokens_nl >= 0.0 and scheduler.tokens_nl >= 0.0
        assert result.air_used_nl <= 0.25 + 1e-12  # what the refill brought since the last call
        assert np.count_nonzero(result.filling) <= 1  # that is one 0.1 step
        first_move = np.where(result.filling & np.isinf(first_move), now, first_move)
    np.testing.assert_array_equal(result.closure, 1.0)
    assert np.all(np.isfinite(first_move))
    assert len(set(first_move[4:])) == 6  # staggered, one after another


def test_never_more_than_max_parallel_fills_at_once():
    scheduler = make(20, **{**FREE, 'rate_per_s': 0.1, 'max_parallel_fills': 3})
    most = 0
    for now in np.arange(1.0, 80.0):
        result = scheduler.step(DAY_S + now, 1.0)
        filling = np.count_nonzero(result.filling)
        assert filling <= 3
        assert np.count_nonzero(result.reason == Reason.WAITING_FOR_AIR) == \
            np.count_nonzero((result.closure < 1.0) & ~result.filling)
        most = max(most, filling)
    assert most == 3
    np.testing.assert_array_equal(result.closure, 1.0)


def test_opening_moves_go_through_with_no_tokens_left():
    scheduler = air_limited(2, capacity_nl=0.25, refill_nl_per_s=0.0, initial_closure=[0.0, 1.0])
    result = scheduler.step(DAY_S + 1, 1.0)
    assert result.tokens_nl == 0.0 and result.filling[0]
    result = scheduler.step(DAY_S + 2, [1.0, 0.0])
    assert result.tokens_nl == 0.0 and result.air_used_nl == 0.0
    assert reasons(result) == ['WAITING_FOR_AIR', 'RATE_LIMITED']
    assert result.closure[0] == pytest.approx(0.1) and result.closure[1] == pytest.approx(0.9)


def test_largest_requested_increase_is_admitted_first():
    scheduler = make(3, **{**FREE, 'max_parallel_fills': 1})
    order = []
    for now in (1.0, 2.0, 3.0):
        result = scheduler.step(DAY_S + now, [0.3, 0.9, 0.6])
        order += list(np.flatnonzero(result.filling))
    assert order == [1, 2, 0]


@pytest.mark.parametrize('aging_s, served', [(60.0, True), (1e9, False)])
def test_aging_serves_a_long_waiting_small_request_before_newer_large_ones(aging_s, served):
    # One fill slot and one new full-stroke request every call from panels 1..80; panel 0
    # wants a small 0.12 from the start. Without aging it would starve behind them.
    scheduler = make(81, **{**FREE, 'max_parallel_fills': 1, 'aging_s': aging_s})
    served_at = None
    for now in range(1, 81):
        desired = np.where(np.arange(81) <= now, 1.0, 0.0)
        desired[0] = 0.12
        result = scheduler.step(DAY_S + now, desired)
        if result.filling[0]:
            served_at = now
            assert result.reason[now] is Reason.WAITING_FOR_AIR  # a newer large request
            break
    assert (served_at is not None) == served
    if served:
        assert served_at == 54  # 0.12 + 53 s / 60 s first outranks a fresh full stroke


def test_storm_trips_after_the_on_delay_and_commands_the_storm_position_at_once():
    scheduler = make(3, initial_closure=0.8)
    for now in range(1, 6):  # above 10 m/s at 1..5 s: not yet 5 s continuously
        result = scheduler.step(DAY_S + now, 0.8, wind_m_s=12.0 if now != 3 else 9.0)
    assert not scheduler.storm_latched
    for now in range(6, 10):
        result = scheduler.step(DAY_S + now, 0.8, wind_m_s=12.0)
        assert scheduler.storm_latched == (now == 9)  # above from 4 s on: 5 s at 9 s
        np.testing.assert_array_equal(result.closure, 0.0 if now == 9 else 0.8)
    np.testing.assert_array_equal(result.closure, 0.0)
    assert set(reasons(result)) == {'STORM'}


def test_storm_holds_through_lulls_and_releases_only_after_the_off_delay():
    scheduler = make(2, storm_latched=True, initial_closure=0.6)
    assert scheduler.storm_latched
    result = scheduler.step(DAY_S + 1, 0.6)
    np.testing.assert_array_equal(result.closure, 0.0)
    now = DAY_S + 1
    # Below 7 m/s for 890 s, a gust, 8 m/s (under the trip speed, over the release speed),
    # then below 7 m/s again from t0 to t0 + 890 s: all latched.
    for wind, duration in ((5.0, 900.0), (11.0, 10.0), (8.0, 2000.0), (5.0, 900.0)):
        for now in np.arange(now + 10.0, now + duration + 10.0, 10.0):
            result = scheduler.step(now, 0.6, wind_m_s=wind)
            assert scheduler.storm_latched and set(reasons(result)) == {'STORM'}
    result = scheduler.step(now + 10.0, 0.6, wind_m_s=5.0)  # t0 + 900 s
    assert not scheduler.storm_latched
    assert set(reasons(result)) == {'RATE_LIMITED'}
    np.testing.assert_allclose(result.closure, 0.2)


def test_override_holds_its_closure_without_dwell_or_deadband():
    scheduler = make(2, min_dwell_s=300.0, deadband=0.03)
    scheduler.step(DAY_S + 1, 0.0)
    scheduler.set_override(0.01, DAY_S + 2, panels=[0])  # inside the deadband
    result = scheduler.step(DAY_S + 2, 0.0)
    assert result.closure[0] == 0.01 and reasons(result) == ['OVERRIDE', 'AUTO']
    scheduler.set_override(0.5, DAY_S + 10, panels=[0])  # within the dwell of the first
    for now in np.arange(11, 60):
        result = scheduler.step(DAY_S + now, 0.0)
    assert result.closure[0] == pytest.approx(0.5)
    assert reasons(result) == ['OVERRIDE', 'AUTO'] and result.closure[1] == 0.0
    assert scheduler.moves_today[0] == 2


def test_zone_override_affects_only_that_zone_and_expires_on_time():
    scheduler = make(4, **FREE, zones=[0, 0, 1, 1])
    scheduler.set_override(0.7, DAY_S, zone=1, duration_s=100.0)
    result = scheduler.step(DAY_S + 99, 0.2)
    np.testing.assert_array_equal(result.closure, [0.2, 0.2, 0.7, 0.7])
    assert reasons(result) == ['AUTO', 'AUTO', 'OVERRIDE', 'OVERRIDE']
    result = scheduler.step(DAY_S + 100, 0.2)
    np.testing.assert_array_equal(result.closure, 0.2)
    assert set(reasons(result)) == {'AUTO'}


def test_newer_override_replaces_older_and_clear_ends_it():
    scheduler = make(3, **FREE)
    scheduler.set_override(0.8, DAY_S, panels=[0, 1], duration_s=1000.0)
    scheduler.set_override(0.3, DAY_S, panels=np.array([False, True, False]), duration_s=50.0)
    result = scheduler.step(DAY_S + 10, 0.0)
    np.testing.assert_array_equal(result.closure, [0.8, 0.3, 0.0])
    result = scheduler.step(DAY_S + 50, 0.0)
    np.testing.assert_array_equal(result.closure, [0.8, 0.0, 0.0])
    scheduler.clear_override(panels=0)
    result = scheduler.step(DAY_S + 51, 0.0)
    np.testing.assert_array_equal(result.closure, 0.0)


def test_storm_beats_override():
    scheduler = make(2, **FREE, storm_on_delay_s=0.0)
    scheduler.set_override(0.9, DAY_S, panels=[0, 1])
    assert set(reasons(scheduler.step(DAY_S + 1, 0.0, wind_m_s=3.0))) == {'OVERRIDE'}
    result = scheduler.step(DAY_S + 2, 0.0, wind_m_s=15.0)
    np.testing.assert_array_equal(result.closure, 0.0)
    assert set(reasons(result)) == {'STORM'}


def test_faulted_panels_keep_their_closure_use_no_air_and_report_fault_even_in_a_storm():
    scheduler = make(3, cost=10.0, **{**FREE, 'rate_per_s': 0.1},
                     initial_closure=[0.2, 0.5, 0.7])
    faulted = np.array([False, True, False])
    result = scheduler.step(DAY_S + 1, 1.0, faulted=faulted)
    np.testing.assert_allclose(result.closure, [0.3, 0.5, 0.8])
    assert reasons(result) == ['RATE_LIMITED', 'FAULT', 'RATE_LIMITED']
    np.testing.assert_array_equal(result.filling, [True, False, True])
    assert result.air_used_nl == pytest.approx(2 * 10.0 * 0.1)
    result = scheduler.step(DAY_S + 2, 1.0, wind_m_s=30.0, faulted=faulted)
    assert not scheduler.storm_latched  # the 5 s on-delay
    for now in range(3, 8):
        result = scheduler.step(DAY_S + now, 1.0, wind_m_s=30.0, faulted=faulted)
    assert scheduler.storm_latched
    np.testing.assert_allclose(result.closure, [0.0, 0.5, 0.0])
    assert reasons(result) == ['STORM', 'FAULT', 'STORM']
    assert not result.filling[1]


def test_dni_gate_has_hysteresis():
    scheduler = make(1, **FREE, default_closure=0.1)
    trace = []
    for now, dni in enumerate([50.0, 110.0, 120.0, 110.0, 100.0, 99.0, 110.0, None], start=1):
        result = scheduler.step(DAY_S + now, 0.9, dni_w_m2=dni)
        trace.append((result.closure[0], result.reason[0].name))
    assert trace == [(0.1, 'DNI_GATE'), (0.1, 'DNI_GATE'), (0.9, 'AUTO'), (0.9, 'AUTO'),
                     (0.9, 'AUTO'), (0.1, 'DNI_GATE'), (0.1, 'DNI_GATE'), (0.9, 'AUTO')]


def run_random(seed):
    rng = np.random.default_rng(seed)
    scheduler = make(50, cost=rng.uniform(5.0, 20.0, 50), zones=np.arange(50) % 5,
                     min_dwell_s=20.0, capacity_nl=20.0, max_parallel_fills=4)
    outputs = []
    for now in np.arange(1.0, 300.0, 2.0):
        if now == 101.0:
            try:
                scheduler.set_override(0.6, DAY_S + now, zone=2, duration_s=60.0)
            except OverrideRefused:  # in a storm
                outputs.append((np.full(50, np.nan), ['REFUSED'], None, None))
        result = scheduler.step(DAY_S + now, rng.random(50), wind_m_s=rng.uniform(0.0, 12.0),
                                dni_w_m2=rng.uniform(50.0, 200.0), faulted=rng.random(50) < 0.05)
        outputs.append((result.closure, reasons(result), result.filling, result.tokens_nl))
    return outputs


def test_same_inputs_give_the_same_outputs():
    first, second = run_random(7), run_random(7)
    for one, other in zip(first, second):
        (closure, why, filling, tokens), (closure2, why2, filling2, tokens2) = one, other
        np.testing.assert_array_equal(closure, closure2)
        np.testing.assert_array_equal(filling, filling2)
        assert why == why2 and tokens == tokens2
    assert len({name for _, why, _, _ in first for name in why}) >= 6


def test_ten_thousand_panels_in_one_call():
    count = 10_000
    scheduler = Scheduler(count, np.full(count, 16.0), zones=np.arange(count) % 40,
                          start_s=DAY_S)
    scheduler.set_override(0.5, DAY_S, zone=3)
    result = scheduler.step(DAY_S + 1.0, np.linspace(0.0, 1.0, count), wind_m_s=4.0,
                            dni_w_m2=600.0, faulted=np.arange(count) % 97 == 0)
    assert isinstance(result, ScheduleResult)
    assert result.closure.shape == result.reason.shape == result.filling.shape == (count,)
    assert result.filling.dtype == bool
    assert all(isinstance(reason, Reason) for reason in result.reason)
    assert np.count_nonzero(result.filling) == SchedulerParameters().max_parallel_fills
    assert 0.0 <= result.tokens_nl <= SchedulerParameters().capacity_nl


@pytest.mark.parametrize('arguments, message', [
    ({'desired_closure': 1.2}, 'desired_closure must lie in'),
    ({'desired_closure': [0.1, float('nan'), 0.2]}, 'desired_closure must be finite'),
    ({'desired_closure': [0.1, 0.2]}, 'desired_closure must be a scalar or have shape'),
    ({'wind_m_s': -1.0}, 'wind_m_s must lie in'),
    ({'wind_m_s': float('inf')}, 'wind_m_s must be finite'),
    ({'dni_w_m2': float('nan')}, 'dni_w_m2 must be finite'),
    ({'faulted': np.zeros(2, dtype=bool)}, 'faulted must have shape'),
    ({'now_s': DAY_S + 4.0}, 'now_s must not go backwards'),
])
def test_step_refuses_bad_input(arguments, message):
    scheduler = make(3)
    scheduler.step(DAY_S + 5.0, 0.0)
    call = {'now_s': DAY_S + 6.0, 'desired_closure': 0.5, **arguments}
    with pytest.raises(ValueError, match=message):
        scheduler.step(**call)
    np.testing.assert_array_equal(scheduler.commanded_closure, 0.0)  # nothing changed


def test_step_refuses_a_non_boolean_fault_mask():
    with pytest.raises(TypeError, match='faulted must be a bool mask'):
        make(2).step(DAY_S + 1, 0.0, faulted=[0, 1])


@pytest.mark.parametrize('options, message', [
    ({'deadband': -0.01}, 'deadband must not be negative'),
    ({'deadband': 1.5}, 'deadband must lie in'),
    ({'min_dwell_s': float('nan')}, 'min_dwell_s must be finite'),
    ({'rate_per_s': 0.0}, 'rate_per_s must be positive'),
    ({'daily_move_cap': 0}, 'daily_move_cap must be an integer >= 1'),
    ({'max_parallel_fills': 2.5}, 'max_parallel_fills must be an integer >= 1'),
    ({'wind_on_m_s': 7.0}, 'wind_on_m_s=7 m/s must exceed wind_off_m_s=7'),
    ({'dni_off_w_m2': 130.0}, 'dni_on_w_m2=120 W/m2 must exceed'),
    ({'storm_position': 1.1}, 'storm_position must lie in'),
    ({'default_closure': -0.1}, 'default_closure must not be negative'),
])
def test_parameters_refuse_bad_values(options, message):
    with pytest.raises(ValueError, match=message):
        SchedulerParameters(**options)


@pytest.mark.parametrize('arguments, message', [
    ({'count': 0}, 'count must be a positive integer'),
    ({'air_cost_nl_per_closure': -1.0}, 'air_cost_nl_per_closure must lie in'),
    ({'air_cost_nl_per_closure': [1.0, 2.0]}, 'air_cost_nl_per_closure must be a scalar'),
    ({'initial_closure': [0.0, 0.5, 2.0]}, 'initial_closure must lie in'),
    ({'zones': [0, 1]}, 'zones must have shape'),
    ({'start_s': float('nan')}, 'start_s must be finite'),
])
def test_constructor_refuses_bad_input(arguments, message):
    with pytest.raises(ValueError, match=message):
        Scheduler(**{'count': 3, 'air_cost_nl_per_closure': 16.0, **arguments})


@pytest.mark.parametrize('arguments, message', [
    ({'closure': 1.5, 'panels': [0]}, 'closure must lie in'),
    ({'closure': 0.5}, 'give exactly one of panels and zone'),
    ({'closure': 0.5, 'panels': [0], 'zone': 1}, 'give panels or zone, not both'),
    ({'closure': 0.5, 'zone': 9}, 'zone 9 has no panels'),
    ({'closure': 0.5, 'panels': [3]}, r'panels must be indices in \[0, 3\)'),
    ({'closure': 0.5, 'panels': [0], 'duration_s': 0.0}, 'duration_s must be positive'),
    ({'closure': 0.5, 'panels': [0], 'now_s': DAY_S - 1.0}, 'now_s must not go backwards'),
])
def test_set_override_refuses_bad_input(arguments, message):
    scheduler = make(3, zones=[0, 1, 1])
    with pytest.raises(ValueError, match=message):
        scheduler.set_override(**{'now_s': DAY_S, **arguments})


@pytest.mark.parametrize('closure, taken', [
    (0.0, True), (1.0, True), (np.nextafter(0.0, -1.0), False), (np.nextafter(1.0, 2.0), False)])
def test_an_override_takes_each_end_of_the_closure_range_and_refuses_one_step_beyond(
        closure, taken):
    scheduler = make(3)
    if taken:
        scheduler.set_override(closure, DAY_S, panels=[0])
    else:
        with pytest.raises(ValueError, match='closure must lie in'):
            scheduler.set_override(closure, DAY_S, panels=[0])


def test_zone_needs_zones():
    with pytest.raises(ValueError, match='zone=1 given but the scheduler has no zones'):
        make(2).set_override(0.5, DAY_S, zone=1)


def test_the_last_step_is_the_start_until_a_step_and_then_that_step():
    scheduler = make(1, **FREE)
    assert scheduler.last_step_s == DAY_S
    scheduler.step(DAY_S + 7.0, 0.0)
    assert scheduler.last_step_s == DAY_S + 7.0


def test_a_step_may_be_at_the_latest_storm_evaluation_and_not_just_before_it():
    scheduler = make(1, **FREE)
    scheduler.step(DAY_S + 1.0, 0.0)
    scheduler.observe_wind(3.0, DAY_S + 5.0)
    assert scheduler.earliest_step_s == DAY_S + 5.0
    with pytest.raises(ValueError, match='now_s must not go backwards'):
        scheduler.step(DAY_S + 5.0 - 1e-6, 0.0)
    scheduler.step(DAY_S + 5.0, 0.0)
    assert scheduler.earliest_step_s == scheduler.last_step_s == DAY_S + 5.0
