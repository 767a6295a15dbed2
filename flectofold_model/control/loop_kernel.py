"""One control period of one panel's pressure loop, compiled: the loop's only implementation.

:class:`~.pressure_loop.PressureController` keeps every panel's loop state in one float array
(rows named below) and its fault and safe action as integer codes; :func:`control_all` runs
one period of every panel's loop on them, and :func:`control_panel` one panel's, which the
compiled simulation of whole loops (:mod:`.simulation_kernel`) calls between plant steps. The
algorithm is the one :mod:`.pressure_loop` describes, step for step; keeping it here, in one
place, is what lets a simulated facade run its loops hundreds of periods per call without a
second copy of them. Compiled with numba on first use and cached on disk.

The kernels' tuples have named fields (:class:`LoopParameters`, :class:`LoopCircuit`,
:class:`MapTables`), and kernel code reads them by name only. Python passes them as plain tuples
in the fields' order, and each kernel Python calls names them on entry (:func:`named_loop`,
free once compiled): numba types a named tuple argument on every call from its class and field
names, about 1 us each against 0.1 us for a plain tuple (numba 0.68; named arguments made a
period of the compiled simulation of 36 panels 8 us, a quarter, slower).

Pressures in Pa (absolute unless the name says gauge), times in s.
"""

import math
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from flectofold_model._compiled import inline_kernel, kernel
from flectofold_model._validate import FloatArray, IntArray
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


class LoopParameters(NamedTuple):
    """:class:`~.pressure_loop.ControllerParameters` as the kernels take them: the same fields.

    Pressures in Pa (gauge where a level), rates in Pa/s, times in s; see there for each.
    """

    max_gauge_pa: float
    pressure_margin_pa: float
    setpoint_rate_pa_per_s: float
    time_constant_s: float
    integral_time_s: float
    measurement_filter_s: float
    supply_filter_s: float
    stuck_time_s: float
    expected_noise_pa: float
    dropout_time_s: float
    leak_time_s: float
    leak_error_pa: float
    supply_margin_pa: float
    supply_time_s: float
    hold_band_pa: float


def parameter_tuple(parameters: object) -> tuple[float, ...]:
    """Return the :class:`~.pressure_loop.ControllerParameters` as the kernels take them.

    A plain tuple of the :class:`LoopParameters` fields, in their order, read by name from
    ``parameters`` (any object that has them; typed ``object`` because the loop's module
    imports this one).
    """
    return tuple(getattr(parameters, name) for name in LoopParameters._fields)


class LoopCircuit(NamedTuple):
    """A panel circuit's constants, shared by all panels."""

    fill_conductance_m3_s_pa: float
    """ISO 6358 conductance of the fully open fill valve [m^3/(s*Pa)]."""
    vent_conductance_m3_s_pa: float
    """ISO 6358 conductance of the fully open vent valve [m^3/(s*Pa)]."""
    critical_ratio: float
    """Critical pressure ratio of the valves [-]."""
    temperature_scale: float
    """ANR density times sqrt(ANR temperature / air temperature) [kg/m^3]: a conductance
    [m^3/(s*Pa)] times this and an upstream pressure [Pa] is a mass flow [kg/s]."""
    dead_volume_m3: float
    """Volume of the lines and fittings beside the cushion [m^3]."""
    rt_j_per_kg: float
    """Gas constant of air times its temperature [J/kg]."""


class MapTables(NamedTuple):
    """The static map's tables: :meth:`.CushionMap.compiled_tables`, in its order.

    The tables (R, S) hold each distinct panel's cushion at the closure samples.
    """

    pressure_pa: np.ndarray
    """Gauge pressure [Pa] (R, S), rising along each row."""
    volume_m3: np.ndarray
    """Cushion volume [m^3] (R, S)."""
    compliance_m3_per_pa: np.ndarray
    """Cushion compliance dV/dp [m^3/Pa] (R, S), off the stops."""
    fold_angle_rad: np.ndarray
    """Apex fold angle [rad] (R, S)."""
    row: np.ndarray
    """Each panel's row in the tables (N,), int64."""
    closures: np.ndarray
    """Closure samples (S,), evenly spaced from 0 to 1."""


