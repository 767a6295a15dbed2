"""Compiled, error-controlled integration of N cushion circuits: the plant's engine.

Within one call the valve openings are constant and each panel's cushion is a scalar ODE
(:mod:`.plant`): ``dp/dt = R T mdot_net(p) / (V(p) + V_dead + p dV/dp)``. This module
integrates it panel by panel with the embedded Dormand-Prince 5(4) pair [1] and the standard
step-size controller [2]: each panel takes steps as long as its local error allows, a few per
control period while a valve moves air and one per period while the valves are shut, instead of
the reference's fixed 1 ms (:class:`~.plant.PneumaticPlant` with ``integrator='fixed'``). Each
panel keeps its step length from one call to the next.

Error bound: the local error estimate of every accepted step (the difference of the fifth- and
fourth-order solutions, in Pa) is at most ``tolerance_pa``; the step is then advanced with the
fifth-order solution. The right-hand side has kinks (the choke boundary, the relief valve's
cracking pressure, the cushion table's nodes and its stops), where a step's order drops: the
controller sees the larger error and shortens the step, so the bound holds there too. The
accuracy against the reference plant over whole manoeuvres is asserted in the tests
(``test/model/actuation/test_integration.py``) and stated in ``msg_docs/actuation.md``.

As in the reference: the pressure is held at or above atmospheric after every step (stages below
it are evaluated at atmospheric); the sensor's first-order lag is advanced exactly for a
pressure going linearly over each step; the air counters (fill inflow, vent outflow, as free air)
are integrated with the same weights as the pressure.

The kernels are compiled with numba [3] on first use and cached on disk next to this module.
Their tuples have named fields (:class:`CushionTables`, :class:`EngineCircuit`), passed from
Python as plain tuples and named on entry, as in :mod:`flectofold_model.control.loop_kernel`.

References: [1] J. R. Dormand, P. J. Prince, "A family of embedded Runge-Kutta formulae",
J. Comput. Appl. Math. 6 (1980) 19-26; [2] E. Hairer, S. P. Norsett, G. Wanner, *Solving
Ordinary Differential Equations I*, 2nd ed., Springer 1993, section II.4 (automatic step size
control); [3] numba, https://numba.pydata.org.

Pressures in Pa (absolute unless the name says gauge), volumes in m^3, conductances in
m^3/(s*Pa), times in s.
"""

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from flectofold_model._compiled import inline_kernel, kernel
from flectofold_model._validate import FloatArray
from flectofold_model.actuation.circuit import PlantParameters
from flectofold_model.actuation.cushion_map import CushionMap
from flectofold_model.actuation.flow import (AIR_GAS_CONSTANT, ANR_DENSITY_KG_M3,
                                             ANR_TEMPERATURE_K, ATMOSPHERIC_PRESSURE_PA)

#: Default bound on the local error estimate of one step [Pa].
TOLERANCE_PA = 0.01
#: Shortest step the controller takes [s]; a step this short is accepted whatever its error.
SHORTEST_STEP_S = 1e-7
#: Step-size controller: safety factor and the largest shrink and growth per step [2].
_SAFETY, _SHRINK, _GROW = 0.9, 0.2, 5.0
#: Error ratios at or below this grow the step by the most, ``_GROW``: no power to compute.
_GROW_FULLY = (_SAFETY / _GROW) ** 5

# Dormand-Prince 5(4) tableau [1]: nodes, stage weights, fifth-order weights (the last stage is
# the fifth-order solution, "first same as last") and the error weights (fifth minus fourth).
_C2, _C3, _C4, _C5 = 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0
_A21 = 1.0 / 5.0
_A31, _A32 = 3.0 / 40.0, 9.0 / 40.0
_A41, _A42, _A43 = 44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0
_A51, _A52, _A53, _A54 = 19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0
_A61, _A62, _A63, _A64, _A65 = (9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0,
                                -5103.0 / 18656.0)
_B1, _B3, _B4, _B5, _B6 = (35.0 / 384.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0,
                           11.0 / 84.0)
