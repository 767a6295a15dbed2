"""A simulated proportional pressure regulator on a cushion circuit's fill and vent valves.

On a regulator channel, :mod:`.terminal_sim` puts this model in place of the register's valve
openings: a proportional pressure regulator (a Festo VPPM-style valve), fed from the supply
and exhausting to the atmosphere, that holds its output at the gauge pressure of its setpoint
register with its own loop. The model is that loop, driving the simulated circuit's own fill
and vent valves (one plant for valve and regulator channels alike): at each plant step it
opens the one that moves the pressure toward the setpoint, in proportion to the error and
scaled by what that valve does fully open at the present pressure::

    opening = clip((setpoint_gauge_pa - gauge_pa) / (TIME_CONSTANT_S * dp/dt fully open), 0, 1)

so that the cushion approaches the setpoint as a first-order lag of :data:`TIME_CONSTANT_S`
wherever the valve can deliver that rate, and at the valve's full flow where it cannot (a
large step, a weak supply). The regulator reads the cushion's true pressure (its own sensor
at its output, not the terminal's noisy input), so it holds the setpoint without offset.
"""

import numpy as np

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA

#: The regulator's own closed-loop time constant [s]: a small valve's step response.
TIME_CONSTANT_S = 0.05


def regulator_openings(plant, setpoint_gauge_pa, time_constant_s=TIME_CONSTANT_S):
    """Fill and vent openings (N,) in [0, 1] that move ``plant`` toward the setpoints.

    Parameters
    ----------
    plant : PneumaticPlant
        The circuits, at their present pressures.
    setpoint_gauge_pa : array-like
        Setpoint of each channel (N,) [Pa gauge]; NaN (no valid setpoint) is taken as 0 Pa,
        the regulator exhausts.
    time_constant_s : float
        The regulator's closed-loop time constant [s]; a few plant steps at least.
    """
    setpoint = np.nan_to_num(np.asarray(setpoint_gauge_pa, dtype=np.float64), nan=0.0)
    count, circuit = plant.count, plant.parameters
    pressure = plant.absolute_pressure_pa
    shut, wide = np.zeros(count), np.ones(count)
    capacitance = plant.capacitance_m3(np.maximum(pressure, ATMOSPHERIC_PRESSURE_PA))
    rising = plant.rates(pressure, wide * circuit.fill_conductance_m3_s_pa, shut, capacitance)[0]
    falling = plant.rates(pressure, shut, wide * circuit.vent_conductance_m3_s_pa,
                          capacitance)[0]
    wanted_pa_s = (setpoint - plant.gauge_pressure_pa) / time_constant_s
    fill = np.where((wanted_pa_s > 0.0) & (rising > 0.0),
                    wanted_pa_s / np.where(rising > 0.0, rising, 1.0), 0.0)
    vent = np.where((wanted_pa_s < 0.0) & (falling < 0.0),
                    wanted_pa_s / np.where(falling < 0.0, falling, -1.0), 0.0)
    return np.clip(fill, 0.0, 1.0), np.clip(vent, 0.0, 1.0)