@inline_kernel
def named_loop(parameters: tuple[float, ...], circuit: tuple[float, ...],
               tables: tuple[npt.NDArray[Any], ...]
               ) -> tuple[LoopParameters, LoopCircuit, MapTables]:
    """Return the loop's tuples with their fields named.

    :class:`LoopParameters`, :class:`LoopCircuit` and :class:`MapTables` of the plain tuples
    (or of named ones) Python passes.
    """
    return LoopParameters(*parameters), LoopCircuit(*circuit), MapTables(*tables)


@inline_kernel
def pressure_for_closure(tables: MapTables, i: int, closure: float) -> float:
    """Gauge pressure [Pa] holding ``closure`` of panel ``i``: the map, interpolated."""
    closures = tables.closures
    position = closure / (closures[1] - closures[0])
    lower = min(int(position), closures.shape[0] - 2)
    values = tables.pressure_pa[tables.row[i]]
    return values[lower] + (position - lower) * (values[lower + 1] - values[lower])


@inline_kernel
def feedback(tables: MapTables, i: int, gauge_pa: float) -> tuple[float, float]:
    """Closure and apex fold angle [rad] of panel ``i`` at a gauge pressure, by the map."""
    closures = tables.closures
    values = tables.pressure_pa[tables.row[i]]
    last = values.shape[0] - 1
    clipped = min(max(gauge_pa, values[0]), values[last])
    lower = min(max(np.searchsorted(values, clipped) - 1, 0), last - 1)
    fraction = (clipped - values[lower]) / (values[lower + 1] - values[lower])
    closure = closures[lower] + fraction * (closures[1] - closures[0])
    position = closure * last
    at = min(int(position), last - 1)
    folds = tables.fold_angle_rad[tables.row[i]]
    return closure, folds[at] + (position - at) * (folds[at + 1] - folds[at])


@kernel
def feedback_all(state: FloatArray, tables: tuple[npt.NDArray[Any], ...], closure: FloatArray,
                 fold_angle_rad: FloatArray) -> None:
    """Closure and apex fold angle (N,) of every panel at its filtered pressure."""
    tables = MapTables(*tables)
    for i in range(closure.shape[0]):
        closure[i], fold_angle_rad[i] = feedback(tables, i, max(state[FILTERED, i], 0.0))


