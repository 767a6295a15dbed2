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

The engine's tuples have named fields (:class:`PlantArrays`, :class:`EngineConstants`,
:class:`SensorView`); Python passes them as plain tuples and :func:`run_periods` names them on
entry, as :mod:`.loop_kernel` does its own.
"""

from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from flectofold_model._compiled import inline_kernel, kernel
from flectofold_model._validate import BoolArray, FloatArray, IntArray
from flectofold_model.actuation.integration import advance_panel, named_engine
from flectofold_model.control.loop_kernel import (control_panel, feedback_all, LAST_FILL,
                                                  LAST_VENT, named_loop, REFERENCE, TARGET)


class PlantArrays(NamedTuple):
    """The engine's live arrays (N,), updated in place.

    The first part of :meth:`~flectofold_model.actuation.plant.PneumaticPlant.kernel_view`, in
    its order.
    """

    pressure_pa: np.ndarray
    """Absolute cushion pressure [Pa]."""
    free_air_m3: np.ndarray
    """Free air drawn from the supply [m^3]."""
    vented_m3: np.ndarray
    """Free air vented [m^3]."""
    lagged_pa: np.ndarray
    """Absolute pressure the sensor sees, after its lag [Pa]."""
    step_s: np.ndarray
    """Each panel's next integration step [s]."""
    leak_conductance_m3_s_pa: np.ndarray
    """Conductance of each panel's leak to the atmosphere [m^3/(s*Pa)]."""
    fill_stuck: np.ndarray
    """Fill valve jammed wide open (bool)."""
    supply_pa: np.ndarray
    """Absolute supply pressure [Pa]."""


class EngineConstants(NamedTuple):
    """The engine's constants.

    The second part of :meth:`~flectofold_model.actuation.plant.PneumaticPlant.kernel_view`,
    in its order.
    """

    fill_conductance_m3_s_pa: float
    """Conductance of the fully open fill valve [m^3/(s*Pa)]."""
    vent_conductance_m3_s_pa: float
    """Conductance of the fully open vent valve [m^3/(s*Pa)]."""
    tables: tuple
    """The cushion tables, :class:`~flectofold_model.actuation.integration.CushionTables`."""
    row: np.ndarray
    """Each panel's row in ``tables`` (N,), int64."""
    circuit: tuple
    """The circuit, :class:`~flectofold_model.actuation.integration.EngineCircuit`."""
    sensor_lag_s: float
    """Time constant of the pressure sensor's first-order lag [s]."""
    tolerance_pa: float
    """Bound on each step's local error estimate [Pa]."""


class SensorView(NamedTuple):
    """The sensors' settings and live state.

    The third part of :meth:`~flectofold_model.actuation.plant.PneumaticPlant.kernel_view`
    (:meth:`~flectofold_model.actuation.sensors.CushionSensors.kernel_view`), in its order.
    """

    offset_pa: float
    """Offset of every cushion reading [Pa]."""
    noise_pa: np.ndarray
    """Standard deviation of each cushion reading's noise (N,) [Pa]."""
    stuck: np.ndarray
    """Sensors stuck on their last reading (N,), bool."""
    dropout: np.ndarray
    """Sensors giving no reading (NaN) (N,), bool."""
    last_reading_pa: np.ndarray
    """Each sensor's last reading (N,) [Pa], updated in place."""
    supply_noise_pa: float
    """Standard deviation of the supply readings' noise [Pa]."""


@kernel
def _resting(setpoint: FloatArray, rested_setpoint: FloatArray, state: FloatArray,
             hold_band_pa: float) -> bool:
    """Every panel at rest: setpoint unchanged, valves shut, reference at its target."""
    if hold_band_pa <= 0.0:
        return False
    for i in range(setpoint.shape[0]):
        if setpoint[i] != rested_setpoint[i] or state[LAST_FILL, i] != 0.0 or \
                state[LAST_VENT, i] != 0.0 or state[REFERENCE, i] != state[TARGET, i]:
            return False
    return True


@inline_kernel
def _active(state: FloatArray, i: int) -> bool:
    """Whether the loop moves panel ``i``: a valve open or its reference still ramping."""
    return state[LAST_FILL, i] != 0.0 or state[LAST_VENT, i] != 0.0 or \
        state[REFERENCE, i] != state[TARGET, i]


