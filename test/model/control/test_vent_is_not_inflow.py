"""A healthy panel vented from closed to open raises no fault."""

import numpy as np

from flectofold_model.actuation import (ActuationModel, CushionMap, DEMONSTRATOR_ACTUATED,
                                        DEMONSTRATOR_PLANT, PneumaticPlant)
from flectofold_model.control.loop_simulation import simulate
from flectofold_model.control.pressure_loop import ControllerParameters, Fault, PressureController


def test_a_full_vent_from_closed_is_not_taken_for_a_jammed_fill_valve():
    # Before the prediction had its floor at the atmosphere, this raised fill_valve_stuck at
    # t = 5 s: the capacitance collapses to the tubing's at the open stop, and the predicted
    # drop ran to -30 kPa while the pressure could only fall by 8.6 kPa.
    cushion_map = CushionMap(ActuationModel([DEMONSTRATOR_ACTUATED]))
    closed = float(cushion_map.pressure_pa[0, -1])
    plant = PneumaticPlant(DEMONSTRATOR_PLANT, cushion_map, 1, seed=7, initial_gauge_pa=closed,
                           integrator='embedded')
    controller = PressureController(cushion_map, DEMONSTRATOR_PLANT,
                                    ControllerParameters(hold_band_pa=60.0))
    trace = simulate(controller, plant, lambda t: 1.0 if t < 2.0 else 0.0, 40.0,
                     control_period_s=0.1)
    assert trace.gauge_pa[-1, 0] < 100.0  # vented (it takes about 25 s, the last Pa slowly)
    assert np.all(trace.fault == Fault.NONE.value)
