"""The predictive controller: what it knows at a decision, what it plans, where it runs."""

import dataclasses
import os

import numpy as np
import pvlib
import pytest

from flectofold_model.environment import read_weather
from flectofold_model.facade.description import build_facade, FacadeError
from flectofold_model.scheduling import annual_report as report
from flectofold_model.scheduling.day_report import CANDIDATE_CLOSURES
from flectofold_model.scheduling.facade_schedule import (FacadeSchedule, representative_panel,
                                                         scheduler_parameters)
from flectofold_model.scheduling.frontier import best_schedule, ClosureProblem
from flectofold_model.scheduling.predictive import (PlanInputs, PredictiveController,
                                                    PredictiveParameters)
from flectofold_model.scheduling.scheduler import Reason
from flectofold_model.shading.table import ShadingTable

TMY3 = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')


@pytest.fixture(scope='module')
def facade(small_facade_text):
    return build_facade(small_facade_text('default_closure: 1.0, min_dwell_s: 600'))


@pytest.fixture(scope='module')
def table(facade):
    return ShadingTable(representative_panel(facade), closures=CANDIDATE_CLOSURES,
                        step_deg=10.0, samples=8)


def _inputs(rng, steps, count, daylight=True):
    return PlanInputs(cos_incidence=rng.uniform(0, 1, (steps, count)),
                      blocked=np.sort(rng.uniform(0, 1, (steps, count, 11)), axis=-1)[..., ::-1],
                      daylight=np.full(steps, daylight),
                      clear_dni_w_m2=np.full(steps, 800.0), step_h=np.ones(steps))


def test_one_step_without_move_cost_takes_the_best_closure_of_that_step(table):
    rng = np.random.default_rng(4)
    inputs = _inputs(rng, 1, 5)
    settings = PredictiveParameters(move_cost_wh_m2=0.0, air_price_wh_m2_per_nl=0.0,
                                    horizon_s=3600.0, plan_step_s=3600.0)
    controller = PredictiveController(CANDIDATE_CLOSURES, table.view, np.full(5, 16.0),
                                      settings)
    desired = controller.desired(np.zeros(5), inputs, dni_now_w_m2=700.0)
    problem = ClosureProblem(
        closures=CANDIDATE_CLOSURES, direct_w_m2=700.0 * inputs.cos_incidence,
        blocked=inputs.blocked, view=table.view, daylight=inputs.daylight, step_s=3600.0,
        start_s=np.zeros(1), weights=np.full(5, 0.2), air_nl=np.full(5, 16.0))
    best = best_schedule(problem, settings.view_value_w_m2)
    np.testing.assert_array_equal(desired, CANDIDATE_CLOSURES[best.levels[0]])


def test_a_move_that_costs_more_than_it_gains_is_not_made(table):
    inputs = _inputs(np.random.default_rng(5), 6, 4)
    # full sun on every panel; only the flat panel blocks it
    inputs = dataclasses.replace(inputs, cos_incidence=np.ones((6, 4)),
                                 blocked=np.broadcast_to(np.eye(11)[0], (6, 4, 11)))
    free = PredictiveController(CANDIDATE_CLOSURES, table.view, np.full(4, 16.0),
                                PredictiveParameters(move_cost_wh_m2=0.0))
    dear = PredictiveController(CANDIDATE_CLOSURES, table.view, np.full(4, 16.0),
                                PredictiveParameters(move_cost_wh_m2=1e6))
    start = np.full(4, 0.3)
    np.testing.assert_array_equal(free.desired(start, inputs, 700.0), 0.0)
    np.testing.assert_allclose(dear.desired(start, inputs, 700.0), start, atol=1e-12)


def test_without_daylight_ahead_every_panel_holds(table):
    rng = np.random.default_rng(6)
    controller = PredictiveController(CANDIDATE_CLOSURES, table.view, np.full(3, 16.0))
    start = np.array([0.0, 0.4, 1.0])
    np.testing.assert_array_equal(
        controller.desired(start, _inputs(rng, 6, 3, daylight=False), 0.0), start)


def test_the_forecast_persists_the_clear_sky_index_and_never_reads_ahead(table):
    controller = PredictiveController(CANDIDATE_CLOSURES, table.view, np.full(2, 16.0))
    inputs = _inputs(np.random.default_rng(7), 4, 2)
    inputs = dataclasses.replace(inputs, clear_dni_w_m2=np.array([800.0, 900.0, 600.0, 40.0]))
    controller.desired(np.zeros(2), inputs, dni_now_w_m2=400.0)
    assert controller.clear_sky_index == 0.5
    np.testing.assert_allclose(controller.forecast_dni(inputs, 400.0), [400, 450, 300, 20])
    # under a clear-sky DNI below 50 W/m2 (dawn) the index is not measured
    dawn = dataclasses.replace(inputs, clear_dni_w_m2=np.array([30.0, 200, 400, 600]))
    controller.desired(np.zeros(2), dawn, dni_now_w_m2=30.0)
    assert controller.clear_sky_index == 0.5


