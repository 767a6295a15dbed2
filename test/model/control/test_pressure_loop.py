"""The pressure loop against the simulated plant: step response, limits, faults, safe actions."""

import numpy as np
import pytest

from flectofold_model.actuation import (ActuationModel, ATMOSPHERIC_PRESSURE_PA,
                                        conductance_from_catalogue, CushionMap,
                                        DEMONSTRATOR_ACTUATED, DEMONSTRATOR_PLANT,
                                        physical_fill_time_s, PlantParameters, PneumaticPlant,
                                        UnreachableClosureWarning)
from flectofold_model.control.loop_simulation import simulate, step_metrics
from flectofold_model.control.pressure_loop import (ControllerParameters, Fault,
                                                    PressureController, SafeAction)

FAULT_TIME_S = 15.0


def demonstrator_map(count):
    return CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED] * count))


def run(count, setpoint, duration_s, events=(), plant=DEMONSTRATOR_PLANT, seed=1, **options):
    table = demonstrator_map(count)
    controller = PressureController(table, plant, **options)
    trace = simulate(controller, PneumaticPlant(plant, table, count, seed=seed), setpoint,
                     duration_s, events=events)
    return trace, controller


@pytest.fixture(scope='module')
def step():
    table = demonstrator_map(1)
    fill_time = physical_fill_time_s(DEMONSTRATOR_PLANT, table, table.pressure_pa[0, -1])
    trace, _ = run(1, lambda t: 0.0 if t < 1.0 else 1.0, 1.0 + 1.5 * fill_time + 8.0)
    return trace, fill_time


def test_full_step_settles_within_the_fill_time_plus_half(step):
    trace, fill_time = step
    metrics = step_metrics(trace, 0, step_time_s=1.0)
    assert 3.0 < fill_time < 30.0  # the 1-30 s of docs/references.md section 5
    assert metrics.settling_time_s <= 1.5 * fill_time
    assert metrics.overshoot_fraction < 0.05
    assert metrics.steady_error_fraction < 0.01  # with the sensor's 20 Pa noise on
    assert trace.closure[-1, 0] == pytest.approx(1.0, abs=0.01)


def test_reference_respects_the_rate_limit(step):
    trace, _ = step
    limit = ControllerParameters().setpoint_rate_pa_per_s * 0.01
    assert np.max(np.abs(np.diff(trace.reference_gauge_pa[:, 0]))) <= limit * (1 + 1e-9)


def test_the_valves_never_fight(step):
    trace, _ = step
    assert not np.any((trace.fill_opening > 0) & (trace.vent_opening > 0))


@pytest.fixture(scope='module')
def faults():
    """Ten demonstrator panels; nine get a fault at 15 s, three of them in a storm hold.

    Panels 0-5 hold closure 0.6 and vent when faulted: 0 stays healthy; 1 sensor stuck,
    2 sensor dropout, 3 a leak the fill valve cannot make up, 4 supply lost, 5 fill valve
    jammed open. Panel 6 is closed when its fill valve jams. Panels 7-9 hold closure 0.6 in
    a storm hold: 7 sensor stuck, 8 supply lost, 9 sensor dropout.
    """
    leak = conductance_from_catalogue(5.0)
    injections = {'inject_sensor_stuck': [1, 7], 'inject_sensor_dropout': [2, 9],
                  'inject_supply_loss': [4, 8], 'inject_fill_valve_stuck_open': [5, 6]}
    events = [(FAULT_TIME_S, lambda plant, _: plant.inject_leak([3], leak))]
    events += [(FAULT_TIME_S, lambda plant, _, name=name, panels=panels:
                getattr(plant, name)(panels)) for name, panels in injections.items()]
    table = demonstrator_map(10)
    controller = PressureController(table, DEMONSTRATOR_PLANT)
    controller.set_safe_action(SafeAction.HOLD, [7, 8, 9])
    setpoint = np.array([0.6] * 6 + [1.0] + [0.6] * 3)
    trace = simulate(controller, PneumaticPlant(DEMONSTRATOR_PLANT, table, 10, seed=1),
                     setpoint, 40.0, events=events)
    return trace, controller


