"""A noisy cushion sensor: raised per panel, the same in the compiled and the stepped paths."""

import numpy as np
import pytest

from flectofold_model.actuation import (ActuationModel, CushionMap, DEMONSTRATOR_ACTUATED,
                                        DEMONSTRATOR_PLANT, PneumaticPlant)
from flectofold_model.control.hardware import SimulatedCushions
from flectofold_model.control.panel_loops import PanelLoops
from flectofold_model.control.pressure_loop import ControllerParameters

COUNT = 3


def plant_and_loops(compiled):
    model = ActuationModel([DEMONSTRATOR_ACTUATED] * COUNT)
    cushion_map = CushionMap(model)
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, cushion_map, COUNT, seed=2,
                           integrator='embedded')
    loops = PanelLoops(model, SimulatedCushions(plant), 0.1,
                       ControllerParameters(hold_band_pa=60.0), quiet_period_s=2.0,
                       cushion_map=cushion_map)
    loops.compiled = compiled
    loops.request_sample_period(0, 0.1)
    return plant, loops


def test_raised_noise_reads_at_its_deviation_on_its_panel_only():
    plant, _ = plant_and_loops(True)
    plant.inject_sensor_noise([1], 400.0)
    readings = np.array([plant.read_sensor() for _ in range(4000)])
    deviation = readings.std(axis=0)
    assert deviation[1] == pytest.approx(400.0, rel=0.05)
    np.testing.assert_allclose(deviation[[0, 2]], DEMONSTRATOR_PLANT.sensor_noise_pa, rtol=0.05)
    supply = np.array([plant.read_supply_sensor() for _ in range(4000)])
    np.testing.assert_allclose(supply.std(axis=0), DEMONSTRATOR_PLANT.sensor_noise_pa,
                               rtol=0.05)
    plant.clear_faults()
    readings = np.array([plant.read_sensor() for _ in range(4000)])
    assert readings.std(axis=0)[1] == pytest.approx(DEMONSTRATOR_PLANT.sensor_noise_pa, rel=0.05)


def run(compiled):
    plant, loops = plant_and_loops(compiled)
    loops.set_setpoints(0.5)
    loops.advance_to(0.0)
    loops.advance_to(20.0)
    plant.inject_sensor_noise([2], 300.0)
    loops.advance_to(40.0)
    return np.array([s.measured_pa for s in loops.samples]), loops.gauge_pa


def test_the_compiled_loop_reads_the_raised_noise_as_the_stepped_one():
    compiled, stepped = run(True), run(False)
    np.testing.assert_array_equal(compiled[0], stepped[0])
    np.testing.assert_array_equal(compiled[1], stepped[1])
    late = compiled[0][-150:]
    assert late[:, 2].std() > 150.0 > 5 * late[:, 0].std()


@pytest.mark.parametrize('value, error', [(-1.0, ValueError), (float('nan'), ValueError),
                                          ('loud', TypeError)])
def test_bad_noise_is_refused(value, error):
    plant, _ = plant_and_loops(True)
    with pytest.raises(error, match='noise_pa'):
        plant.inject_sensor_noise([0], value)
