"""The pressure loops of the panels one process hosts, run against a cushion driver.

:class:`PanelLoops` holds each panel's closure setpoint, one vectorised
:class:`~flectofold_model.pressure_control.PressureController` and a
:class:`~flectofold_model.hardware.CushionDriver`; :meth:`PanelLoops.advance_to` runs the loop
up to a clock reading. Against a simulated driver it runs whole control periods and advances
the simulation by each, catching up however far the clock jumped, so a sped-up or stalled ROS
clock changes nothing in the physics; against real hardware it runs one period per call with
the time that actually passed. Feedback for each panel (measured pressure, closure and flap
fold angle from the static maps) is read from here.
"""

from collections import deque
import dataclasses
from dataclasses import dataclass
import math

import numpy as np

from flectofold_model._validate import real_scalar
from flectofold_model.actuation import actuated_like, ActuationModel, CushionMap
from flectofold_model.hardware import CushionDriver, SimulatedCushions
from flectofold_model.pneumatics import DEMONSTRATOR_PLANT, PneumaticPlant
from flectofold_model.pressure_control import ControllerParameters, PressureController


@dataclass(frozen=True)
class LoopAdvance:
    """What one :meth:`PanelLoops.advance_to` did."""

    periods: int
    """Control periods run."""
    skipped_s: float
    """Clock time not simulated because the jump exceeded the catch-up limit [s]."""


@dataclass(frozen=True)
class LoopSample:
    """Every panel's feedback at one instant of the loop's clock."""

    sequence: int
    """Counts up by one per sample, also across restarts."""
    time_s: float
    """Clock reading the state belongs to [s]."""
    closure: np.ndarray
    fold_angle_rad: np.ndarray
    measured_pa: np.ndarray


class PanelLoops:
    """Closure setpoints in, valve openings out, for the ``N`` panels of one actuation model.

    Parameters
    ----------
    model : ActuationModel
        The panels' static actuation (one row per driver channel).
    driver : CushionDriver
        Valves and sensors, ``driver.count == len(model)``.
    control_period_s : float
        Period of the loop [s], in (0, 1].
    parameters : ControllerParameters
        Gains and limits; ``time_constant_s`` must be at least twice the period.
    max_catch_up_s : float
        Longest clock jump a simulated driver is integrated through [s]; the rest is skipped
        (the plant holds) and reported, so that a clock leaping hours ahead cannot stall
        the process.
    quiet_period_s : float, optional
        Simulated drivers only: while every panel rests (reference at target, pressure
        inside ``hold_band_pa`` so the valves are shut, setpoints unchanged) and the clock is
        far enough ahead, the loop runs one period of up to this length [s] instead of many
        short ones; the plant is integrated just as exactly and the fault monitors still
        run once per long period. This is what lets a facade day run hundreds of times
        faster than real time. ``None`` (default) always runs ``control_period_s``.
    """

    def __init__(self, model, driver, control_period_s=0.1, parameters=ControllerParameters(),
                 max_catch_up_s=3600.0, quiet_period_s=None):
        if not isinstance(model, ActuationModel):
            raise TypeError(f'model must be an ActuationModel, got {type(model).__name__}')
        if not isinstance(driver, CushionDriver):
            raise TypeError(f'driver must be a CushionDriver, got {type(driver).__name__}')
        if driver.count != len(model):
            raise ValueError(f'the driver has {driver.count} channels for {len(model)} panels')
        self.period_s = _positive('control_period_s', control_period_s, 1.0)
        if parameters.time_constant_s < 2.0 * self.period_s:
            raise ValueError(
                f'time_constant_s={parameters.time_constant_s:g} s is too short for a '
                f'{self.period_s:g} s control period: give at least twice the period')
        self.max_catch_up_s = _positive('max_catch_up_s', max_catch_up_s, math.inf)
        self.quiet_periods = 1 if quiet_period_s is None else max(1, math.floor(
            _positive('quiet_period_s', quiet_period_s, 60.0) / self.period_s + 1e-9))
        self.quiet_periods_run = 0
        self.model = model
        self.map = CushionMap(model)
        self.driver = driver
        self.controller = PressureController(self.map, driver.circuit, parameters)
        self.setpoint = np.zeros(len(model))
        self.measured_pa = np.full(len(model), np.nan)
        self._rested_setpoint = None
        self.time_s = None
        self._fold_angle_table = _fold_angle_table(model, self.map.closures)
        self.sample_period_s = None
        self.samples = deque(maxlen=4096)
        self._next_sample_s = -math.inf
        self._sequence = 0

    def __len__(self):
        return self.setpoint.shape[0]

    def set_safe_action(self, action, panels=None):
        """VENT (default) or HOLD for panels with a latched circuit fault."""
        self.controller.set_safe_action(action, panels)

    def advance_to(self, now_s):
        """Run the loop up to the clock reading ``now_s`` [s]; repeated readings do nothing.

        The first call only starts the clock. A clock that goes backwards (a replayed bag
        looping) restarts it there.
        """
        now_s = real_scalar('now_s', now_s)
        if self.time_s is None or now_s < self.time_s:
            self.time_s = now_s
            self._next_sample_s = -math.inf
            return LoopAdvance(0, 0.0)
        if not self.driver.simulated:
            dt = now_s - self.time_s
            if dt < 0.5 * self.period_s:
                return LoopAdvance(0, 0.0)
            self._period(min(dt, 5.0 * self.period_s))
            self.time_s = now_s
            self._sample(now_s)
            return LoopAdvance(1, 0.0)
        periods = math.floor((now_s - self.time_s) / self.period_s + 1e-9)
        limit = math.floor(self.max_catch_up_s / self.period_s)
        skipped = max(0, periods - limit) * self.period_s
        remaining, run = min(periods, limit), 0
        clock_s = self.time_s
        while remaining:
            span = min(self.quiet_periods, remaining) if self._resting() else 1
            command = self._period(span * self.period_s)
            if span > 1 and (np.any(command.fill_opening) or np.any(command.vent_opening)):
                span = 1  # woke up: these openings hold for one short period only
            self.quiet_periods_run += span > 1
            self.driver.advance(span * self.period_s)
            remaining -= span
            run += 1
            clock_s += span * self.period_s
            self._sample(clock_s)
        self.time_s += periods * self.period_s
        return LoopAdvance(run, skipped)

    def _sample(self, clock_s):
        """Keep the feedback once per ``sample_period_s`` (when set) of the loop's clock.

        A loop that catches up a long clock jump in one call thereby still leaves its
        states at their own times, for nodes to publish with the right stamps.
        """
        if self.sample_period_s is None or clock_s < self._next_sample_s - 1e-9:
            return
        self._sequence += 1
        self.samples.append(LoopSample(self._sequence, clock_s, self.closure,
                                       self.fold_angle_rad, self.measured_pa.copy()))
        self._next_sample_s = clock_s + self.sample_period_s

    def _resting(self):
        """Every panel at rest in its hold band (valves shut), setpoints unchanged."""
        controller = self.controller
        last = controller.last_command
        return (self.quiet_periods > 1 and controller.parameters.hold_band_pa > 0.0
                and np.array_equal(self.setpoint, self._rested_setpoint)
                and not np.any(last.fill_opening) and not np.any(last.vent_opening)
                and np.array_equal(controller.reference_gauge_pa, controller.target_gauge_pa))

    def _period(self, dt_s):
        self._rested_setpoint = self.setpoint.copy()
        self.measured_pa = self.driver.read_pressure_pa()
        command = self.controller.step(dt_s, self.setpoint, self.measured_pa,
                                       self.driver.read_supply_pa())
        self.driver.write_valves(command.fill_opening, command.vent_opening)
        return command

    @property
    def gauge_pa(self):
        """The loop's filtered cushion pressure (N,) [Pa gauge]."""
        return self.controller.filtered_gauge_pa.copy()

    @property
    def closure(self):
        """Closure (N,) the static map gives for the filtered measured pressure."""
        return self.map.closure(np.maximum(self.controller.filtered_gauge_pa, 0.0))

    @property
    def fold_angle_rad(self):
        """Flap fold angle at the crease apex (N,) [rad], from :attr:`closure`."""
        table = self._fold_angle_table
        position = self.closure * (table.shape[1] - 1)
        lower = np.minimum(position.astype(np.intp), table.shape[1] - 2)
        rows = np.arange(len(self))
        low, high = table[rows, lower], table[rows, lower + 1]
        return low + (position - lower) * (high - low)

    @property
    def fault(self):
        """Latched circuit fault of each panel (N,), :class:`~.pressure_control.Fault` objects."""
        return self.controller.fault.copy()

    def reset_faults(self, panels=None):
        """Clear latched circuit faults; see :meth:`PressureController.reset_faults`."""
        self.controller.reset_faults(panels)

    @property
    def free_air_used_nl(self):
        """Air drawn from the supply per panel [NL], where the driver measures it, else NaN."""
        used = getattr(self.driver, 'free_air_used_m3', None)
        return np.full(len(self), np.nan) if used is None else used * 1e3

    def close(self):
        """Shut the valves: the panels keep their air (a held position) until vented."""
        self.driver.close()


