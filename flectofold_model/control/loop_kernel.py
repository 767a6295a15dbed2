"""One control period of one panel's pressure loop, compiled: the loop's only implementation.

:class:`~.pressure_loop.PressureController` keeps every panel's loop state in one float array
(rows named below) and its fault and safe action as integer codes; :func:`control_all` runs
one period of every panel's loop on them, and :func:`control_panel` one panel's, which the
compiled simulation of whole loops (:mod:`.simulation_kernel`) calls between plant steps. The
algorithm is the one :mod:`.pressure_loop` describes, step for step; keeping it here, in one
place, is what lets a simulated facade run its loops hundreds of periods per call without a
second copy of them. Compiled with numba on first use and cached on disk.

Pressures in Pa (absolute unless the name says gauge), times in s.
"""

import math

import numpy as np

from flectofold_model._compiled import inline_kernel, kernel
from flectofold_model.actuation.flow import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.actuation.integration import cushion_off_stops, mass_flow, off_stops

_ATM = ATMOSPHERIC_PRESSURE_PA

# Rows of the loop state (F, N).
TARGET, REFERENCE, FILTERED, INTEGRAL, SUPPLY, LAST_READING, STARTED = range(7)
STUCK_TIMER, DROPOUT_TIMER, LEAK_TIMER, INFLOW_TIMER, SUPPLY_TIMER = range(7, 12)
LEAK_START, INFLOW_START, EXPECTED_CHANGE = range(12, 15)
FILL_CAPACITY, VENT_CAPACITY, INFLOW_CAPACITANCE, LAST_FILL, LAST_VENT, LIMITED, TARGET_LIMIT = \
    range(15, 22)
STATE_ROWS = 22
# Rows of the codes (2, N) and their values: Fault and SafeAction in pressure_loop.
FAULT, SAFE_ACTION = 0, 1
NO_FAULT, SENSOR_STUCK, SENSOR_DROPOUT, LEAK, SUPPLY_LOST, FILL_VALVE_STUCK, OVERPRESSURE, \
    COMMS_LOST = range(8)  # COMMS_LOST: latched from outside the kernel (PanelLoops)
VENT, HOLD = 0, 1
#: A reference at or below this [Pa gauge] is the open (vented) position: the loop never fills.
OPEN_REFERENCE_PA = 1.0
# Fields of the parameter tuple, in ControllerParameters' order.
(_MAX, _MARGIN, _RATE, _TAU, _TI, _FILTER, _SUPPLY_FILTER, _STUCK_TIME, _NOISE, _DROPOUT_TIME,
 _LEAK_TIME, _LEAK_ERROR, _SUPPLY_MARGIN, _SUPPLY_TIME, _HOLD_BAND) = range(15)


def parameter_tuple(parameters):
    """Return the :class:`~.pressure_loop.ControllerParameters` as the kernels take them."""
    p = parameters
    return (p.max_gauge_pa, p.pressure_margin_pa, p.setpoint_rate_pa_per_s, p.time_constant_s,
            p.integral_time_s, p.measurement_filter_s, p.supply_filter_s, p.stuck_time_s,
            p.expected_noise_pa, p.dropout_time_s, p.leak_time_s, p.leak_error_pa,
            p.supply_margin_pa, p.supply_time_s, p.hold_band_pa)


@inline_kernel
def pressure_for_closure(tables, i, closure):
    """Gauge pressure [Pa] holding ``closure`` of panel ``i``: the map, interpolated."""
    pressure_table, closures, row = tables[0], tables[5], tables[4]
    position = closure / (closures[1] - closures[0])
    lower = min(int(position), closures.shape[0] - 2)
    values = pressure_table[row[i]]
    return values[lower] + (position - lower) * (values[lower + 1] - values[lower])


