"""The pressure loop of a Flectofold cushion: closure setpoint -> valve openings, with faults.

Structure (vectorised over panels, one call per control tick):

1. **Static feed-forward.** The closure setpoint becomes a gauge-pressure target through the
   static actuation map (:class:`~flectofold_model.actuation.CushionMap`), clipped below the
   hard maximum pressure.
2. **Setpoint rate limit.** The reference moves toward the target at most
   ``setpoint_rate_pa_per_s``, so the panel moves no faster than the hardware should.
3. **PI in pressure-rate space with feedback linearisation.** The cushion obeys
   ``dp/dt = mdot / C(p)`` with the capacitance ``C = (V + p dV/dp) / (R T)`` known from the
   static map, and an ISO 6358 valve passes ``u * mdot_max(p)`` at opening ``u``. Asking for
   ``dp/dt = v`` with ``v = dref/dt + (e + integral(e) / T_i) / tau`` and opening the valve by
   ``u = C v / mdot_max`` cancels the plant's strong nonlinearity (the capacitance varies
   tenfold over the stroke and the flow chokes), so one pair of gains gives the same first-order
   response ``tau`` everywhere. The ``dref/dt`` term is the model-based feed-forward. Fill and
   vent valves split the sign of ``u``.
4. **Anti-windup.** The integral only runs while the valve it would drive is not saturated (or
   while the error would bring it out of saturation).
5. **Hard maximum.** The fill valve stays shut within ``2 pressure_margin_pa`` of
   ``max_gauge_pa``; past ``max_gauge_pa - pressure_margin_pa`` the panel raises
   ``OVERPRESSURE`` and vents whatever else is going on, so that with a vent valve that
   out-flows the fill valve even a fill valve jammed open cannot take the cushion past the
   maximum.
6. **The open reference never fills.** At a reference of at most
   :data:`~.loop_kernel.OPEN_REFERENCE_PA` (closure 0: vented, flat) the fill valve stays shut
   and the integral does not wind up on readings below the atmosphere: a vented cushion cannot
   be below it, so such a reading is sensor noise or offset, and filling on it would leave the
   panel part-closed (the storm position included).
7. **Faults.** :class:`Fault` names each detected fault. A faulted panel latches its fault
   until :meth:`PressureController.reset_faults` and takes its safe action: vent (the panel
   springs open) or, where asked for a storm position, hold (both valves shut).
"""

from dataclasses import dataclass, fields
import enum
import math
from typing import Optional, Sequence, Union
import warnings

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import (BoolArray, FloatArray, in_range, IntArray, real_array,
                                        real_fields, real_scalar)
from flectofold_model.actuation import (AIR_GAS_CONSTANT, ATMOSPHERIC_PRESSURE_PA, CushionMap,
                                        PlantParameters, UnreachableClosureWarning)
from flectofold_model.actuation.flow import ANR_DENSITY_KG_M3, ANR_TEMPERATURE_K


#: Which panels a call is for: a boolean mask (N,), panel indices or a slice.
PanelSelection = Union[BoolArray, IntArray, Sequence[int], int, slice]


class Fault(enum.Enum):
    """Named fault states of a panel's pressure circuit."""

    NONE = 'none'
    SENSOR_STUCK = 'sensor_stuck'
    SENSOR_DROPOUT = 'sensor_dropout'
    LEAK = 'leak'
    SUPPLY_LOST = 'supply_lost'
    FILL_VALVE_STUCK = 'fill_valve_stuck'
    OVERPRESSURE = 'overpressure'
    COMMS_LOST = 'comms_lost'
    """The driver lost its link to the valves (a fieldbus terminal that stopped answering):
    raised by :class:`~.panel_loops.PanelLoops` from :attr:`~.hardware.CushionDriver.comms_lost`,
    not by the loop's monitors."""


class SafeAction(enum.Enum):
    """What a faulted panel does with its valves."""

    VENT = 'vent'
    HOLD = 'hold'