def _positive(name, value, largest):
    value = real_scalar(name, value)
    if not 0.0 < value <= largest:
        raise ValueError(f'{name} must lie in (0, {largest:g}], got {value:g}')
    return value


def _fold_angle_table(model, closures):
    """Apex fold angle (N, S) at the static map's closure samples."""
    return np.stack([model.fold.state_from_closure(c).apex_fold_angle_rad for c in closures],
                    axis=1)


def facade_loops(facade, panel_ids, control_period_s=0.1, parameters=ControllerParameters(),
                 circuit=DEMONSTRATOR_PLANT, seed=0, quiet_period_s=None):
    """Build :class:`PanelLoops` for some panels of a facade on one simulated circuit.

    Each panel is actuated like the demonstrator module (see
    :func:`~flectofold_model.actuation.actuated_like`); ``panel_ids`` must name panels of
    ``facade`` (``ValueError`` lists what is there otherwise).
    """
    indices = panel_indices(facade, panel_ids)
    if quiet_period_s is not None and circuit.max_quiet_step_s < quiet_period_s:
        # valves shut, only the healthy leak moves the pressure: one sub-step is exact enough
        circuit = dataclasses.replace(circuit, max_quiet_step_s=quiet_period_s)
    model = ActuationModel([actuated_like(facade.panels[i]) for i in indices])
    driver = SimulatedCushions(PneumaticPlant(circuit, CushionMap(model), len(indices),
                                              seed=seed, adaptive_step=True))
    return PanelLoops(model, driver, control_period_s, parameters,
                      quiet_period_s=quiet_period_s)


def panel_indices(facade, panel_ids):
    """Positions of ``panel_ids`` in ``facade.panel_ids``; unknown or repeated ids raise."""
    panel_ids = list(panel_ids)
    if not panel_ids:
        raise ValueError('no panel ids given')
    unknown = [p for p in panel_ids if p not in facade.panel_ids]
    if unknown:
        raise ValueError(f'unknown panel id(s) {", ".join(map(str, unknown))} in facade '
                         f'{facade.name!r}, which has {facade.panel_ids[0]} .. '
                         f'{facade.panel_ids[-1]}')
    if len(set(panel_ids)) != len(panel_ids):
        raise ValueError('a panel id is given twice')
    return [facade.panel_ids.index(p) for p in panel_ids]