@inline_kernel
def control_panel(i: int, dt_s: float, setpoint: float, measured_pa: float, supply_pa: float,
                  state: FloatArray, codes: IntArray, parameters: LoopParameters,
                  circuit: LoopCircuit, tables: MapTables) -> tuple[float, float]:
    """One period of panel ``i``'s loop: update its state, return its fill and vent openings.

    ``parameters``, ``circuit`` and ``tables`` are named (:func:`named_loop`).
    """
    wanted = min(pressure_for_closure(tables, i, setpoint), state[TARGET_LIMIT, i])
    # the supply reading, smoothed; NaN while it gives none
    supply_gauge = supply_pa - _ATM
    finite_supply = math.isfinite(supply_gauge)
    smoothed = state[SUPPLY, i]
    if finite_supply and not math.isfinite(smoothed):
        smoothed = supply_gauge
    blend = dt_s / (parameters.supply_filter_s + dt_s)
    smoothed = smoothed + blend * (supply_gauge - smoothed) if finite_supply else np.nan
    state[SUPPLY, i] = smoothed
    reachable = smoothed - 2 * parameters.supply_margin_pa
    limited = smoothed > parameters.supply_margin_pa and reachable < wanted
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
        blend = dt_s / (parameters.measurement_filter_s + dt_s)
        state[FILTERED, i] = state[FILTERED, i] + blend * (gauge - state[FILTERED, i])
    pressure = state[FILTERED, i]
    # the rate-limited reference
    previous_reference = state[REFERENCE, i]
    largest = parameters.setpoint_rate_pa_per_s * dt_s
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
def _regulate(i: int, dt_s: float, previous_reference: float, supply_pa: float, state: FloatArray,
              parameters: LoopParameters, circuit: LoopCircuit, tables: MapTables
              ) -> tuple[float, float]:
    """PI in pressure-rate space, linearised by the capacitance and the valves' capacities."""
    pressure, reference = state[FILTERED, i], state[REFERENCE, i]
    error = reference - pressure
    integral_time, time_constant = parameters.integral_time_s, parameters.time_constant_s
    rate = ((reference - previous_reference) / dt_s
            + (error + state[INTEGRAL, i] / integral_time) / time_constant)
    gauge = max(pressure, 0.0)
    row = tables.row[i]
    volume, free_compliance = cushion_off_stops(tables.pressure_pa, tables.volume_m3,
                                                tables.compliance_m3_per_pa, row, gauge)
    compliance = free_compliance * off_stops(tables.pressure_pa[row], gauge)
    absolute = pressure + _ATM
    dead_volume, rt = circuit.dead_volume_m3, circuit.rt_j_per_kg
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
    can_fill = upstream > absolute + parameters.supply_margin_pa
    fill_capacity = mass_flow(max(upstream, absolute + 1.0), absolute,
                              circuit.fill_conductance_m3_s_pa, circuit.critical_ratio,
                              circuit.temperature_scale)
    vent_capacity = mass_flow(max(absolute, _ATM + 1.0), _ATM, circuit.vent_conductance_m3_s_pa,
                              circuit.critical_ratio, circuit.temperature_scale)
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
    resting = reference == target and abs(target - pressure) < parameters.hold_band_pa
    if not (saturated or resting or (vented and error > 0)):
        state[INTEGRAL, i] += error * dt_s
    if resting:
        return 0.0, 0.0
    return min(max(fill_wish, 0.0), 1.0), min(max(vent_wish, 0.0), 1.0)


@inline_kernel
def _detect_faults(i: int, dt_s: float, measured_pa: float, readable: bool, supply_pa: float,
                   state: FloatArray, codes: IntArray, parameters: LoopParameters) -> None:
    state[DROPOUT_TIMER, i] = 0.0 if readable else state[DROPOUT_TIMER, i] + dt_s
    moving_air = state[LAST_FILL, i] > 0.05 or state[LAST_VENT, i] > 0.05
    expect_change = moving_air or parameters.expected_noise_pa > 0
    repeated = readable and measured_pa == state[LAST_READING, i] and expect_change
    state[STUCK_TIMER, i] = state[STUCK_TIMER, i] + dt_s if repeated else 0.0
    leaking = _leak_stalled(i, dt_s, readable, state, parameters)
    inflowing = _uncommanded_inflow(i, dt_s, readable, state, parameters)
    # A supply reading no higher than the atmosphere means no supply at all; a weak one only
    # limits the target.
    no_supply = not (supply_pa - _ATM > parameters.supply_margin_pa)
    state[SUPPLY_TIMER, i] = state[SUPPLY_TIMER, i] + dt_s if no_supply else 0.0
    if codes[FAULT, i] != NO_FAULT:
        return
    if readable and measured_pa - _ATM > parameters.max_gauge_pa - parameters.pressure_margin_pa:
        codes[FAULT, i] = OVERPRESSURE
    elif state[DROPOUT_TIMER, i] >= parameters.dropout_time_s:
        codes[FAULT, i] = SENSOR_DROPOUT
    elif state[STUCK_TIMER, i] >= parameters.stuck_time_s:
        codes[FAULT, i] = SENSOR_STUCK
    elif state[SUPPLY_TIMER, i] >= parameters.supply_time_s:
        codes[FAULT, i] = SUPPLY_LOST
    elif inflowing:
        codes[FAULT, i] = FILL_VALVE_STUCK
    elif leaking:
        codes[FAULT, i] = LEAK


