"""Regulator setpoints from the pressure loop: tracking, vent, hold, comms loss, no reading."""

import math

import numpy as np
import pytest

from flectofold_model.actuation import (ActuationModel, ATMOSPHERIC_PRESSURE_PA, CushionMap,
                                        DEMONSTRATOR_ACTUATED, DEMONSTRATOR_PLANT)
from flectofold_model.control.hardware import CushionDriver
from flectofold_model.control.panel_loops import PanelLoops
from flectofold_model.control.pressure_loop import (ControllerParameters, Fault,
                                                    PressureController, SafeAction)
from flectofold_model.control.regulator import RegulatorSetpoints

PERIOD_S = 0.1
PARAMETERS = ControllerParameters(hold_band_pa=60.0)
SUPPLY_PA = DEMONSTRATOR_PLANT.supply_pressure_pa
#: Sensor noise [Pa]: bit-identical readings would be a stuck sensor.
NOISE_PA = 20.0


class Regulated:
    """Two loops whose cushions follow their setpoints as a 0.05 s lag (ideal regulators)."""

    def __init__(self):
        self.noise = np.random.default_rng(1)
        model = ActuationModel([DEMONSTRATOR_ACTUATED] * 2)
        self.controller = PressureController(CushionMap(model, samples=9), DEMONSTRATOR_PLANT,
                                             PARAMETERS)
        self.setpoints = RegulatorSetpoints(self.controller, np.array([True, True]))
        self.gauge_pa = np.zeros(2)
        self.link = np.array([True, True])

    def period(self, closure, readings=None):
        """One period; ``readings``: absolute readings instead of the cushions' pressures."""
        if readings is None:
            readings = np.where(self.link, self.gauge_pa + ATMOSPHERIC_PRESSURE_PA
                                + self.noise.normal(0.0, NOISE_PA, 2), np.nan)
        command = self.controller.step(PERIOD_S, closure, readings, np.full(2, SUPPLY_PA))
        setpoint = self.setpoints.update(command, readings)
        written = self.link  # nothing reaches a regulator whose link is down
        self.gauge_pa[written] += (setpoint[written] - self.gauge_pa[written]) * \
            (1.0 - math.exp(-PERIOD_S / 0.05))
        return setpoint

    def run(self, closure, seconds):
        for _ in range(round(seconds / PERIOD_S)):
            setpoint = self.period(closure)
        return setpoint


def test_the_setpoint_is_the_rate_limited_reference_and_reaches_the_target():
    loops = Regulated()
    loops.period([0.0, 0.0])
    setpoints = [loops.period([0.8, 0.3]) for _ in range(60)]
    controller = loops.controller
    np.testing.assert_allclose(setpoints[-1], controller.target_gauge_pa)
    np.testing.assert_allclose(setpoints[-1], controller.reference_gauge_pa)
    steps = np.diff(np.array(setpoints), axis=0)
    assert np.max(steps) <= PARAMETERS.setpoint_rate_pa_per_s * PERIOD_S * (1 + 1e-9)
    assert controller.target_gauge_pa[0] > 4000.0 > controller.target_gauge_pa[1] > 1000.0
    assert all(f is Fault.NONE for f in controller.fault)


def test_a_fault_that_vents_sets_0_pa():
    loops = Regulated()
    loops.run([0.8, 0.8], 6.0)
    loops.controller.latch_fault(Fault.LEAK, [0])
    setpoint = loops.period([0.8, 0.8])
    assert setpoint[0] == 0.0 and setpoint[1] > 4000.0


def test_a_fault_that_holds_keeps_the_setpoint_it_had_not_0_not_the_target():
    loops = Regulated()
    loops.controller.set_safe_action(SafeAction.HOLD)
    loops.period([0.0, 0.0])
    for _ in range(15):  # halfway up the ramp
        before = loops.period([1.0, 1.0])
    loops.controller.latch_fault(Fault.SENSOR_STUCK, [0])
    held = [loops.period([1.0, 1.0])[0] for _ in range(30)]
    assert held == [before[0]] * 30 and 0.0 < held[0] < loops.controller.target_gauge_pa[0]
    assert loops.setpoints.gauge_pa[1] == loops.controller.target_gauge_pa[1]
    loops.controller.reset_faults()  # tracking again, from the pressure it held
    assert loops.period([1.0, 1.0])[0] == pytest.approx(
        held[0] + PARAMETERS.setpoint_rate_pa_per_s * PERIOD_S, abs=30.0)


def test_an_over_pressure_vents_also_under_hold_then_holds_the_setpoint_before_it():
    loops = Regulated()
    loops.controller.set_safe_action(SafeAction.HOLD)
    before = loops.run([0.8, 0.8], 6.0)
    over = np.array([PARAMETERS.max_gauge_pa, 0.0]) + loops.gauge_pa + ATMOSPHERIC_PRESSURE_PA
    assert loops.period([0.8, 0.8], readings=over)[0] == 0.0
    assert loops.controller.fault[0] is Fault.OVERPRESSURE
    calm = loops.gauge_pa + ATMOSPHERIC_PRESSURE_PA
    assert loops.period([0.8, 0.8], readings=calm)[0] == before[0]