_E1, _E3, _E4, _E5, _E6, _E7 = (71.0 / 57600.0, -71.0 / 16695.0, 71.0 / 1920.0,
                                -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0)

_ATM = ATMOSPHERIC_PRESSURE_PA


class CushionTables(NamedTuple):
    """The cushion tables of the distinct panels (R, S).

    Each row holds one distinct panel's cushion at the map's closure samples; a panel's row in
    them is given beside (``row``, (N,)).
    """

    pressure_pa: FloatArray
    """Gauge pressure [Pa], rising along each row."""
    volume_m3: FloatArray
    """Cushion volume [m^3]."""
    compliance_m3_per_pa: FloatArray
    """Cushion compliance dV/dp [m^3/Pa], off the stops."""


class EngineCircuit(NamedTuple):
    """The circuit's constants, shared by all panels."""

    critical_ratio: float
    """Critical pressure ratio of the valves' ISO 6358 model [-]."""
    temperature_scale: float
    """ANR density times sqrt(ANR temperature / air temperature) [kg/m^3]: a conductance
    [m^3/(s*Pa)] times this and an upstream pressure [Pa] is a mass flow [kg/s]."""
    rt_j_per_kg: float
    """Gas constant of air times its temperature [J/kg]."""
    dead_volume_m3: float
    """Volume of the lines and fittings beside the cushion [m^3]."""
    relief_cracking_pa: float
    """Gauge pressure at which the relief valve starts to open [Pa]."""
    relief_span_pa: float
    """Pressure rise over which the relief valve goes from cracking to fully open [Pa]."""
    relief_conductance_m3_s_pa: float
    """Conductance of the fully open relief valve [m^3/(s*Pa)]."""


#: The rows of the cushion tables, int64 (N,), as the kernels take them.
RowArray = npt.NDArray[np.int64]
#: What :meth:`EmbeddedIntegrator.kernel_constants` returns: the :class:`CushionTables` and
#: :class:`EngineCircuit` fields as plain tuples, the rows, the sensor lag [s] and the tolerance
#: [Pa].
EngineConstants = tuple[tuple[FloatArray, ...], RowArray, tuple[float, ...], float, float]


@inline_kernel
def named_engine(tables: tuple[FloatArray, ...],
                 circuit: tuple[float, ...]) -> tuple[CushionTables, EngineCircuit]:
    """Return :class:`CushionTables` and :class:`EngineCircuit` of plain (or named) tuples."""
    return CushionTables(*tables), EngineCircuit(*circuit)


class _Panel(NamedTuple):
    """What :func:`_rates` needs of one panel over one call: constant while it runs."""

    fill_conductance: float
    """Fill valve conductance at its opening [m^3/(s*Pa)]."""
    vent_conductance: float
    """Vent valve conductance at its opening [m^3/(s*Pa)]."""
    leak_conductance: float
    """Conductance of a leak to the atmosphere [m^3/(s*Pa)]."""
    supply_pa: float
    """Supply pressure [Pa]."""
    tables: CushionTables
    row: int
    """The panel's row in ``tables``."""
    circuit: EngineCircuit


@inline_kernel
def mass_flow(from_pa: float, to_pa: float, conductance: float, critical_ratio: float,
              temperature_scale: float) -> float:
    """Signed ISO 6358 mass flow [kg/s]; :func:`.flow.mass_flow` for scalars."""
    high, low = (from_pa, to_pa) if from_pa >= to_pa else (to_pa, from_pa)
    subsonic = min(max((low / high - critical_ratio) / (1.0 - critical_ratio), 0.0), 1.0)
    flow = conductance * high * math.sqrt(1.0 - subsonic * subsonic) * temperature_scale
    if from_pa > to_pa:
        return flow
    if from_pa < to_pa:
        return -flow
    return 0.0


