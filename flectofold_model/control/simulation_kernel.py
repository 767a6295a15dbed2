"""Many control periods of simulated pressure loops in one compiled call.

What :meth:`.panel_loops.PanelLoops.advance_to` does period by period against a simulated
driver (read the sensors, run every panel's loop, write the valves, integrate the plant over
the period, or over a quiet span while every panel rests), :func:`run_periods` does for up to
``max_runs`` periods (spans) without returning to Python: the sensors as
:class:`~flectofold_model.actuation.sensors.CushionSensors` reads them (noise drawn by the
caller from the sensors' own generator, in the same order), the loop by
:func:`.loop_kernel.control_panel`, the plant by the engine's
:func:`~flectofold_model.actuation.integration.advance_panel`. The same inputs give the same
numbers as the period-by-period path; the tests hold the two against each other.

It records each run's span and every panel's measurement, closure and fold angle after it,
for the loop to keep the states its nodes publish.
"""

import numpy as np

from flectofold_model._compiled import inline_kernel, kernel
from flectofold_model.actuation.integration import advance_panel
from flectofold_model.control.loop_kernel import (control_panel, feedback_all, LAST_FILL,
                                                  LAST_VENT, REFERENCE, TARGET)


@kernel
def _resting(setpoint, rested_setpoint, state, hold_band_pa):
    """Every panel at rest: setpoint unchanged, valves shut, reference at its target."""
    if hold_band_pa <= 0.0:
        return False
    for i in range(setpoint.shape[0]):
        if setpoint[i] != rested_setpoint[i] or state[LAST_FILL, i] != 0.0 or \
                state[LAST_VENT, i] != 0.0 or state[REFERENCE, i] != state[TARGET, i]:
            return False
    return True


@inline_kernel
def _active(state, i):
    """Whether the loop moves panel ``i``: a valve open or its reference still ramping."""
    return state[LAST_FILL, i] != 0.0 or state[LAST_VENT, i] != 0.0 or \
        state[REFERENCE, i] != state[TARGET, i]


@kernel
def _read_sensors(run, noise, plant, sensors, measured, supply_reading):
    """Write every panel's cushion and supply readings, as the sensors give them."""
    lagged, supply_pa = plant[3], plant[7]
    offset_pa, noise_pa, stuck, dropout, last_reading, supply_noise_pa = sensors
    for i in range(measured.shape[0]):
        reading = lagged[i] + offset_pa + noise[run, 0, i] * noise_pa[i]
        if stuck[i]:
            reading = last_reading[i]
        if dropout[i]:
            reading = np.nan
        if not stuck[i]:
            last_reading[i] = reading
        measured[i] = reading
        supply_reading[i] = supply_pa[i] + noise[run, 1, i] * supply_noise_pa


@kernel
def run_periods(periods, max_runs, period_s, quiet_periods, setpoint, rested_setpoint, noise,
                state, codes, parameters, circuit, tables, plant, engine, sensors, fill, vent,
                spans, measured, closure, fold_angle_rad, active):
    """Run up to ``periods`` control periods in at most ``max_runs`` runs.

    ``plant`` is the engine's arrays (pressure, free air, vented, lagged pressure, step length,
    leak conductance, fill valve jammed, supply pressure), ``engine`` its constants
    (conductances of the fill and vent valves, its cushion tables and rows, the circuit tuple,
    sensor lag, tolerance), ``sensors`` theirs (offset, cushion noise (N,), stuck, dropout,
    last reading, supply noise); ``noise`` (max_runs, 2, N) the standard normal draws of the
    cushion and supply sensors. ``fill`` and ``vent`` hold the valve openings in force and are
    updated. Run ``r`` writes its span to ``spans[r]`` and the state after it to row
    ``r + 1`` of ``measured``, ``closure`` and ``fold_angle_rad``.
    Returns the runs made, the periods they covered, the quiet spans among them and the plant
    steps accepted and rejected.
    """
    pressure, free_air, vented, lagged, step_s, leak, fill_stuck, supply_pa = plant
    fill_max, vent_max, plant_tables, plant_row, plant_circuit, sensor_lag_s, tolerance_pa = \
        engine
    count = setpoint.shape[0]
    fill_conductance = np.empty(count)
    vent_conductance = np.empty(count)
    supply_reading = np.empty(count)
    runs, done, quiet, accepted, rejected = 0, 0, 0, 0, 0
    while done < periods and runs < max_runs:
        resting = quiet_periods > 1 and _resting(setpoint, rested_setpoint, state,
                                                 parameters[14])
        span = min(quiet_periods, periods - done) if resting else 1
        rested_setpoint[:] = setpoint
        reading = measured[runs + 1]
        _read_sensors(runs, noise, plant, sensors, reading, supply_reading)
        woke = False
        for i in range(count):
            fill[i], vent[i] = control_panel(i, span * period_s, setpoint[i], reading[i],
                                             supply_reading[i], state, codes, parameters,
                                             circuit, tables)
            woke = woke or fill[i] != 0.0 or vent[i] != 0.0
        if span > 1 and woke:
            span = 1  # woke up: these openings hold for one short period only
        quiet += span > 1
        for i in range(count):
            fill_conductance[i] = (1.0 if fill_stuck[i] else fill[i]) * fill_max
            vent_conductance[i] = vent[i] * vent_max
        for i in range(count):
            a, r = advance_panel(i, span * period_s, pressure, free_air, vented, lagged, step_s,
                                 fill_conductance, vent_conductance, leak, supply_pa,
                                 plant_tables, plant_row, plant_circuit, sensor_lag_s,
                                 tolerance_pa)
            accepted += a
            rejected += r
        feedback_all(state, tables, closure[runs + 1], fold_angle_rad[runs + 1])
        for i in range(count):
            active[runs + 1, i] = _active(state, i)
        spans[runs] = span
        done += span
        runs += 1
    return runs, done, quiet, accepted, rejected