@dataclass(frozen=True)
class ControllerParameters:
    """Gains, limits and fault thresholds; defaults suit the demonstrator module."""

    max_gauge_pa: float = 12e3
    """Hard maximum cushion pressure [Pa gauge], never to be exceeded."""
    pressure_margin_pa: float = 500.0
    """Over-pressure is declared (and the panel vented) this far below the maximum, and the
    fill valve shut twice as far below it [Pa]."""
    setpoint_rate_pa_per_s: float = 2e3
    """Largest rate of change of the pressure reference [Pa/s]."""
    time_constant_s: float = 0.4
    """Closed-loop time constant of the linearised loop [s]."""
    integral_time_s: float = 1.6
    """Integral time of the PI [s]; four time constants keeps the step free of overshoot."""
    measurement_filter_s: float = 0.05
    """Time constant of the first-order filter on the measured pressure [s]."""
    supply_filter_s: float = 1.0
    """Time constant of the filter on the supply reading that caps the target [s]."""
    stuck_time_s: float = 0.5
    """Bit-identical readings for this long, while the sensor should be noisy or the valves
    are moving air, mean a stuck sensor [s]."""
    expected_noise_pa: float = 1.0
    """Noise the healthy sensor is known to have [Pa]; 0 if it can read perfectly steady."""
    dropout_time_s: float = 0.05
    """Non-finite readings for this long mean a sensor dropout [s]."""
    leak_time_s: float = 5.0
    """Window of the leak test [s]: the fill valve wide open and the pressure short of the
    reference for this long, while gaining less than ``leak_error_pa``, means a leak the
    valve cannot make up."""
    leak_error_pa: float = 300.0
    """Shortfall that arms the leak test, and the least gain over its window [Pa]."""
    supply_margin_pa: float = 500.0
    """A supply reading less than this above the atmosphere means no supply; the fill valve
    only opens to a supply this much above the cushion [Pa]."""
    supply_time_s: float = 0.2
    """How long the supply must look lost before the fault is raised [s]."""
    hold_band_pa: float = 0.0
    """Valves stay shut while the reference has reached its target and the filtered pressure
    is within this of it [Pa]: a panel at rest does not chatter its valves on sensor noise.
    Three noise standard deviations suit; 0 regulates continuously."""

    def __post_init__(self) -> None:
        real_fields(self)
        for field in fields(self):
            if getattr(self, field.name) < 0.0:
                raise ValueError(f'{field.name} must not be negative, got '
                                 f'{getattr(self, field.name):g}')
        for name in ('max_gauge_pa', 'setpoint_rate_pa_per_s', 'time_constant_s',
                     'integral_time_s', 'stuck_time_s', 'dropout_time_s', 'leak_time_s',
                     'supply_time_s'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g}')
        if 2 * self.pressure_margin_pa >= self.max_gauge_pa:
            raise ValueError(f'pressure_margin_pa={self.pressure_margin_pa:g} Pa leaves no '
                             f'working range below max_gauge_pa={self.max_gauge_pa:g} Pa')


@dataclass(frozen=True)
class ValveCommand:
    """Openings in [0, 1] of each panel's fill and vent valves."""

    fill_opening: np.ndarray
    vent_opening: np.ndarray