@inline_kernel
def feedback(tables, i, gauge_pa):
    """Closure and apex fold angle [rad] of panel ``i`` at a gauge pressure, by the map."""
    pressure_table, fold_table, row, closures = tables[0], tables[3], tables[4], tables[5]
    values = pressure_table[row[i]]
    last = values.shape[0] - 1
    clipped = min(max(gauge_pa, values[0]), values[last])
    lower = min(max(np.searchsorted(values, clipped) - 1, 0), last - 1)
    fraction = (clipped - values[lower]) / (values[lower + 1] - values[lower])
    closure = closures[lower] + fraction * (closures[1] - closures[0])
    position = closure * last
    at = min(int(position), last - 1)
    folds = fold_table[row[i]]
    return closure, folds[at] + (position - at) * (folds[at + 1] - folds[at])


@kernel
def feedback_all(state, tables, closure, fold_angle_rad):
    """Closure and apex fold angle (N,) of every panel at its filtered pressure."""
    for i in range(closure.shape[0]):
        closure[i], fold_angle_rad[i] = feedback(tables, i, max(state[FILTERED, i], 0.0))


@inline_kernel
def control_panel(i, dt_s, setpoint, measured_pa, supply_pa, state, codes, parameters, circuit,
                  tables):
    """One period of panel ``i``'s loop: update its state, return its fill and vent openings."""
    fill_conductance, vent_conductance, critical_ratio, temperature_scale, dead_volume, rt = \
        circuit
    wanted = min(pressure_for_closure(tables, i, setpoint), state[TARGET_LIMIT, i])
    # the supply reading, smoothed; NaN while it gives none
    supply_gauge = supply_pa - _ATM
    finite_supply = math.isfinite(supply_gauge)
    smoothed = state[SUPPLY, i]
    if finite_supply and not math.isfinite(smoothed):
        smoothed = supply_gauge
    blend = dt_s / (parameters[_SUPPLY_FILTER] + dt_s)
    smoothed = smoothed + blend * (supply_gauge - smoothed) if finite_supply else np.nan
    state[SUPPLY, i] = smoothed
    reachable = smoothed - 2 * parameters[_SUPPLY_MARGIN]
    limited = smoothed > parameters[_SUPPLY_MARGIN] and reachable < wanted
    state[LIMITED, i] = 1.0 if limited else 0.0
    target = max(reachable, 0.0) if limited else wanted
    state[TARGET, i] = target
    # the measurement filter; a first reading starts the loop on it
    readable = math.isfinite(measured_pa)
    if readable:
        gauge = measured_pa - _ATM
        if state[STARTED, i] == 0.0:
            state[FILTERED, i] = gauge
            state[REFERENCE, i] = gauge
            state[INTEGRAL, i] = 0.0
            state[STARTED, i] = 1.0
        blend = dt_s / (parameters[_FILTER] + dt_s)
        state[FILTERED, i] = state[FILTERED, i] + blend * (gauge - state[FILTERED, i])
    pressure = state[FILTERED, i]
    # the rate-limited reference
    previous_reference = state[REFERENCE, i]
    largest = parameters[_RATE] * dt_s
    reference = previous_reference + min(max(target - previous_reference, -largest), largest)
    state[REFERENCE, i] = reference
    fill, vent = _regulate(i, dt_s, previous_reference, supply_pa, state, parameters, circuit,
                           tables)
    _detect_faults(i, dt_s, measured_pa, readable, supply_pa, state, codes, parameters)
    fill, vent = _apply_safety(i, fill, vent, readable, pressure, codes, parameters)
    state[LAST_READING, i] = measured_pa if readable else np.nan
    state[LAST_FILL, i], state[LAST_VENT, i] = fill, vent
    return fill, vent