@pytest.mark.parametrize('panel, fault, latest_s', [
    (1, Fault.SENSOR_STUCK, 1.0),
    (2, Fault.SENSOR_DROPOUT, 0.2),
    (3, Fault.LEAK, 8.0),
    (4, Fault.SUPPLY_LOST, 0.5),
    (5, Fault.FILL_VALVE_STUCK, 8.0),
    (6, Fault.FILL_VALVE_STUCK, 8.0),
])
def test_each_injected_fault_is_named_in_time_and_vented(faults, panel, fault, latest_s):
    trace, controller = faults
    raised = np.flatnonzero(trace.fault[:, panel] != Fault.NONE.value)
    assert raised.size and trace.time_s[raised[0]] >= FAULT_TIME_S
    assert trace.time_s[raised[0]] <= FAULT_TIME_S + latest_s
    assert set(trace.fault[raised, panel]) == {fault.value}
    assert controller.fault[panel] is fault
    after = raised[0] + 1
    assert np.all(trace.fill_opening[after:, panel] == 0.0)
    assert np.all(trace.vent_opening[after:, panel] == 1.0)


def test_healthy_panel_is_untouched_and_holds_its_closure(faults):
    trace, _ = faults
    assert np.all(trace.fault[:, 0] == Fault.NONE.value)
    assert trace.closure[-1, 0] == pytest.approx(0.6, abs=0.01)


def test_vented_panels_spring_open(faults):
    trace, _ = faults
    assert np.all(trace.closure[-1, 1:5] < 0.05)
    # A jammed fill valve keeps feeding air: venting holds the panel, it cannot open it.
    assert np.all(trace.closure[-1, 5:7] < 1.0)


def test_no_fault_takes_the_cushion_past_the_maximum(faults):
    trace, _ = faults
    assert np.max(trace.gauge_pa) <= ControllerParameters().max_gauge_pa


def test_storm_hold_keeps_the_position_with_both_valves_shut(faults):
    trace, controller = faults
    assert [fault.value for fault in controller.fault[7:]] == [
        'sensor_stuck', 'supply_lost', 'sensor_dropout']
    late = trace.time_s > FAULT_TIME_S + 1.0
    assert np.all(trace.fill_opening[late, 7:] == 0.0)
    assert np.all(trace.vent_opening[late, 7:] == 0.0)
    np.testing.assert_allclose(trace.closure[-1, 7:], 0.6, atol=0.01)


def test_overpressure_is_vented_even_in_a_storm_hold():
    """A fill valve jammed open at closed pressure, with a vent too small to out-flow it.

    The controller names the over-pressure and vents; only the relief valve can cap this
    pressure, which is why the demonstrator's vent valve is sized to out-flow the fill valve.
    """
    weak_vent = PlantParameters(fill_conductance_m3_s_pa=conductance_from_catalogue(1.0))
    table = demonstrator_map(2)
    controller = PressureController(table, weak_vent)
    controller.set_safe_action(SafeAction.HOLD, [1])
    events = [(14.0, lambda plant, _: plant.inject_fill_valve_stuck_open([0, 1]))]
    trace = simulate(controller, PneumaticPlant(weak_vent, table, 2, seed=1), 1.0, 22.0,
                     events=events)
    assert [fault.value for fault in controller.fault] == ['overpressure', 'overpressure']
    parameters = ControllerParameters()
    for panel in (0, 1):
        raised = np.flatnonzero(trace.fault[:, panel] != Fault.NONE.value)[0]
        assert trace.measured_gauge_pa[raised, panel] > (parameters.max_gauge_pa
                                                         - parameters.pressure_margin_pa)
        assert np.all(trace.vent_opening[raised + 1:, panel] == 1.0)
        assert np.all(trace.fill_opening[raised + 1:, panel] == 0.0)
    assert np.max(trace.gauge_pa) < weak_vent.relief_full_open_pa