@inline_kernel
def _cushion(pressure_table: FloatArray, volume_table: FloatArray, compliance_table: FloatArray,
             row: int, gauge_pa: float) -> tuple[float, float]:
    """Volume and compliance of one panel's cushion: :meth:`.CushionMap.__call__` for a scalar."""
    volume, compliance = cushion_off_stops(pressure_table, volume_table, compliance_table, row,
                                           gauge_pa)
    return volume, compliance * off_stops(pressure_table[row], gauge_pa)


@inline_kernel
def cushion_off_stops(pressure_table: FloatArray, volume_table: FloatArray,
                      compliance_table: FloatArray, row: int,
                      gauge_pa: float) -> tuple[float, float]:
    """Volume and compliance of one panel's cushion as the table has them, no stop ramped in."""
    table = pressure_table[row]
    last = table.shape[0] - 1
    clipped = min(max(gauge_pa, table[0]), table[last])
    lower = min(max(np.searchsorted(table, clipped) - 1, 0), last - 1)
    fraction = (clipped - table[lower]) / (table[lower + 1] - table[lower])
    volumes, compliances = volume_table[row], compliance_table[row]
    volume = volumes[lower] + fraction * (volumes[lower + 1] - volumes[lower])
    compliance = compliances[lower] + fraction * (compliances[lower + 1] - compliances[lower])
    return volume, compliance


@inline_kernel
def off_stops(table: FloatArray, gauge_pa: float) -> float:
    """Share of the table's compliance a cushion has at ``gauge_pa``: 0 on a stop, 1 off it.

    Within the first and the last interval of the pressure ``table`` it ramps to zero at the
    stop (:class:`.CushionMap`).
    """
    last = table.shape[0] - 1
    off_open_stop = min(max(gauge_pa / table[1], 0.0), 1.0)
    off_closed_stop = min(max((table[last] - gauge_pa) / (table[last] - table[last - 1]), 0.0),
                          1.0)
    return off_open_stop * off_closed_stop


@inline_kernel
def _rates(pressure_pa: float, panel: _Panel) -> tuple[float, float, float]:
    """``dp/dt`` [Pa/s], fill inflow and vent outflow [m^3/s free air] of one panel.

    ``panel`` is a :class:`_Panel`.
    """
    circuit, tables = panel.circuit, panel.tables
    critical_ratio, temperature_scale = circuit.critical_ratio, circuit.temperature_scale
    p = max(pressure_pa, _ATM)
    fill = 0.0 if panel.fill_conductance == 0.0 else mass_flow(
        panel.supply_pa, p, panel.fill_conductance, critical_ratio, temperature_scale)
    per_conductance = mass_flow(p, _ATM, 1.0, critical_ratio, temperature_scale)
    relief = (min(max((p - _ATM - circuit.relief_cracking_pa) / circuit.relief_span_pa, 0.0), 1.0)
              * circuit.relief_conductance_m3_s_pa)
    exhaust = panel.vent_conductance + panel.leak_conductance + relief
    volume, compliance = _cushion(tables.pressure_pa, tables.volume_m3,
                                  tables.compliance_m3_per_pa, panel.row, p - _ATM)
    capacitance = volume + circuit.dead_volume_m3 + p * compliance
    rate = circuit.rt_j_per_kg * (fill - per_conductance * exhaust) / capacitance
    return (rate, max(fill, 0.0) / ANR_DENSITY_KG_M3,
            per_conductance * panel.vent_conductance / ANR_DENSITY_KG_M3)