@inline_kernel
def _regulate(i, dt_s, previous_reference, supply_pa, state, parameters, circuit, tables):
    """PI in pressure-rate space, linearised by the capacitance and the valves' capacities."""
    fill_conductance, vent_conductance, critical_ratio, temperature_scale, dead_volume, rt = \
        circuit
    pressure, reference = state[FILTERED, i], state[REFERENCE, i]
    error = reference - pressure
    rate = ((reference - previous_reference) / dt_s
            + (error + state[INTEGRAL, i] / parameters[_TI]) / parameters[_TAU])
    gauge = max(pressure, 0.0)
    volume, free_compliance = cushion_off_stops(tables[0], tables[1], tables[2], tables[4][i],
                                                gauge)
    compliance = free_compliance * off_stops(tables[0][tables[4][i]], gauge)
    absolute = pressure + _ATM
    capacitance = (volume + dead_volume + absolute * compliance) / rt
    # The inflow test expects of a vent no more than the least drop the cushion allows: with
    # the table's compliance, not the one ramped to zero on a stop. A panel resting on its
    # closed stop leaves it within a few pascals, onto a compliance that may be 40 times the
    # gas's alone (a structural map, msg_docs/structure.md): the ramped one predicted a first
    # drop the vent could not make, read as air coming in (fill_valve_stuck).
    largest_capacitance = (volume + dead_volume + absolute * free_compliance) / rt
    demand = capacitance * rate
    upstream = supply_pa if math.isfinite(supply_pa) else 0.0
    # Opening the fill valve against a supply no higher than the cushion would drain it.
    can_fill = upstream > absolute + parameters[_SUPPLY_MARGIN]
    fill_capacity = mass_flow(max(upstream, absolute + 1.0), absolute, fill_conductance,
                              critical_ratio, temperature_scale)
    vent_capacity = mass_flow(max(absolute, _ATM + 1.0), _ATM, vent_conductance,
                              critical_ratio, temperature_scale)
    state[FILL_CAPACITY, i] = fill_capacity if can_fill else 0.0
    state[VENT_CAPACITY, i], state[INFLOW_CAPACITANCE, i] = vent_capacity, largest_capacitance
    # A vented cushion cannot go below the atmosphere, so at the open reference a reading below
    # it is sensor noise or offset: filling on it would put air into a panel meant to lie flat
    # (seen: a storm position held at 150 Pa after a noisy reading of -70 Pa).
    vented = reference <= OPEN_REFERENCE_PA
    fill_wish = demand / fill_capacity if demand > 0 and can_fill and not vented else 0.0
    vent_wish = -demand / vent_capacity if demand < 0 else 0.0
    saturated = (fill_wish > 1.0 and error > 0) or (vent_wish > 1.0 and error < 0)
    target = state[TARGET, i]
    resting = reference == target and abs(target - pressure) < parameters[_HOLD_BAND]
    if not (saturated or resting or (vented and error > 0)):
        state[INTEGRAL, i] += error * dt_s
    if resting:
        return 0.0, 0.0
    return min(max(fill_wish, 0.0), 1.0), min(max(vent_wish, 0.0), 1.0)


@inline_kernel
def _detect_faults(i, dt_s, measured_pa, readable, supply_pa, state, codes, parameters):
    state[DROPOUT_TIMER, i] = 0.0 if readable else state[DROPOUT_TIMER, i] + dt_s
    moving_air = state[LAST_FILL, i] > 0.05 or state[LAST_VENT, i] > 0.05
    expect_change = moving_air or parameters[_NOISE] > 0
    repeated = readable and measured_pa == state[LAST_READING, i] and expect_change
    state[STUCK_TIMER, i] = state[STUCK_TIMER, i] + dt_s if repeated else 0.0
    leaking = _leak_stalled(i, dt_s, readable, state, parameters)
    inflowing = _uncommanded_inflow(i, dt_s, readable, state, parameters)
    # A supply reading no higher than the atmosphere means no supply at all; a weak one only
    # limits the target.
    no_supply = not (supply_pa - _ATM > parameters[_SUPPLY_MARGIN])
    state[SUPPLY_TIMER, i] = state[SUPPLY_TIMER, i] + dt_s if no_supply else 0.0
    if codes[FAULT, i] != NO_FAULT:
        return
    if readable and measured_pa - _ATM > parameters[_MAX] - parameters[_MARGIN]:
        codes[FAULT, i] = OVERPRESSURE
    elif state[DROPOUT_TIMER, i] >= parameters[_DROPOUT_TIME]:
        codes[FAULT, i] = SENSOR_DROPOUT
    elif state[STUCK_TIMER, i] >= parameters[_STUCK_TIME]:
        codes[FAULT, i] = SENSOR_STUCK
    elif state[SUPPLY_TIMER, i] >= parameters[_SUPPLY_TIME]:
        codes[FAULT, i] = SUPPLY_LOST
    elif inflowing:
        codes[FAULT, i] = FILL_VALVE_STUCK
    elif leaking:
        codes[FAULT, i] = LEAK