@kernel
def _read_sensors(run: int, noise: FloatArray, plant: PlantArrays, sensors: SensorView,
                  measured: FloatArray, supply_reading: FloatArray) -> None:
    """Write every panel's cushion and supply readings, as the sensors give them.

    ``plant`` and ``sensors`` are named (:class:`PlantArrays`, :class:`SensorView`).
    """
    lagged, supply_pa = plant.lagged_pa, plant.supply_pa
    stuck, last_reading = sensors.stuck, sensors.last_reading_pa
    for i in range(measured.shape[0]):
        reading = lagged[i] + sensors.offset_pa + noise[run, 0, i] * sensors.noise_pa[i]
        if stuck[i]:
            reading = last_reading[i]
        if sensors.dropout[i]:
            reading = np.nan
        if not stuck[i]:
            last_reading[i] = reading
        measured[i] = reading
        supply_reading[i] = supply_pa[i] + noise[run, 1, i] * sensors.supply_noise_pa


@kernel
def run_periods(periods: int, max_runs: int, period_s: float, quiet_periods: int,
                setpoint: FloatArray, rested_setpoint: FloatArray, noise: FloatArray,
                state: FloatArray, codes: IntArray, parameters: tuple[float, ...],
                circuit: tuple[float, ...], tables: tuple[npt.NDArray[Any], ...],
                plant: tuple[npt.NDArray[Any], ...], engine: tuple[Any, ...],
                sensors: tuple[Any, ...], fill: FloatArray, vent: FloatArray, spans: IntArray,
                measured: FloatArray, closure: FloatArray, fold_angle_rad: FloatArray,
                active: BoolArray) -> tuple[int, int, int, int, int]:
    """Run up to ``periods`` control periods in at most ``max_runs`` runs.

    ``parameters``, ``circuit`` and ``tables`` are the loop's (:mod:`.loop_kernel`);
    ``plant`` is the engine's :class:`PlantArrays`, ``engine`` its :class:`EngineConstants`,
    ``sensors`` the :class:`SensorView`, each a plain tuple (or a named one); ``noise``
    (max_runs, 2, N) the standard normal draws of the cushion and supply sensors. ``fill`` and
    ``vent`` hold the valve openings in force and are updated. Run ``r`` writes its span to
    ``spans[r]`` and the state after it to row ``r + 1`` of ``measured``, ``closure`` and
    ``fold_angle_rad``.
    Returns the runs made, the periods they covered, the quiet spans among them and the plant
    steps accepted and rejected.
    """
    parameters, circuit, tables = named_loop(parameters, circuit, tables)
    plant, engine, sensors = PlantArrays(*plant), EngineConstants(*engine), SensorView(*sensors)
    engine_tables, engine_circuit = named_engine(engine.tables, engine.circuit)
    fill_stuck = plant.fill_stuck
    fill_max, vent_max = engine.fill_conductance_m3_s_pa, engine.vent_conductance_m3_s_pa
    count = setpoint.shape[0]
    fill_conductance = np.empty(count)
    vent_conductance = np.empty(count)
    supply_reading = np.empty(count)
    runs, done, quiet, accepted, rejected = 0, 0, 0, 0, 0
    while done < periods and runs < max_runs:
        resting = quiet_periods > 1 and _resting(setpoint, rested_setpoint, state,
                                                 parameters.hold_band_pa)
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
            a, r = advance_panel(i, span * period_s, plant.pressure_pa, plant.free_air_m3,
                                 plant.vented_m3, plant.lagged_pa, plant.step_s,
                                 fill_conductance, vent_conductance,
                                 plant.leak_conductance_m3_s_pa, plant.supply_pa, engine_tables,
                                 engine.row, engine_circuit, engine.sensor_lag_s,
                                 engine.tolerance_pa)
            accepted += a
            rejected += r
        feedback_all(state, tables, closure[runs + 1], fold_angle_rad[runs + 1])
        for i in range(count):
            active[runs + 1, i] = _active(state, i)
        spans[runs] = span
        done += span
        runs += 1
    return runs, done, quiet, accepted, rejected