@inline_kernel
def advance_panel(i: int, dt_s: float, pressure: FloatArray, free_air_m3: FloatArray,
                  vented_m3: FloatArray, lagged_pa: FloatArray, step_s: FloatArray,
                  fill: FloatArray, vent: FloatArray, leak: FloatArray, supply: FloatArray,
                  tables: CushionTables, row: RowArray, circuit: EngineCircuit,
                  sensor_lag_s: float, tolerance_pa: float) -> tuple[int, int]:
    """Integrate panel ``i`` over ``dt_s``; return the steps accepted and rejected.

    ``tables`` and ``circuit`` are named (:func:`named_engine`).
    """
    p, free_air, vented, lagged = pressure[i], free_air_m3[i], vented_m3[i], lagged_pa[i]
    h = step_s[i]
    panel = _Panel(fill[i], vent[i], leak[i], supply[i], tables, row[i], circuit)
    k1, f1, v1 = _rates(p, panel)
    t, accepted, rejected = 0.0, 0, 0
    while t < dt_s:
        last = h >= dt_s - t
        h_try = dt_s - t if last else h
        k2, f2, v2 = _rates(p + h_try * _A21 * k1, panel)
        k3, f3, v3 = _rates(p + h_try * (_A31 * k1 + _A32 * k2), panel)
        k4, f4, v4 = _rates(p + h_try * (_A41 * k1 + _A42 * k2 + _A43 * k3), panel)
        k5, f5, v5 = _rates(p + h_try * (_A51 * k1 + _A52 * k2 + _A53 * k3 + _A54 * k4), panel)
        k6, f6, v6 = _rates(p + h_try * (_A61 * k1 + _A62 * k2 + _A63 * k3 + _A64 * k4
                                         + _A65 * k5), panel)
        p_new = p + h_try * (_B1 * k1 + _B3 * k3 + _B4 * k4 + _B5 * k5 + _B6 * k6)
        p_new = max(p_new, _ATM)
        k7, f7, v7 = _rates(p_new, panel)
        error = abs(h_try * (_E1 * k1 + _E3 * k3 + _E4 * k4 + _E5 * k5 + _E6 * k6 + _E7 * k7))
        ratio = error / tolerance_pa
        if ratio > 1.0 and h_try > SHORTEST_STEP_S:
            h = max(SHORTEST_STEP_S, h_try * max(_SHRINK, _SAFETY * ratio ** -0.2))
            rejected += 1
            continue
        free_air += h_try * (_B1 * f1 + _B3 * f3 + _B4 * f4 + _B5 * f5 + _B6 * f6)
        vented += h_try * (_B1 * v1 + _B3 * v3 + _B4 * v4 + _B5 * v5 + _B6 * v6)
        if sensor_lag_s == 0.0:
            lagged = p_new
        else:
            decay = math.exp(-h_try / sensor_lag_s)
            lagged = (p_new + (lagged - p) * decay
                      - (p_new - p) * (sensor_lag_s * (1.0 - decay) / h_try))
        p, k1, f1, v1 = p_new, k7, f7, v7
        t = dt_s if last else t + h_try
        accepted += 1
        grow = _GROW if ratio <= _GROW_FULLY else _SAFETY * ratio ** -0.2
        # a step cut short to land on dt_s says nothing about the step the physics allows
        if not (last and h_try < h):
            h = h_try * grow
    pressure[i], free_air_m3[i], vented_m3[i], lagged_pa[i] = p, free_air, vented, lagged
    step_s[i] = h
    return accepted, rejected


@kernel
def _advance_all(dt_s: float, pressure: FloatArray, free_air_m3: FloatArray,
                 vented_m3: FloatArray, lagged_pa: FloatArray, step_s: FloatArray,
                 fill: FloatArray, vent: FloatArray, leak: FloatArray, supply: FloatArray,
                 tables: tuple[FloatArray, ...], row: RowArray, circuit: tuple[float, ...],
                 sensor_lag_s: float, tolerance_pa: float) -> tuple[int, int]:
    tables, circuit = named_engine(tables, circuit)
    accepted, rejected = 0, 0
    for i in range(pressure.shape[0]):
        a, r = advance_panel(i, dt_s, pressure, free_air_m3, vented_m3, lagged_pa, step_s,
                             fill, vent, leak, supply, tables, row, circuit, sensor_lag_s,
                             tolerance_pa)
        accepted += a
        rejected += r
    return accepted, rejected