class PressureController:
    """Pressure loops and fault monitors of N panels that share one static map per panel.

    The loops run in the compiled kernel of :mod:`.loop_kernel`; this class holds their state
    (one float row per quantity, integer codes for the fault and the safe action), validates
    what comes in and names what goes out.
    """

    def __init__(self, cushion_map: CushionMap, plant: PlantParameters,
                 parameters: ControllerParameters = ControllerParameters(),
                 safe_action: SafeAction = SafeAction.VENT) -> None:
        if not isinstance(cushion_map, CushionMap):
            raise TypeError(f'cushion_map must be a CushionMap, got {type(cushion_map).__name__}')
        if not isinstance(plant, PlantParameters):
            raise TypeError(f'plant must be PlantParameters, got {type(plant).__name__}')
        if not isinstance(parameters, ControllerParameters):
            raise TypeError('parameters must be ControllerParameters')
        if parameters.max_gauge_pa >= plant.relief_cracking_pa:
            raise ValueError(f'max_gauge_pa={parameters.max_gauge_pa:g} Pa must stay below the '
                             f'relief valve, which cracks at {plant.relief_cracking_pa:g} Pa')
        from flectofold_model.control import loop_kernel  # numba: a second to import
        self._kernel = loop_kernel
        self.map = cushion_map
        self.plant = plant
        self.parameters = parameters
        count = cushion_map.pressure_pa.shape[0]
        self.state = np.zeros((loop_kernel.STATE_ROWS, count))
        """Every panel's loop state, one row per quantity (:mod:`.loop_kernel` names them)."""
        self.codes = np.zeros((2, count), dtype=np.int64)
        """Every panel's latched fault and safe action, as :mod:`.loop_kernel` codes."""
        self.state[[loop_kernel.SUPPLY, loop_kernel.LAST_READING]] = np.nan
        self.state[loop_kernel.INFLOW_CAPACITANCE] = 1.0
        self.state[loop_kernel.TARGET_LIMIT] = np.minimum(
            cushion_map.pressure_pa[:, -1],
            parameters.max_gauge_pa - 3 * parameters.pressure_margin_pa)
        self.set_safe_action(safe_action)
        self.kernel_parameters = loop_kernel.parameter_tuple(parameters)
        """The parameters as the compiled loop takes them: ``LoopParameters``' fields."""
        self.kernel_circuit = tuple(loop_kernel.LoopCircuit(
            fill_conductance_m3_s_pa=plant.fill_conductance_m3_s_pa,
            vent_conductance_m3_s_pa=plant.vent_conductance_m3_s_pa,
            critical_ratio=plant.critical_ratio,
            temperature_scale=ANR_DENSITY_KG_M3 * math.sqrt(
                ANR_TEMPERATURE_K / plant.temperature_k),
            dead_volume_m3=plant.dead_volume_m3,
            rt_j_per_kg=AIR_GAS_CONSTANT * plant.temperature_k))
        """The circuit's constants as the compiled loop takes them: ``LoopCircuit``'s fields."""
        self.kernel_tables = cushion_map.compiled_tables()
        """The static map's tables as the compiled loop takes them: ``MapTables``' fields."""
        self._fill = np.zeros(count)
        self._vent = np.zeros(count)
        self._warn_if_unreachable()

    def __len__(self) -> int:
        return self.state.shape[1]

    def _row(self, name: str) -> FloatArray:
        view = self.state[getattr(self._kernel, name)]
        view.flags.writeable = False
        return view

    @property
    def target_gauge_pa(self) -> FloatArray:
        """Pressure target of each loop [Pa gauge] (N,), read-only."""
        return self._row('TARGET')

    @property
    def reference_gauge_pa(self) -> FloatArray:
        """Rate-limited pressure reference [Pa gauge] (N,), read-only."""
        return self._row('REFERENCE')

    @property
    def filtered_gauge_pa(self) -> FloatArray:
        """Filtered measured pressure [Pa gauge] (N,), read-only."""
        return self._row('FILTERED')

    @property
    def target_pressure_limit_pa(self) -> FloatArray:
        """Highest target each loop aims at [Pa gauge] (N,), read-only."""
        return self._row('TARGET_LIMIT')

    @property
    def active(self) -> BoolArray:
        """Whether each loop moves its panel (N,): a valve open, or the reference ramping."""
        k, state = self._kernel, self.state
        return (state[k.LAST_FILL] != 0.0) | (state[k.LAST_VENT] != 0.0) | \
            (state[k.REFERENCE] != state[k.TARGET])

    @property
    def limited_by_supply(self) -> BoolArray:
        """Whether a weak supply holds the target below what the setpoint needs (N,)."""
        return self.state[self._kernel.LIMITED] != 0.0

    @property
    def fault(self) -> npt.NDArray[np.object_]:
        """Latched :class:`Fault` of each panel (N,), an object array."""
        return np.array([_FAULTS[code] for code in self.codes[self._kernel.FAULT]], dtype=object)

    @property
    def fault_codes(self) -> IntArray:
        """Latched fault of each panel (N,) as its index in :class:`Fault`, read-only."""
        view = self.codes[self._kernel.FAULT]
        view.flags.writeable = False
        return view

    def fault_at(self, index: int) -> Fault:
        """Latched :class:`Fault` of panel ``index``."""
        return _FAULTS[self.codes[self._kernel.FAULT, index]]

    def _warn_if_unreachable(self) -> None:
        """Warn, naming the reachable closure, where the supply or the maximum cannot close."""
        supply_limit = (self.plant.supply_pressure_pa - ATMOSPHERIC_PRESSURE_PA
                        - 2 * self.parameters.supply_margin_pa)
        reachable_pa = np.minimum(self.target_pressure_limit_pa, supply_limit)
        short = reachable_pa < self.map.pressure_pa[:, -1]
        if np.any(short):
            index = int(np.flatnonzero(short)[0])
            closure = self.map.closure(np.maximum(reachable_pa, 0.0))[index]
            warnings.warn(
                f'panel {index} needs {self.map.pressure_pa[index, -1] / 1e3:.2f} kPa to close, '
                f'but the supply ({self.plant.supply_pressure_pa / 1e3:.1f} kPa absolute) and '
                f'max_gauge_pa={self.parameters.max_gauge_pa:g} Pa let it reach closure '
                f'{closure:.3f}; setpoints above that are held there', UnreachableClosureWarning,
                stacklevel=3)

    def set_safe_action(self, action: SafeAction,
                        panels: Optional[PanelSelection] = None) -> None:
        """Choose VENT or HOLD for faulted panels (all, or those selected by ``panels``)."""
        if not isinstance(action, SafeAction):
            raise TypeError(f'action must be a SafeAction, got {action!r}')
        code = self._kernel.VENT if action is SafeAction.VENT else self._kernel.HOLD
        self.codes[self._kernel.SAFE_ACTION, self._selection(panels)] = code

    def reset_faults(self, panels: Optional[PanelSelection] = None) -> None:
        """Clear latched faults; the loop restarts from the current measurement."""
        k, selected = self._kernel, self._selection(panels)
        self.codes[k.FAULT, selected] = k.NO_FAULT
        self.state[k.STARTED, selected] = 0.0
        for timer in (k.STUCK_TIMER, k.DROPOUT_TIMER, k.LEAK_TIMER, k.INFLOW_TIMER,
                      k.SUPPLY_TIMER, k.EXPECTED_CHANGE):
            self.state[timer, selected] = 0.0
        for start in (k.LEAK_START, k.INFLOW_START):
            self.state[start, selected] = self.state[k.FILTERED, selected]

    def clear_integral(self, panels: Optional[PanelSelection] = None) -> None:
        """Zero the PI integral of the selected loops (all by default).

        For loops whose output a pressure regulator replaces (:mod:`.regulator`): there the
        integral would wind up on the regulator's lag, unopposed.
        """
        self.state[self._kernel.INTEGRAL, self._selection(panels)] = 0.0

    def latch_fault(self, fault: Fault, panels: Optional[PanelSelection] = None) -> int:
        """Latch ``fault`` on the selected panels that have none yet; return how many took it.

        For faults found outside the loop (:attr:`Fault.COMMS_LOST`); a latched fault is kept,
        so the first cause stays named. The safe action follows from the next :meth:`step`.
        """
        if not isinstance(fault, Fault) or fault is Fault.NONE:
            raise ValueError(f'fault must be a Fault other than NONE, got {fault!r}')
        k = self._kernel
        selected = self._selection(panels) & (self.codes[k.FAULT] == k.NO_FAULT)
        self.codes[k.FAULT, selected] = _FAULTS.index(fault)
        return int(np.count_nonzero(selected))

    def _selection(self, panels: Optional[PanelSelection]) -> BoolArray:
        mask = np.zeros(len(self), dtype=bool)
        mask[slice(None) if panels is None else panels] = True
        return mask

    @property
    def last_command(self) -> ValveCommand:
        """The :class:`ValveCommand` of the last :meth:`step`."""
        k = self._kernel
        return ValveCommand(self.state[k.LAST_FILL].copy(), self.state[k.LAST_VENT].copy())

    def feedback(self, closure: FloatArray, fold_angle_rad: FloatArray) -> None:
        """Write each panel's closure and apex fold angle [rad] at its filtered pressure (N,)."""
        self._kernel.feedback_all(self.state, self.kernel_tables, closure, fold_angle_rad)

    def pressure_for_closure(self, closure: npt.ArrayLike) -> FloatArray:
        """Gauge-pressure target [Pa] for closure setpoints (N,) in [0, 1]."""
        closure = in_range('closure', np.broadcast_to(real_array('closure', closure),
                                                      (len(self),)), 0.0, 1.0)
        return np.minimum(self.map.pressure_for_closure(closure), self.target_pressure_limit_pa)

    def step(self, dt_s: float, closure_setpoint: npt.ArrayLike, measured_pa: npt.ArrayLike,
             measured_supply_pa: npt.ArrayLike) -> ValveCommand:
        """Advance every loop by ``dt_s`` and return the valve openings to apply now.

        ``closure_setpoint`` (N,) must be in [0, 1]; ``measured_pa`` and
        ``measured_supply_pa`` are absolute sensor readings (N,), which may be NaN when a
        sensor drops out.
        """
        dt_s = real_scalar('dt_s', dt_s)
        if dt_s <= 0.0:
            raise ValueError(f'dt_s must be positive, got {dt_s:g} s')
        count = len(self)
        setpoint = in_range('closure', np.broadcast_to(
            real_array('closure', closure_setpoint), (count,)), 0.0, 1.0)
        measured = np.broadcast_to(np.asarray(measured_pa, dtype=np.float64), (count,))
        supply = np.broadcast_to(np.asarray(measured_supply_pa, dtype=np.float64), (count,))
        self._kernel.control_all(
            dt_s, np.ascontiguousarray(setpoint, dtype=np.float64),
            np.ascontiguousarray(measured), np.ascontiguousarray(supply), self.state,
            self.codes, self.kernel_parameters, self.kernel_circuit, self.kernel_tables,
            self._fill, self._vent)
        return ValveCommand(self._fill.copy(), self._vent.copy())


#: Fault of each code of :mod:`.loop_kernel`, in code order.
_FAULTS = tuple(Fault)
