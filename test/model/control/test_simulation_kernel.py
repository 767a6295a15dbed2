"""The compiled simulation of many periods gives the numbers of the period-by-period path.

:class:`PanelLoops` on the compiled engine runs whole stretches of periods in one compiled
call (``loops.compiled``); with that switched off it runs the same loop, sensors and plant one
period per Python call. The two must agree to the bit: setpoint moves, quiet spans, clock
leaps, injected faults and a held safe action included.
"""

import numpy as np
import pytest

from flectofold_model.actuation import (ActuationModel, conductance_from_catalogue, CushionMap,
                                        DEMONSTRATOR_ACTUATED, DEMONSTRATOR_PLANT,
                                        PneumaticPlant)
from flectofold_model.control import loop_kernel
from flectofold_model.control.hardware import SimulatedCushions
from flectofold_model.control.panel_loops import PanelLoops
from flectofold_model.control.pressure_loop import ControllerParameters, Fault, SafeAction

COUNT = 6


def loops(compiled, quiet_period_s=2.0):
    model = ActuationModel([DEMONSTRATOR_ACTUATED] * COUNT)
    cushion_map = CushionMap(model)
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, cushion_map, COUNT, seed=3,
                           integrator='embedded')
    result = PanelLoops(model, SimulatedCushions(plant), 0.1,
                        ControllerParameters(hold_band_pa=60.0), quiet_period_s=quiet_period_s,
                        cushion_map=cushion_map)
    assert result.compiled
    result.compiled = compiled
    result.request_sample_period(0, 0.3)
    return result


def script(loops, tick_s):
    """Run moves, rests, a leak, a stuck sensor held on its fault; return what was kept."""
    plant = loops.driver.plant
    loops.set_safe_action(SafeAction.HOLD, [4])
    loops.advance_to(0.0)
    now = 0.0
    trace = []
    steps = [(np.linspace(0.0, 1.0, COUNT), None), (np.full(COUNT, 0.6), None),
             (np.ones(COUNT), lambda: plant.inject_leak([2], conductance_from_catalogue(3.0))),
             (np.full(COUNT, 0.2), lambda: plant.inject_sensor_stuck([4])),
             (np.zeros(COUNT), None)]
    for setpoint, event in steps:
        loops.set_setpoints(setpoint)
        if event is not None:
            event()
        for _ in range(round(15.0 / tick_s)):
            now += tick_s
            loops.advance_to(now)
        trace.append((loops.gauge_pa, loops.closure, loops.fold_angle_rad, loops.fault,
                      loops.free_air_used_nl, loops.driver.valve_openings()))
    samples = [(s.sequence, s.time_s, s.closure, s.fold_angle_rad, s.measured_pa, s.active)
               for s in loops.samples]
    return trace, samples, loops.quiet_periods_run


@pytest.mark.parametrize('tick_s', [0.1, 0.7, 7.2])
def test_the_compiled_simulation_equals_the_period_by_period_path(tick_s):
    compiled = script(loops(True), tick_s)
    stepped = script(loops(False), tick_s)
    for (c_trace, s_trace) in zip(compiled[0], stepped[0]):
        for c, s in zip(c_trace[:3] + c_trace[4:5], s_trace[:3] + s_trace[4:5]):
            np.testing.assert_array_equal(c, s)
        assert list(c_trace[3]) == list(s_trace[3])
        for c, s in zip(c_trace[5], s_trace[5]):
            np.testing.assert_array_equal(c, s)
    assert len(compiled[1]) == len(stepped[1]) > 0
    for c, s in zip(compiled[1], stepped[1]):
        assert c[:2] == s[:2]
        for a, b in zip(c[2:], s[2:]):
            np.testing.assert_array_equal(a, b)
    assert compiled[2] == stepped[2]
    active = np.array([s[5] for s in compiled[1]])
    # every panel sent off the start moves; later the panels come to rest, sample by sample
    assert active[0][1:].all() and active.sum(axis=1).min() < COUNT // 2
    if tick_s > 1.0:
        assert compiled[2] > 0  # quiet spans were run, and alike
    assert compiled[0][-1][3][4] is Fault.SENSOR_STUCK  # a latched fault, held, alike


def test_a_stretch_is_split_into_calls_without_changing_anything():
    whole, split = loops(True), loops(True)
    split._runs_per_call = 8  # many short compiled calls instead of a few long ones
    for each in (whole, split):
        each.set_setpoints(np.linspace(0.0, 1.0, COUNT))
        each.advance_to(0.0)
        each.advance_to(60.0)
    np.testing.assert_array_equal(whole.gauge_pa, split.gauge_pa)
    assert [s.time_s for s in whole.samples] == [s.time_s for s in split.samples]


def test_sensor_draws_taken_ahead_and_handed_back_leave_the_readings_unchanged():
    model = ActuationModel([DEMONSTRATOR_ACTUATED] * 3)
    plain, ahead = (PneumaticPlant(DEMONSTRATOR_PLANT, CushionMap(model), 3, seed=5)
                    for _ in range(2))
    draws = ahead.sensors.draw_ahead(4)
    assert draws.shape == (4, 2, 3)
    ahead.sensors.put_back(draws[1:])  # one read's draws used, three handed back
    first = plain.read_sensor(), plain.read_supply_sensor()
    noise = DEMONSTRATOR_PLANT.sensor_noise_pa
    np.testing.assert_allclose(first[0] - plain.sensors.lagged_pa
                               - DEMONSTRATOR_PLANT.sensor_offset_pa, draws[0, 0] * noise)
    for _ in range(5):  # the handed-back draws first, then the generator's next ones
        np.testing.assert_array_equal(plain.read_sensor(), ahead.read_sensor())
        np.testing.assert_array_equal(plain.read_supply_sensor(), ahead.read_supply_sensor())


def test_the_kernel_fault_codes_are_the_faults_in_order():
    codes = {'NONE': loop_kernel.NO_FAULT, 'SENSOR_STUCK': loop_kernel.SENSOR_STUCK,
             'SENSOR_DROPOUT': loop_kernel.SENSOR_DROPOUT, 'LEAK': loop_kernel.LEAK,
             'SUPPLY_LOST': loop_kernel.SUPPLY_LOST,
             'FILL_VALVE_STUCK': loop_kernel.FILL_VALVE_STUCK,
             'OVERPRESSURE': loop_kernel.OVERPRESSURE, 'COMMS_LOST': loop_kernel.COMMS_LOST}
    assert [fault.name for fault in Fault] == sorted(codes, key=codes.get)