def test_a_decision_depends_on_no_weather_after_it(facade, table):
    """Change every hour of the file from step k on: the schedule before k is the same."""
    weather = read_weather(TMY3)
    first = report.annual_report(facade, weather, '02-06', '02-08', table=table,
                                 families=False)
    k = 40
    changed = dataclasses.replace(weather, dni_w_m2=weather.dni_w_m2.copy())
    start = np.flatnonzero(weather.time_utc >= np.datetime64('2001-02-06T05:00'))[0] + k
    changed.dni_w_m2[start:] = np.random.default_rng(1).uniform(0, 900,
                                                                changed.dni_w_m2[start:].size)
    runs = [_scheduled_closures(facade, table, w) for w in (weather, changed)]
    np.testing.assert_array_equal(runs[0][:k], runs[1][:k])
    assert not np.array_equal(runs[0], runs[1])  # the change did reach the later decisions
    assert first.figures('scheduled').actuations_per_panel > 0


def _scheduled_closures(facade, table, weather):
    """Return the scheduled run's closures (T, N) over 02-06..02-08, as the report has them."""
    captured = {}
    original = report._run_scheduler

    def spy(context, parameters, desired, dni, wind, share):
        run = original(context, parameters, desired, dni, wind, share)
        captured.setdefault('run', run)
        return run
    report._run_scheduler = spy
    try:
        report.annual_report(facade, weather, '02-06', '02-08', table=table, families=False)
    finally:
        report._run_scheduler = original
    return captured['run'].closure


def test_the_coordinator_schedule_runs_the_predictive_controller_without_the_dni_gate(
        facade, table):
    schedule = FacadeSchedule(facade, start_s=1_781_000_000.0, table=table)
    assert schedule.controller == 'predictive' and schedule.predictive is not None
    sun = np.array([0.0, -0.6, 0.8])  # high in the south
    result = schedule.step(1_781_000_060.0, sun, dni_w_m2=0.0)
    # a DNI of 0 closes the target rule's gate (default closure); here it is a forecast
    assert Reason.DNI_GATE not in set(result.reason)
    inputs = schedule.plan_inputs(1_781_000_060.0, sun)
    settings = PredictiveParameters()
    assert inputs.blocked.shape == (settings.steps(settings.plan_step_s), len(facade), 11)
    assert inputs.step_h[0] * 3600 == pytest.approx(900.0 - (1_781_000_060 % 900))
    with pytest.raises(ValueError, match='unit vectors'):
        schedule.step(1_781_000_120.0, np.array([0.0, 0.0, 2.0]))


def test_the_target_controller_is_still_the_rule_it_was(small_facade_text, table):
    facade = build_facade(small_facade_text('controller: target, default_closure: 1.0'))
    schedule = FacadeSchedule(facade, start_s=0.0, table=table)
    assert schedule.predictive is None
    result = schedule.step(60.0, np.array([0.0, -0.6, 0.8]), dni_w_m2=0.0)
    assert set(result.reason) == {Reason.DNI_GATE}


@pytest.mark.parametrize('control, message', [
    ('controller: bogus', 'must be one of predictive, target'),
    ('controller: 3', 'must be one of'),
    ('view_value_w_m2: -1', 'view_value_w_m2 must not be negative'),
    ('move_cost_wh_m2: .nan', 'must be finite'),
    ('horizon_s: 604800.001', 'at most a week'),
    ('plan_step_s: 0', 'plan_step_s must be positive'),
    ('horizon_s: 600, plan_step_s: 601', 'must be at least plan_step_s'),
])
def test_bad_predictive_settings_are_refused_at_load(small_facade_text, control, message):
    with pytest.raises(FacadeError, match=message):
        build_facade(small_facade_text(control))


def test_the_settings_bounds_are_accepted_at_the_bound(small_facade_text):
    facade = build_facade(small_facade_text(
        'horizon_s: 604800, plan_step_s: 604800, view_value_w_m2: 0, move_cost_wh_m2: 0, '
        'air_price_wh_m2_per_nl: 0'))
    settings = PredictiveParameters.of(facade.control)
    assert settings.steps(settings.plan_step_s) == 1
    assert scheduler_parameters(facade).deadband == 0.03  # the scheduler's keys untouched
