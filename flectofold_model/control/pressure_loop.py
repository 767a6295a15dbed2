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
6. **Faults.** :class:`Fault` names each detected fault. A faulted panel latches its fault
   until :meth:`PressureController.reset_faults` and takes its safe action: vent (the panel
   springs open) or, where asked for a storm position, hold (both valves shut).
"""

from dataclasses import dataclass, fields
import enum
import warnings

import numpy as np

from flectofold_model._validate import in_range, real_array, real_fields, real_scalar
from flectofold_model.actuation import (AIR_GAS_CONSTANT, ATMOSPHERIC_PRESSURE_PA, CushionMap,
                                        PlantParameters, UnreachableClosureWarning)
from flectofold_model.actuation.flow import mass_flow


class Fault(enum.Enum):
    """Named fault states of a panel's pressure circuit."""

    NONE = 'none'
    SENSOR_STUCK = 'sensor_stuck'
    SENSOR_DROPOUT = 'sensor_dropout'
    LEAK = 'leak'
    SUPPLY_LOST = 'supply_lost'
    FILL_VALVE_STUCK = 'fill_valve_stuck'
    OVERPRESSURE = 'overpressure'


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

    def __post_init__(self):
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
    """Pressure loops and fault monitors of N panels that share one static map per panel."""

    def __init__(self, cushion_map, plant, parameters=ControllerParameters(),
                 safe_action=SafeAction.VENT):
        if not isinstance(cushion_map, CushionMap):
            raise TypeError(f'cushion_map must be a CushionMap, got {type(cushion_map).__name__}')
        if not isinstance(plant, PlantParameters):
            raise TypeError(f'plant must be PlantParameters, got {type(plant).__name__}')
        if not isinstance(parameters, ControllerParameters):
            raise TypeError('parameters must be ControllerParameters')
        if parameters.max_gauge_pa >= plant.relief_cracking_pa:
            raise ValueError(f'max_gauge_pa={parameters.max_gauge_pa:g} Pa must stay below the '
                             f'relief valve, which cracks at {plant.relief_cracking_pa:g} Pa')
        self.map = cushion_map
        self.plant = plant
        self.parameters = parameters
        count = cushion_map.pressure_pa.shape[0]
        self.fault = np.full(count, Fault.NONE, dtype=object)
        self._safe_action = np.full(count, SafeAction.VENT, dtype=object)
        self.set_safe_action(safe_action)
        self.target_gauge_pa = np.zeros(count)
        self.limited_by_supply = np.zeros(count, dtype=bool)
        self._supply_gauge_pa = np.full(count, np.nan)
        self.reference_gauge_pa = np.zeros(count)
        self.filtered_gauge_pa = np.zeros(count)
        self._integral = np.zeros(count)
        self._last_reading = np.full(count, np.nan)
        self._started = np.zeros(count, dtype=bool)
        self._timers = {name: np.zeros(count) for name in
                        ('stuck', 'dropout', 'leak', 'inflow', 'supply')}
        self._window_start_pa = {'leak': np.zeros(count), 'inflow': np.zeros(count)}
        self._expected_change_pa = np.zeros(count)
        self._fill_capacity = np.zeros(count)
        self._vent_capacity = np.zeros(count)
        self._capacitance = np.ones(count)
        self._last_command = ValveCommand(np.zeros(count), np.zeros(count))
        self.target_pressure_limit_pa = np.minimum(
            cushion_map.pressure_pa[:, -1],
            parameters.max_gauge_pa - 3 * parameters.pressure_margin_pa)
        self._warn_if_unreachable()

    def __len__(self):
        return self.fault.shape[0]

    def _warn_if_unreachable(self):
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

    def set_safe_action(self, action, panels=None):
        """Choose VENT or HOLD for faulted panels (all, or those selected by ``panels``)."""
        if not isinstance(action, SafeAction):
            raise TypeError(f'action must be a SafeAction, got {action!r}')
        self._safe_action[self._selection(panels)] = action

    def reset_faults(self, panels=None):
        """Clear latched faults; the loop restarts from the current measurement."""
        selected = self._selection(panels)
        self.fault[selected] = Fault.NONE
        self._started[selected] = False
        for timer in self._timers.values():
            timer[selected] = 0.0
        self._expected_change_pa[selected] = 0.0
        for start in self._window_start_pa.values():
            start[selected] = self.filtered_gauge_pa[selected]

    def _selection(self, panels):
        mask = np.zeros(len(self), dtype=bool)
        mask[slice(None) if panels is None else panels] = True
        return mask

    @property
    def last_command(self):
        """The :class:`ValveCommand` of the last :meth:`step`."""
        return self._last_command

    def pressure_for_closure(self, closure):
        """Gauge-pressure target [Pa] for closure setpoints (N,) in [0, 1]."""
        closure = in_range('closure', np.broadcast_to(real_array('closure', closure),
                                                      (len(self),)), 0.0, 1.0)
        return np.minimum(self.map.pressure_for_closure(closure), self.target_pressure_limit_pa)

    def step(self, dt_s, closure_setpoint, measured_pa, measured_supply_pa):
        """Advance every loop by ``dt_s`` and return the valve openings to apply now.

        ``closure_setpoint`` (N,) must be in [0, 1]; ``measured_pa`` and
        ``measured_supply_pa`` are absolute sensor readings (N,), which may be NaN when a
        sensor drops out.
        """
        dt_s = real_scalar('dt_s', dt_s)
        if dt_s <= 0.0:
            raise ValueError(f'dt_s must be positive, got {dt_s:g} s')
        measured = np.broadcast_to(np.asarray(measured_pa, dtype=np.float64), (len(self),))
        supply = np.broadcast_to(np.asarray(measured_supply_pa, dtype=np.float64), (len(self),))
        wanted = self.pressure_for_closure(closure_setpoint)
        # A weak supply lowers what can be reached: aim there rather than fill against it. No
        # supply at all is a fault (see _detect_faults), not a reason to move. The supply is
        # smoothed first: its noise would otherwise shake the target and the feed-forward.
        supply_gauge = self._smooth_supply(dt_s, supply - ATMOSPHERIC_PRESSURE_PA)
        present = supply_gauge > self.parameters.supply_margin_pa
        reachable = supply_gauge - 2 * self.parameters.supply_margin_pa
        self.limited_by_supply = present & (reachable < wanted)
        self.target_gauge_pa = np.where(self.limited_by_supply, np.maximum(reachable, 0.0),
                                        wanted)
        readable = np.isfinite(measured)
        gauge = np.where(readable, measured - ATMOSPHERIC_PRESSURE_PA, self.filtered_gauge_pa)
        self._filter(dt_s, gauge, readable)
        previous_reference = self.reference_gauge_pa.copy()
        self._move_reference(dt_s)
        fill, vent = self._regulate(dt_s, previous_reference, supply)
        self._detect_faults(dt_s, measured, readable, supply)
        fill, vent = self._apply_safety(fill, vent, readable)
        self._last_reading = np.where(readable, measured, np.nan)
        self._last_command = ValveCommand(fill, vent)
        return self._last_command

    def _smooth_supply(self, dt_s, supply_gauge):
        finite = np.isfinite(supply_gauge)
        fresh = finite & ~np.isfinite(self._supply_gauge_pa)
        self._supply_gauge_pa = np.where(fresh, supply_gauge, self._supply_gauge_pa)
        blend = dt_s / (self.parameters.supply_filter_s + dt_s)
        self._supply_gauge_pa = np.where(
            finite, self._supply_gauge_pa + blend * (supply_gauge - self._supply_gauge_pa),
            np.nan)
        return self._supply_gauge_pa

    def _filter(self, dt_s, gauge, readable):
        fresh = readable & ~self._started
        self.filtered_gauge_pa = np.where(fresh, gauge, self.filtered_gauge_pa)
        self.reference_gauge_pa = np.where(fresh, gauge, self.reference_gauge_pa)
        self._integral = np.where(fresh, 0.0, self._integral)
        self._started |= readable
        blend = dt_s / (self.parameters.measurement_filter_s + dt_s)
        self.filtered_gauge_pa = np.where(
            readable, self.filtered_gauge_pa + blend * (gauge - self.filtered_gauge_pa),
            self.filtered_gauge_pa)

    def _move_reference(self, dt_s):
        largest = self.parameters.setpoint_rate_pa_per_s * dt_s
        self.reference_gauge_pa += np.clip(self.target_gauge_pa - self.reference_gauge_pa,
                                           -largest, largest)

    def _regulate(self, dt_s, previous_reference, supply):
        parameters = self.parameters
        pressure = self.filtered_gauge_pa
        error = self.reference_gauge_pa - pressure
        rate = ((self.reference_gauge_pa - previous_reference) / dt_s
                + (error + self._integral / parameters.integral_time_s)
                / parameters.time_constant_s)
        volume, compliance = self.map(np.clip(pressure, 0.0, None))
        absolute = pressure + ATMOSPHERIC_PRESSURE_PA
        capacitance = (volume + self.plant.dead_volume_m3 + absolute * compliance) / (
            AIR_GAS_CONSTANT * self.plant.temperature_k)
        demand = capacitance * rate
        upstream = np.where(np.isfinite(supply), supply, 0.0)
        # Opening the fill valve against a supply no higher than the cushion would drain it.
        can_fill = upstream > absolute + self.parameters.supply_margin_pa
        # the unchecked ISO 6358 flow: every argument here is built finite and positive
        fill_capacity = mass_flow(np.maximum(upstream, absolute + 1.0), absolute,
                                  self.plant.fill_conductance_m3_s_pa, self.plant.critical_ratio,
                                  self.plant.temperature_k)
        vent_capacity = mass_flow(np.maximum(absolute, ATMOSPHERIC_PRESSURE_PA + 1.0),
                                  ATMOSPHERIC_PRESSURE_PA, self.plant.vent_conductance_m3_s_pa,
                                  self.plant.critical_ratio, self.plant.temperature_k)
        self._fill_capacity = np.where(can_fill, fill_capacity, 0.0)
        self._vent_capacity, self._capacitance = vent_capacity, capacitance
        fill_wish = np.where((demand > 0) & can_fill, demand / fill_capacity, 0.0)
        vent_wish = np.where(demand < 0, -demand / vent_capacity, 0.0)
        fill, vent = np.clip(fill_wish, 0.0, 1.0), np.clip(vent_wish, 0.0, 1.0)
        saturated = ((fill_wish > 1.0) & (error > 0)) | ((vent_wish > 1.0) & (error < 0))
        resting = (self.reference_gauge_pa == self.target_gauge_pa) & \
            (np.abs(self.target_gauge_pa - pressure) < parameters.hold_band_pa)
        self._integral = np.where(saturated | resting, self._integral,
                                  self._integral + error * dt_s)
        return np.where(resting, 0.0, fill), np.where(resting, 0.0, vent)

    def _detect_faults(self, dt_s, measured, readable, supply):
        parameters, timers = self.parameters, self._timers
        healthy = self.fault == Fault.NONE
        timers['dropout'] = np.where(readable, 0.0, timers['dropout'] + dt_s)
        moving_air = (self._last_command.fill_opening > 0.05) | \
            (self._last_command.vent_opening > 0.05)
        expect_change = moving_air | (parameters.expected_noise_pa > 0)
        repeated = readable & (measured == self._last_reading) & expect_change
        timers['stuck'] = np.where(repeated, timers['stuck'] + dt_s, 0.0)
        leaking = self._leak_stalled(dt_s, readable)
        inflowing = self._uncommanded_inflow(dt_s, readable)
        # A supply reading no higher than the atmosphere means no supply at all; a weak one
        # only limits the target (see step).
        no_supply = ~(supply - ATMOSPHERIC_PRESSURE_PA > parameters.supply_margin_pa)
        timers['supply'] = np.where(no_supply, timers['supply'] + dt_s, 0.0)
        over = readable & (measured - ATMOSPHERIC_PRESSURE_PA
                           > parameters.max_gauge_pa - parameters.pressure_margin_pa)
        checks = ((over, Fault.OVERPRESSURE),
                  (timers['dropout'] >= parameters.dropout_time_s, Fault.SENSOR_DROPOUT),
                  (timers['stuck'] >= parameters.stuck_time_s, Fault.SENSOR_STUCK),
                  (timers['supply'] >= parameters.supply_time_s, Fault.SUPPLY_LOST),
                  (inflowing, Fault.FILL_VALVE_STUCK),
                  (leaking, Fault.LEAK))
        for condition, fault in checks:
            raised = healthy & condition
            self.fault[raised] = fault
            healthy &= ~raised

    def _leak_stalled(self, dt_s, readable):
        """Flag panels whose pressure stalls short of the reference with the fill valve open.

        True after a whole ``leak_time_s`` window with the fill valve wide open and the
        pressure short of the reference, in which it still gained less than ``leak_error_pa``:
        a leak larger than the valve can make up.
        """
        parameters = self.parameters
        timer, start = self._timers['leak'], self._window_start_pa['leak']
        armed = readable & (self._last_command.fill_opening >= 0.999) & \
            (self.reference_gauge_pa - self.filtered_gauge_pa > parameters.leak_error_pa)
        start[:] = np.where(armed & (timer > 0), start, self.filtered_gauge_pa)
        timer[:] = np.where(armed, timer + dt_s, 0.0)
        window_done = timer >= parameters.leak_time_s
        stalled = window_done & (self.filtered_gauge_pa - start < parameters.leak_error_pa)
        timer[window_done & ~stalled] = 0.0
        return stalled

    def _uncommanded_inflow(self, dt_s, readable):
        """Flag panels whose venting does not lower the pressure as the valve model says.

        Over each ``leak_time_s`` window the commanded openings predict a pressure change
        from the same ISO 6358 valve model and capacitance the loop linearises with. Air
        that the vent should have let out but that stayed means air comes in uncommanded: a
        fill valve jammed open. Raised when the vent was meant to drop the pressure by more
        than ``leak_error_pa`` and the pressure stayed more than half of that, and at least
        ``leak_error_pa``, above the prediction.
        """
        parameters = self.parameters
        timer, start = self._timers['inflow'], self._window_start_pa['inflow']
        command = self._last_command
        self._expected_change_pa += dt_s * (command.fill_opening * self._fill_capacity
                                            - command.vent_opening * self._vent_capacity
                                            ) / self._capacitance
        # No vent takes the cushion below the atmosphere: without this floor, a full vent
        # through the open stop (where the capacitance shrinks to the dead volume) predicts
        # a drop far larger than the pressure has, and reads as air coming in.
        np.maximum(self._expected_change_pa, -np.maximum(start, 0.0),
                   out=self._expected_change_pa)
        timer[:] = np.where(readable, timer + dt_s, 0.0)
        window_done = timer >= parameters.leak_time_s
        expected = self._expected_change_pa
        unexplained = (self.filtered_gauge_pa - start) - expected
        inflow = window_done & (expected < -parameters.leak_error_pa) & \
            (unexplained > np.maximum(parameters.leak_error_pa, -0.5 * expected))
        restart = window_done | ~readable
        timer[restart] = 0.0
        start[restart] = self.filtered_gauge_pa[restart]
        self._expected_change_pa[restart] = 0.0
        return inflow

    def _apply_safety(self, fill, vent, readable):
        parameters = self.parameters
        gauge = self.filtered_gauge_pa
        fill = np.where(gauge >= parameters.max_gauge_pa - 2 * parameters.pressure_margin_pa,
                        0.0, fill)
        blind = ~readable  # no trustworthy reading yet: do nothing rather than guess
        fill = np.where(blind, 0.0, fill)
        vent = np.where(blind, 0.0, vent)
        faulted = self.fault != Fault.NONE
        # Air coming in uncommanded would over-pressure a held panel: that one always vents.
        forced_vent = self.fault == Fault.FILL_VALVE_STUCK
        venting = faulted & ((self._safe_action == SafeAction.VENT) | forced_vent)
        holding = faulted & ~venting
        fill = np.where(faulted, 0.0, fill)
        vent = np.where(venting, 1.0, np.where(holding, 0.0, vent))
        # Near the maximum, or after an over-pressure until back below the fill cut-off,
        # vent whatever the safe action: a held storm position must not stay over-pressured.
        limit = parameters.max_gauge_pa - parameters.pressure_margin_pa
        relieving = readable & ((gauge > limit)
                                | ((self.fault == Fault.OVERPRESSURE)
                                   & (gauge > limit - parameters.pressure_margin_pa)))
        return fill, np.where(relieving, 1.0, vent)