def test_reset_after_repair_resumes_control():
    table = demonstrator_map(1)
    controller = PressureController(table, DEMONSTRATOR_PLANT)
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, table, 1, seed=4)
    events = [(8.0, lambda p, _: p.inject_sensor_dropout([0])),
              (10.0, lambda p, c: (p.clear_faults(), c.reset_faults()))]
    trace = simulate(controller, plant, 0.4, 20.0, events=events)
    assert Fault.SENSOR_DROPOUT.value in set(trace.fault[:, 0])
    assert trace.fault[-1, 0] == Fault.NONE.value
    assert trace.closure[-1, 0] == pytest.approx(0.4, abs=0.01)


def test_a_weak_supply_limits_the_target_instead_of_faulting():
    weak = PlantParameters(supply_pressure_pa=ATMOSPHERIC_PRESSURE_PA + 6e3,
                           fill_conductance_m3_s_pa=conductance_from_catalogue(1.0))
    table = demonstrator_map(1)
    with pytest.warns(UnreachableClosureWarning, match=r'let it reach closure 0\.79'):
        controller = PressureController(table, weak)
    plant = PneumaticPlant(weak, table, 1, seed=2, initial_gauge_pa=4e3)
    trace = simulate(controller, plant, 1.0, 15.0)
    assert controller.fault[0] is Fault.NONE
    assert controller.limited_by_supply[0]
    np.testing.assert_allclose(trace.target_gauge_pa[-1, 0], 5e3, atol=100.0)
    assert trace.gauge_pa[-1, 0] == pytest.approx(5e3, abs=150.0)
    assert np.max(trace.gauge_pa) < 6e3


def test_same_seed_same_run():
    first, _ = run(2, 0.5, 3.0, seed=9)
    second, _ = run(2, 0.5, 3.0, seed=9)
    np.testing.assert_array_equal(first.gauge_pa, second.gauge_pa)
    np.testing.assert_array_equal(first.fill_opening, second.fill_opening)


@pytest.mark.parametrize('closure', [float('nan'), 1.5, -0.2])
def test_bad_setpoints_are_refused(closure):
    controller = PressureController(demonstrator_map(1), DEMONSTRATOR_PLANT)
    with pytest.raises(ValueError, match='closure'):
        controller.step(0.01, closure, ATMOSPHERIC_PRESSURE_PA, 151325.0)


@pytest.mark.parametrize('options, error, message', [
    ({'max_gauge_pa': -1.0}, ValueError, 'max_gauge_pa must not be negative'),
    ({'time_constant_s': 0.0}, ValueError, 'time_constant_s must be positive'),
    ({'pressure_margin_pa': 7e3}, ValueError, 'leaves no working range'),
    ({'integral_time_s': float('nan')}, ValueError, 'integral_time_s must be finite'),
])
def test_bad_controller_parameters_are_refused(options, error, message):
    with pytest.raises(error, match=message):
        ControllerParameters(**options)


def test_a_maximum_above_the_relief_valve_is_refused():
    with pytest.raises(ValueError, match='must stay below the relief valve'):
        PressureController(demonstrator_map(1), DEMONSTRATOR_PLANT,
                           ControllerParameters(max_gauge_pa=20e3))


def test_a_fault_latched_from_outside_takes_the_safe_action_and_keeps_a_first_cause():
    from flectofold_model.actuation import ActuationModel, CushionMap, DEMONSTRATOR_ACTUATED
    from flectofold_model.actuation.circuit import DEMONSTRATOR_PLANT
    from flectofold_model.control import Fault, PressureController
    cushion_map = CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED] * 2), samples=5)
    controller = PressureController(cushion_map, DEMONSTRATOR_PLANT)
    controller.codes[0, 1] = list(Fault).index(Fault.LEAK)
    assert controller.latch_fault(Fault.COMMS_LOST) == 1
    assert list(controller.fault) == [Fault.COMMS_LOST, Fault.LEAK]
    command = controller.step(0.1, [1.0, 1.0], [np.nan, np.nan], [np.nan, np.nan])
    assert list(command.fill_opening) == [0.0, 0.0] and list(command.vent_opening) == [1.0, 1.0]
    with pytest.raises(ValueError, match='other than NONE'):
        controller.latch_fault(Fault.NONE)
