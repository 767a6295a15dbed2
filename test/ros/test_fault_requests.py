"""Fault requests for simulated panels: checked at the boundary, kept per panel and kind."""

import math

import numpy as np
import pytest

from flectofold_model.actuation import (ActuationModel, CushionMap, DEMONSTRATOR_ACTUATED,
                                        DEMONSTRATOR_PLANT, PneumaticPlant)
from flectofold_ros.wire.fault_injection import (FaultInjector, FaultRequestError,
                                                 parse_request, request_fields)

FACADE = [f'r{row:02d}c{column:02d}' for row in range(6) for column in range(6)]
HEALTHY_LEAK = DEMONSTRATOR_PLANT.leak_conductance_m3_s_pa


@pytest.mark.parametrize('kind, panels, values, reason', [
    ('explode', 'r00c00', [], 'unknown fault kind'),
    ('leak', 'r00c00', [], 'leak needs conductance_m3_s_pa'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', 'nan')], 'must lie in'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', 'inf')], 'must lie in'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', '-1e-9')], 'must lie in'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', '0')], 'must lie in'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', '1e-3')], 'must lie in'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', 'big')], 'is no number'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', True)], 'is no number'),
    ('leak', 'r00c00', [('conductance_m3_s_pa', '1e-8'), ('conductance_m3_s_pa', '2e-8')],
     'given twice'),
    ('sensor_noise', 'r00c00', [('noise_std_pa', '1e9')], 'must lie in'),
    ('sensor_stuck', 'r00c00', [('noise_std_pa', '100')], 'takes no value'),
    ('sensor_stuck', 'r00c00', [('duration_s', '-5')], 'must lie in'),
    ('restore', 'r00c00', [('duration_s', '5')], 'takes no value'),
    ('sensor_stuck', 'r00c00', [('duration_s', '1')] * 9, 'at most 8'),
    ('sensor_stuck', 'r09c09', [], 'unknown panel'),
    ('sensor_stuck', 'r00c00,r00c00', [], 'named twice'),
    ('sensor_stuck', '', [], 'unknown panel'),
    ('sensor_stuck', ','.join(['r00c00'] * 10_000), [], 'longer than the 36 panels'),
    ('sensor_stuck', ['r00c00'] * 40, [], '40 panels named'),
    ('sensor_stuck', [{'a': 1}], [], 'unknown panel'),
    ('sensor_stuck', 7, [], "panels must be '*'"),
])
def test_a_bad_request_is_refused_with_its_reason(kind, panels, values, reason):
    with pytest.raises(FaultRequestError, match=reason):
        parse_request(kind, panels, values, FACADE)


def test_a_good_request_round_trips_through_the_message_fields():
    request = parse_request('leak', 'r00c01, r00c02',
                            [('conductance_m3_s_pa', '2e-08'), ('duration_s', '30')], FACADE)
    assert request.panels == ('r00c01', 'r00c02') and request.duration_s == 30.0
    assert request.values == {'conductance_m3_s_pa': 2e-8, 'duration_s': 30.0}
    kind, panels, values = request_fields(request)
    assert parse_request(kind, panels, values, FACADE) == request
    every = parse_request('supply_loss', '*', [], FACADE)
    assert every.every_panel and every.duration_s == math.inf
    assert 'every panel' in every.describe()


@pytest.fixture
def injector():
    model = ActuationModel([DEMONSTRATOR_ACTUATED] * 3)
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, CushionMap(model, samples=3), 3, seed=1)
    return FaultInjector(plant, ['r00c00', 'r00c01', 'r00c02'])


def request(kind, panels, **values):
    return parse_request(kind, panels, list(values.items()), FACADE)


def test_faults_go_into_the_plant_per_panel_and_come_out_per_panel(injector):
    plant = injector.plant
    injector.apply(request('leak', 'r00c00,r00c01', conductance_m3_s_pa=2e-8), 10.0)
    injector.apply(request('supply_loss', 'r00c01'), 10.0)
    injector.apply(request('sensor_noise', 'r00c02', noise_std_pa=300.0), 10.0)
    injector.apply(request('fill_valve_stuck_open', 'r00c02'), 10.0)
    injector.apply(request('sensor_stuck', 'r00c00'), 10.0)
    np.testing.assert_allclose(plant.faults.leak_conductance,
                               HEALTHY_LEAK + np.array([2e-8, 2e-8, 0.0]))
    assert list(plant.faults.supply_pa < DEMONSTRATOR_PLANT.supply_pressure_pa) == [
        False, True, False]
    assert list(plant.faults.fill_stuck_open) == [False, False, True]
    assert list(plant.sensors.noise_pa) == [20.0, 20.0, 300.0]
    assert injector.injected(0) == 'sensor_stuck, leak(2e-08)'
    assert injector.injected(1) == 'leak(2e-08), supply_loss'
    # the stuck sensor repeats itself; restoring another panel leaves it stuck
    stuck = plant.read_sensor()[0]
    injector.apply(request('restore', 'r00c01'), 11.0)
    assert plant.read_sensor()[0] == stuck
    assert injector.injected(1) == 'none'
    np.testing.assert_allclose(plant.faults.leak_conductance,
                               HEALTHY_LEAK + np.array([2e-8, 0.0, 0.0]))
    assert not plant.faults.supply_pa[1] < DEMONSTRATOR_PLANT.supply_pressure_pa
    injector.apply(request('supply_restore', '*'), 12.0)
    assert injector.injected(2) == 'sensor_noise(300), fill_valve_stuck_open'
    injector.apply(request('restore', '*'), 12.0)
    assert [injector.injected(i) for i in range(3)] == ['none'] * 3
    assert plant.read_sensor()[0] != stuck


def test_a_repeated_kind_replaces_its_figure(injector):
    injector.apply(request('leak', 'r00c00', conductance_m3_s_pa=2e-8), 1.0)
    injector.apply(request('leak', 'r00c00', conductance_m3_s_pa=5e-9), 1.0)
    assert injector.plant.faults.leak_conductance[0] == pytest.approx(HEALTHY_LEAK + 5e-9)


def test_a_timed_fault_ends_by_itself(injector):
    injector.apply(request('sensor_dropout', 'r00c01', duration_s=5.0), 100.0)
    injector.apply(request('supply_loss', 'r00c01'), 100.0)
    assert injector.expire(104.9) == []
    assert np.isnan(injector.plant.read_sensor()[1])
    assert injector.expire(105.0) == [('r00c01', 'sensor_dropout')]
    assert np.isfinite(injector.plant.read_sensor()[1])
    assert injector.injected(1) == 'supply_loss'
    with pytest.raises(FaultRequestError, match='needs the clock'):
        injector.apply(request('sensor_stuck', 'r00c00', duration_s=5.0), 0.0)


def test_panels_of_another_process_are_left_alone(injector):
    assert injector.apply(request('sensor_stuck', 'r05c05'), 1.0).size == 0
    assert [injector.injected(i) for i in range(3)] == ['none'] * 3