class EmbeddedIntegrator:
    """The compiled Dormand-Prince integration of ``count`` circuits, with each panel's step.

    Parameters
    ----------
    parameters : PlantParameters
        The circuit shared by all panels.
    cushion_map : CushionMap
        The tabulated static map; its tables are read once, here.
    count : int
        Number of panels ``N``.
    tolerance_pa : float
        Bound on each step's local error estimate [Pa], ``> 0``.
    """

    def __init__(self, parameters: PlantParameters, cushion_map: CushionMap, count: int,
                 tolerance_pa: float = TOLERANCE_PA) -> None:
        *tables, row = cushion_map.tables()
        pressure, volume, compliance = (np.ascontiguousarray(t, dtype=np.float64) for t in tables)
        self._tables = tuple(CushionTables(pressure_pa=pressure, volume_m3=volume,
                                           compliance_m3_per_pa=compliance))
        self._row = np.ascontiguousarray(row, dtype=np.int64)
        if self._row.shape != (count,):
            raise ValueError(f'the cushion map has {self._row.shape[0]} panels, the plant '
                             f'{count}')
        if np.min(volume) + parameters.dead_volume_m3 <= 0.0:
            raise ValueError('the chamber has no volume: give dead_volume_m3 > 0 or a cushion '
                             'map with a positive volume')
        number = isinstance(tolerance_pa, (int, float)) and not isinstance(tolerance_pa, bool)
        if not (number and math.isfinite(tolerance_pa) and tolerance_pa > 0.0):
            raise ValueError(f'tolerance_pa must be positive and finite, got {tolerance_pa!r}')
        self.tolerance_pa = float(tolerance_pa)
        self._sensor_lag_s = parameters.sensor_lag_s
        self._circuit = tuple(EngineCircuit(
            critical_ratio=parameters.critical_ratio,
            temperature_scale=ANR_DENSITY_KG_M3 * math.sqrt(
                ANR_TEMPERATURE_K / parameters.temperature_k),
            rt_j_per_kg=AIR_GAS_CONSTANT * parameters.temperature_k,
            dead_volume_m3=parameters.dead_volume_m3,
            relief_cracking_pa=parameters.relief_cracking_pa,
            relief_span_pa=parameters.relief_full_open_pa - parameters.relief_cracking_pa,
            relief_conductance_m3_s_pa=parameters.relief_conductance_m3_s_pa))
        self.step_s = np.full(count, parameters.max_step_s)
        """Each panel's next step length [s], kept from call to call."""
        self.rejected_steps = 0
        """Steps whose error was too large, retried shorter, since construction."""

    def kernel_constants(self) -> EngineConstants:
        """Return the tables, rows, circuit, sensor lag [s] and tolerance [Pa] of the kernels.

        The tables are the :class:`CushionTables` fields and the circuit the
        :class:`EngineCircuit` fields, each a plain tuple; the rows (N,) int64.
        """
        return self._tables, self._row, self._circuit, self._sensor_lag_s, self.tolerance_pa

    def advance(self, dt_s: float, state: tuple[FloatArray, FloatArray, FloatArray, FloatArray],
                fill_conductance: npt.ArrayLike, vent_conductance: npt.ArrayLike,
                leak_conductance: npt.ArrayLike, supply_pa: npt.ArrayLike) -> int:
        """Integrate every panel over ``dt_s`` [s] at these conductances (N,) and supplies.

        ``state`` is four float arrays (N,) updated in place: absolute pressure [Pa], free air
        in and vented [m^3], and the lagged pressure the sensor sees [Pa]. Returns the number
        of steps accepted.
        """
        accepted, rejected = _advance_all(
            float(dt_s), *state, self.step_s, _contiguous(fill_conductance),
            _contiguous(vent_conductance), _contiguous(leak_conductance), _contiguous(supply_pa),
            self._tables, self._row, self._circuit, self._sensor_lag_s, self.tolerance_pa)
        self.rejected_steps += rejected
        return accepted


def _contiguous(values: npt.ArrayLike) -> FloatArray:
    return np.ascontiguousarray(values, dtype=np.float64)