@inline_kernel
def _leak_stalled(i, dt_s, readable, state, parameters):
    """Return whether the pressure stalled short of the reference with the fill valve open.

    True after a whole leak window with the fill valve wide open and the pressure short of the
    reference, in which it gained less than ``leak_error_pa``.
    """
    timer = state[LEAK_TIMER, i]
    armed = (readable and state[LAST_FILL, i] >= 0.999
             and state[REFERENCE, i] - state[FILTERED, i] > parameters[_LEAK_ERROR])
    if not (armed and timer > 0):
        state[LEAK_START, i] = state[FILTERED, i]
    timer = timer + dt_s if armed else 0.0
    window_done = timer >= parameters[_LEAK_TIME]
    stalled = window_done and state[FILTERED, i] - state[LEAK_START, i] < parameters[_LEAK_ERROR]
    state[LEAK_TIMER, i] = 0.0 if window_done and not stalled else timer
    return stalled


@inline_kernel
def _uncommanded_inflow(i, dt_s, readable, state, parameters):
    """Return whether venting failed to lower the pressure as the valve model says."""
    start = state[INFLOW_START, i]
    expected = state[EXPECTED_CHANGE, i] + dt_s * (
        state[LAST_FILL, i] * state[FILL_CAPACITY, i]
        - state[LAST_VENT, i] * state[VENT_CAPACITY, i]) / state[INFLOW_CAPACITANCE, i]
    # No vent takes the cushion below the atmosphere: without this floor a full vent through
    # the open stop predicts a drop far larger than the pressure has, read as air coming in.
    expected = max(expected, -max(start, 0.0))
    timer = state[INFLOW_TIMER, i] + dt_s if readable else 0.0
    window_done = timer >= parameters[_LEAK_TIME]
    unexplained = (state[FILTERED, i] - start) - expected
    error = parameters[_LEAK_ERROR]
    inflow = window_done and expected < -error and unexplained > max(error, -0.5 * expected)
    if window_done or not readable:
        timer, expected = 0.0, 0.0
        state[INFLOW_START, i] = state[FILTERED, i]
    state[INFLOW_TIMER, i], state[EXPECTED_CHANGE, i] = timer, expected
    return inflow


@inline_kernel
def _apply_safety(i, fill, vent, readable, gauge, codes, parameters):
    if gauge >= parameters[_MAX] - 2 * parameters[_MARGIN]:
        fill = 0.0
    if not readable:  # no trustworthy reading yet: do nothing rather than guess
        fill, vent = 0.0, 0.0
    fault = codes[FAULT, i]
    if fault != NO_FAULT:
        fill = 0.0
        # Air coming in uncommanded would over-pressure a held panel: that one always vents.
        vent = 1.0 if codes[SAFE_ACTION, i] == VENT or fault == FILL_VALVE_STUCK else 0.0
    # Near the maximum, or after an over-pressure until back below the fill cut-off, vent
    # whatever the safe action: a held storm position must not stay over-pressured.
    limit = parameters[_MAX] - parameters[_MARGIN]
    if readable and (gauge > limit or (fault == OVERPRESSURE
                                       and gauge > limit - parameters[_MARGIN])):
        vent = 1.0
    return fill, vent


@kernel
def control_all(dt_s, setpoint, measured_pa, supply_pa, state, codes, parameters, circuit,
                tables, fill, vent):
    """One period of every panel's loop; the openings land in ``fill`` and ``vent`` (N,)."""
    for i in range(setpoint.shape[0]):
        fill[i], vent[i] = control_panel(i, dt_s, setpoint[i], measured_pa[i], supply_pa[i],
                                         state, codes, parameters, circuit, tables)