@inline_kernel
def _leak_stalled(i: int, dt_s: float, readable: bool, state: FloatArray,
                  parameters: LoopParameters) -> bool:
    """Return whether the pressure stalled short of the reference with the fill valve open.

    True after a whole leak window with the fill valve wide open and the pressure short of the
    reference, in which it gained less than ``leak_error_pa``.
    """
    timer = state[LEAK_TIMER, i]
    armed = (readable and state[LAST_FILL, i] >= 0.999
             and state[REFERENCE, i] - state[FILTERED, i] > parameters.leak_error_pa)
    if not (armed and timer > 0):
        state[LEAK_START, i] = state[FILTERED, i]
    timer = timer + dt_s if armed else 0.0
    window_done = timer >= parameters.leak_time_s
    stalled = window_done and state[FILTERED, i] - state[LEAK_START, i] < parameters.leak_error_pa
    state[LEAK_TIMER, i] = 0.0 if window_done and not stalled else timer
    return stalled


@inline_kernel
def _uncommanded_inflow(i: int, dt_s: float, readable: bool, state: FloatArray,
                        parameters: LoopParameters) -> bool:
    """Return whether venting failed to lower the pressure as the valve model says."""
    start = state[INFLOW_START, i]
    expected = state[EXPECTED_CHANGE, i] + dt_s * (
        state[LAST_FILL, i] * state[FILL_CAPACITY, i]
        - state[LAST_VENT, i] * state[VENT_CAPACITY, i]) / state[INFLOW_CAPACITANCE, i]
    # No vent takes the cushion below the atmosphere: without this floor a full vent through
    # the open stop predicts a drop far larger than the pressure has, read as air coming in.
    expected = max(expected, -max(start, 0.0))
    timer = state[INFLOW_TIMER, i] + dt_s if readable else 0.0
    window_done = timer >= parameters.leak_time_s
    unexplained = (state[FILTERED, i] - start) - expected
    error = parameters.leak_error_pa
    inflow = window_done and expected < -error and unexplained > max(error, -0.5 * expected)
    if window_done or not readable:
        timer, expected = 0.0, 0.0
        state[INFLOW_START, i] = state[FILTERED, i]
    state[INFLOW_TIMER, i], state[EXPECTED_CHANGE, i] = timer, expected
    return inflow


@inline_kernel
def _apply_safety(i: int, fill: float, vent: float, readable: bool, gauge: float, codes: IntArray,
                  parameters: LoopParameters) -> tuple[float, float]:
    if gauge >= parameters.max_gauge_pa - 2 * parameters.pressure_margin_pa:
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
    limit = parameters.max_gauge_pa - parameters.pressure_margin_pa
    if readable and (gauge > limit or (fault == OVERPRESSURE
                                       and gauge > limit - parameters.pressure_margin_pa)):
        vent = 1.0
    return fill, vent


@kernel
def control_all(dt_s: float, setpoint: FloatArray, measured_pa: FloatArray, supply_pa: FloatArray,
                state: FloatArray, codes: IntArray, parameters: tuple[float, ...],
                circuit: tuple[float, ...], tables: tuple[npt.NDArray[Any], ...],
                fill: FloatArray, vent: FloatArray) -> None:
    """One period of every panel's loop; the openings land in ``fill`` and ``vent`` (N,)."""
    parameters, circuit, tables = named_loop(parameters, circuit, tables)
    for i in range(setpoint.shape[0]):
        fill[i], vent[i] = control_panel(i, dt_s, setpoint[i], measured_pa[i], supply_pa[i],
                                         state, codes, parameters, circuit, tables)