def test_after_a_comms_loss_vent_writes_0_and_hold_keeps_no_more_than_was_left():
    loops = Regulated()
    loops.controller.set_safe_action(SafeAction.HOLD, [1])
    before = loops.run([0.8, 0.8], 6.0)
    loops.link[:] = False
    loops.gauge_pa[:] = 0.4 * before  # meanwhile the terminal's fail-safe exhausted some
    for _ in range(5):
        loops.controller.latch_fault(Fault.COMMS_LOST)  # what PanelLoops does while lost
        setpoint = loops.period([0.8, 0.8])
        assert setpoint[0] == 0.0 and setpoint[1] == before[1]
    loops.link[:] = True
    back = loops.period([0.8, 0.8])
    assert back[0] == 0.0  # the first write: the vent
    assert back[1] == pytest.approx(0.4 * before[1], abs=3 * NOISE_PA)  # not refilled
    loops.gauge_pa[1] = before[1]  # a higher reading later does not raise it again
    assert loops.period([0.8, 0.8])[1] == back[1]


def test_without_a_reading_the_setpoint_stays_until_the_dropout_latches():
    loops = Regulated()
    before = loops.run([0.8, 0.8], 1.0)
    assert 1000.0 < before[0] < loops.controller.target_gauge_pa[0]  # still ramping
    nothing = np.array([np.nan, loops.gauge_pa[1] + ATMOSPHERIC_PRESSURE_PA])
    controller = loops.controller
    command = controller.step(0.01, [0.8, 0.8], nothing, np.full(2, SUPPLY_PA))
    assert controller.fault[0] is Fault.NONE  # 0.01 s: shorter than the dropout time
    assert loops.setpoints.update(command, nothing)[0] == before[0]
    assert loops.period([0.8, 0.8], readings=nothing)[0] == 0.0  # latched: vent


def test_the_integral_of_regulated_loops_is_held_at_zero():
    model = ActuationModel([DEMONSTRATOR_ACTUATED] * 2)
    controller = PressureController(CushionMap(model, samples=9), DEMONSTRATOR_PLANT,
                                    PARAMETERS)
    setpoints = RegulatorSetpoints(controller, np.array([True, False]))
    noise = np.random.default_rng(1)
    for _ in range(40):  # regulators that stay 100 Pa short of their setpoints
        low = ATMOSPHERIC_PRESSURE_PA + setpoints.gauge_pa - 100.0 + noise.normal(0.0, 5.0, 2)
        command = controller.step(PERIOD_S, [0.3, 0.3], low, np.full(2, SUPPLY_PA))
        setpoints.update(command, low)
    from flectofold_model.control.loop_kernel import INTEGRAL
    assert controller.state[INTEGRAL, 0] == 0.0 and controller.state[INTEGRAL, 1] > 0.0


def test_a_bad_mask_is_refused():
    controller = Regulated().controller
    with pytest.raises(ValueError, match='boolean mask of 2'):
        RegulatorSetpoints(controller, [1, 1])
    with pytest.raises(TypeError, match='PressureController'):
        RegulatorSetpoints(None, np.array([True, True]))


class IdealRegulators(CushionDriver):
    """A driver of ideal regulators on some channels: it records what the loop writes."""

    def __init__(self, regulated):
        self._regulated = np.array(regulated)
        self.gauge_pa = np.zeros(len(regulated))
        self.noise = np.random.default_rng(2)
        self.outputs, self.valves = [], []

    count = property(lambda self: len(self._regulated))
    circuit = property(lambda self: DEMONSTRATOR_PLANT)
    regulated = property(lambda self: self._regulated.copy())

    def read_pressure_pa(self):
        noise_pa = self.noise.normal(0.0, NOISE_PA, self.count)
        return self.gauge_pa + ATMOSPHERIC_PRESSURE_PA + noise_pa

    def read_supply_pa(self):
        return np.full(self.count, SUPPLY_PA)

    def write_valves(self, fill_opening, vent_opening):
        self.valves.append((fill_opening, vent_opening))

    def write_outputs(self, fill_opening, vent_opening, regulator_gauge_pa):
        self.outputs.append((fill_opening, vent_opening, regulator_gauge_pa))
        self.gauge_pa = np.where(self._regulated, regulator_gauge_pa, self.gauge_pa)


def test_panel_loops_write_setpoints_to_a_driver_with_regulators_and_track_through_them():
    model = ActuationModel([DEMONSTRATOR_ACTUATED] * 2)
    driver = IdealRegulators([True, False])
    loops = PanelLoops(model, driver, PERIOD_S, PARAMETERS)
    loops.set_setpoints([0.6, 0.6])
    for k in range(80):
        loops.advance_to(k * PERIOD_S)
    assert len(driver.outputs) == 79 and not driver.valves  # one write a period, with both
    fill, vent, setpoint = driver.outputs[-1]
    assert setpoint[0] == loops.controller.reference_gauge_pa[0]
    assert loops.closure[0] == pytest.approx(0.6, abs=0.01)
    assert loops.regulators.gauge_pa[0] == setpoint[0]


def test_a_driver_without_regulators_gets_valve_writes_only():
    model = ActuationModel([DEMONSTRATOR_ACTUATED])
    driver = IdealRegulators([False])
    loops = PanelLoops(model, driver, PERIOD_S, PARAMETERS)
    loops.advance_to(0.0)
    loops.advance_to(PERIOD_S)
    assert loops.regulators is None and len(driver.valves) == 1 and not driver.outputs


def test_regulators_need_a_hold_band_and_a_valve_driver_has_no_setpoints():
    model = ActuationModel([DEMONSTRATOR_ACTUATED])
    with pytest.raises(ValueError, match='hold_band_pa > 0'):
        PanelLoops(model, IdealRegulators([True]), PERIOD_S, ControllerParameters())

    class Valves(IdealRegulators):
        regulated = CushionDriver.regulated
        write_outputs = CushionDriver.write_outputs

    valves = Valves([True])
    assert valves.regulated.tolist() == [False]
    with pytest.raises(NotImplementedError, match='no pressure regulators'):
        valves.write_outputs([0.0], [0.0], [0.0])
