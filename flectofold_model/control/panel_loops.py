"""The pressure loops of the panels one process hosts, run against a cushion driver.

:class:`PanelLoops` holds each panel's closure setpoint, one vectorised
:class:`~.pressure_loop.PressureController` and a :class:`~.hardware.CushionDriver`;
:meth:`PanelLoops.advance_to` runs the loop up to a clock reading. Against a simulated driver
it runs whole control periods and advances the simulation by each, catching up however far
the clock jumped, so a sped-up or stalled ROS clock changes nothing in the physics; against
real hardware it runs one period per call with the time that actually passed.

A panel process calls the loops' own methods, with a panel index where one panel is meant:
it sets the setpoints (:meth:`PanelLoops.set_setpoints`), asks for states at its publish
period (:meth:`PanelLoops.request_sample_period`), takes the states kept since the last one
it took (:meth:`PanelLoops.samples_since`), reads the feedback
(:meth:`PanelLoops.current_feedback`) and resets a panel's fault
(:meth:`PanelLoops.reset_faults`). Taking states costs the number taken, however long the
loop has run.
"""

from collections import deque
from dataclasses import dataclass
from itertools import islice
import math
import time
from typing import Any, cast, Iterable, Optional, TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, in_range, real_array, real_scalar
from flectofold_model.actuation import (actuated_like, actuation_model_of, ActuationModel,
                                        DEMONSTRATOR_ACTUATED, PneumaticPlant,
                                        StaticActuationModel)
from flectofold_model.actuation.circuit import DEMONSTRATOR_PLANT, PlantParameters
from flectofold_model.actuation.cushion_map import CushionMap
from flectofold_model.control.decimation import PublishDecimator
from flectofold_model.control.hardware import CushionDriver, SimulatedCushions
from flectofold_model.control.pressure_loop import (ControllerParameters, Fault,
                                                    PanelSelection, PressureController,
                                                    SafeAction, ValveCommand)
from flectofold_model.control.regulator import RegulatorSetpoints
from flectofold_model.structure.facade_map import facade_cushion_map

if TYPE_CHECKING:  # a facade's description loads where a facade is read
    from flectofold_model.facade.description import Facade

#: States a loop keeps: nodes that take them at least this often lose none.
SAMPLE_HISTORY = 4096
#: Panel-periods one call of the compiled simulation runs at most (10-20 ms of work), so that a
#: loop with a deadline looks at the clock often enough.
RUN_BUDGET = 16384


@dataclass(frozen=True)
class LoopAdvance:
    """What one :meth:`PanelLoops.advance_to` did."""

    periods: int
    """Control periods run."""
    skipped_s: float
    """Clock time not simulated because the jump exceeded the catch-up limit [s]."""
    behind_s: float = 0.0
    """Clock time still to simulate when the call ran out of time (``max_call_s``) [s]."""


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
    active: np.ndarray
    """Whether the loop was moving each panel (a valve open or its pressure reference still
    ramping to the target) in the period the state ends; False while it rests."""


class PanelLoops:
    """Closure setpoints in, valve openings out, for the ``N`` panels of one actuation model.

    Parameters
    ----------
    model : ActuationModel or HexagonActuationModel
        The panels' static actuation (one row per driver channel), of either panel kind.
    driver : CushionDriver
        Valves and sensors, ``driver.count == len(model)``. Its
        :attr:`~.hardware.CushionDriver.regulated` channels get pressure setpoints
        (:mod:`.regulator`) rather than valve openings; such a driver needs a positive
        ``hold_band_pa``.
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
    cushion_map : CushionMap, optional
        The tabulated map of ``model``; built from it when not given.
    max_call_s : float, optional
        Simulated drivers only: the longest one :meth:`advance_to` call works [s, wall clock].
        A loop that cannot keep up with its clock then stops there and goes on at a later
        call (:attr:`behind_s` says how far behind it is); calls within as long again as it
        worked do no work, so that its process keeps at least half its time to publish and
        answer signals, however many of its nodes tick. ``None`` (default): every call
        catches up fully.
    """

    def __init__(self, model: StaticActuationModel, driver: CushionDriver,
                 control_period_s: float = 0.1,
                 parameters: ControllerParameters = ControllerParameters(),
                 max_catch_up_s: float = 3600.0, quiet_period_s: Optional[float] = None,
                 cushion_map: Optional[CushionMap] = None,
                 max_call_s: Optional[float] = None) -> None:
        if not isinstance(model, StaticActuationModel):
            raise TypeError(f'model must be an ActuationModel or a HexagonActuationModel, got '
                            f'{type(model).__name__}')
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
        self.max_call_s = None if max_call_s is None else _positive('max_call_s', max_call_s,
                                                                    60.0)
        self.behind_s = 0.0
        """Clock time the loop has yet to simulate after its last call [s]."""
        self._resting_until = -math.inf
        self.skipped_s = 0.0
        """Clock time not simulated, in all, because jumps exceeded the catch-up limit [s]."""
        self.quiet_periods = 1 if quiet_period_s is None else max(1, math.floor(
            _positive('quiet_period_s', quiet_period_s, 60.0) / self.period_s + 1e-9))
        self.quiet_periods_run = 0
        self.model = model
        self.map = CushionMap(model) if cushion_map is None else cushion_map
        self.driver = driver
        self.controller = PressureController(self.map, driver.circuit, parameters)
        self.regulators = _regulators(self.controller, driver)
        """The :class:`~.regulator.RegulatorSetpoints` of a driver with regulated channels,
        else None."""
        self._setpoint = np.zeros(len(model))
        self.measured_pa: FloatArray = np.full(len(model), np.nan)
        self._rested_setpoint: Optional[FloatArray] = None
        self.time_s: Optional[float] = None
        self._feedback: Optional[tuple[FloatArray, FloatArray]] = None
        self._sample_periods: dict[int, float] = {}
        self._sampler: Optional[PublishDecimator] = None
        self.samples: deque[LoopSample] = deque(maxlen=SAMPLE_HISTORY)
        self._sequence = 0
        self.compiled = isinstance(driver, SimulatedCushions) and \
            type(driver).advance is SimulatedCushions.advance and \
            driver.plant.integrator == 'embedded'
        """Whether whole runs of periods go to the compiled simulation (a simulated driver on
        the compiled engine) rather than one period per Python call."""
        self._runs_per_call = max(8, min(512, RUN_BUDGET // len(model)))
        self._work: Optional[tuple[Any, ...]] = None
        self._resting_flags = np.zeros(len(model), dtype=bool)

    def __len__(self) -> int:
        return self._setpoint.shape[0]

    @property
    def setpoint(self) -> FloatArray:
        """Closure setpoints being tracked (N,), read-only; set them with :meth:`set_setpoints`."""
        view = self._setpoint.view()
        view.flags.writeable = False
        return view

    def set_setpoints(self, closure: npt.ArrayLike,
                      panels: PanelSelection = slice(None)) -> None:
        """Track closures in [0, 1] (scalar or one per selected panel) from the next period."""
        closure = in_range('closure', real_array('closure', closure), 0.0, 1.0)
        self._setpoint[panels] = closure

    def set_safe_action(self, action: SafeAction,
                        panels: Optional[PanelSelection] = None) -> None:
        """VENT (default) or HOLD for panels with a latched circuit fault."""
        self.controller.set_safe_action(action, panels)

    def advance_to(self, now_s: float) -> LoopAdvance:
        """Run the loop up to the clock reading ``now_s`` [s]; repeated readings do nothing.

        The first call only starts the clock. A clock that goes backwards (a replayed bag
        looping) restarts it there.
        """
        now_s = real_scalar('now_s', now_s)
        if self.time_s is None or now_s < self.time_s:
            self.time_s = now_s
            if self._sampler is not None:
                self._sampler.restart()
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
        skipped = max(0, periods - math.floor(self.max_catch_up_s / self.period_s))
        if skipped:
            # The plant holds through the time beyond the catch-up limit: its state, at the
            # new time, starts a new grid of samples.
            self.time_s += skipped * self.period_s
            self.skipped_s += skipped * self.period_s
            periods -= skipped
            if self._sampler is not None:
                self._sampler.restart()
                self._sample(self.time_s)
        started = time.monotonic()
        if started < self._resting_until:
            # behind, and resting after a call that ran out of time: the process's turn
            self.behind_s = periods * self.period_s
            return LoopAdvance(0, skipped * self.period_s, self.behind_s)
        deadline = None if self.max_call_s is None else started + self.max_call_s
        run_periods = self._run_compiled if self.compiled else self._run_periods
        run, periods = run_periods(periods, deadline)
        self.behind_s = periods * self.period_s
        if periods:  # out of time: rest as long as this call worked
            finished = time.monotonic()
            self._resting_until = finished + (finished - started)
        return LoopAdvance(run, skipped * self.period_s, self.behind_s)

    def _run_periods(self, periods: int, deadline: Optional[float]) -> tuple[int, int]:
        """Run ``periods`` periods one Python call each; return the runs and the periods left."""
        run = 0
        while periods:
            span = min(self.quiet_periods, periods) if self._resting() else 1
            # the state a quiet span holds: computed only for one
            held = (self.current_feedback(), self.measured_pa) if span > 1 else None
            command = self._period(span * self.period_s)
            if span > 1 and (np.any(command.fill_opening) or np.any(command.vent_opening)):
                span = 1  # woke up: these openings hold for one short period only
            self.quiet_periods_run += span > 1
            self.driver.advance(span * self.period_s)
            periods -= span
            run += 1
            self.time_s = cast(float, self.time_s) + span * self.period_s  # set by advance_to
            if span > 1 and held is not None:  # held: computed for every quiet span
                self._hold_samples(self.time_s, *held)
            self._sample(self.time_s)
            if deadline is not None and time.monotonic() > deadline:
                break  # out of time for this call: the rest waits for the next one
        return run, periods

    def _run_compiled(self, periods: int, deadline: Optional[float]) -> tuple[int, int]:
        """:meth:`_run_periods` in the compiled simulation, many periods per call."""
        driver = cast(SimulatedCushions, self.driver)  # self.compiled: a simulated driver
        controller, plant, count = self.controller, driver.plant, len(self)
        if self._work is None:
            from flectofold_model.control.simulation_kernel import run_periods
            size = self._runs_per_call
            self._work = (run_periods, np.zeros(size, dtype=np.int64),
                          *(np.empty((size + 1, count)) for _ in range(3)),
                          np.full(count, np.nan), np.zeros((size + 1, count), dtype=np.bool_))
        run_periods, spans, measured, closure, fold_angle, rested, active = self._work
        # nothing has rested yet: NaN equals no setpoint, so the first run cannot be quiet
        rested[:] = np.nan if self._rested_setpoint is None else self._rested_setpoint
        fill, vent = driver.valve_openings(copy=False)
        run = 0
        while periods:
            runs = min(self._runs_per_call, periods)
            noise = plant.sensors.draw_ahead(runs)
            measured[0] = self.measured_pa
            closure[0], fold_angle[0] = self.current_feedback()
            arrays, constants, sensors = plant.kernel_view()
            made, done, quiet, accepted, rejected = run_periods(
                periods, runs, self.period_s, self.quiet_periods, self._setpoint, rested,
                noise, controller.state, controller.codes, controller.kernel_parameters,
                controller.kernel_circuit, controller.kernel_tables, arrays, constants, sensors,
                fill, vent, spans, measured, closure, fold_angle, active)
            if made < runs:
                plant.sensors.put_back(noise[made:])
            self._rested_setpoint = rested
            self.quiet_periods_run += quiet
            for r in range(made):
                self.time_s = cast(float, self.time_s) + int(spans[r]) * self.period_s
                if spans[r] > 1:
                    self._hold_samples(self.time_s, (closure[r], fold_angle[r]), measured[r])
                self._sample(self.time_s, (closure[r + 1], fold_angle[r + 1]), measured[r + 1],
                             active[r + 1])
            plant.account(done * self.period_s, accepted, rejected)
            self.measured_pa = measured[made].copy()
            self._feedback = (closure[made].copy(), fold_angle[made].copy())
            periods -= done
            run += made
            if deadline is not None and time.monotonic() > deadline:
                break  # out of time for this call: the rest waits for the next one
        return run, periods

    # -- samples ---------------------------------------------------------------------------

    def request_sample_period(self, row: int, period_s: float) -> None:
        """Keep states at least every ``period_s`` [s] of the loop's clock for ``row``.

        The loop keeps them at the shortest period any row asked for; each row then picks
        its own from those (a :class:`~.decimation.PublishDecimator`).
        """
        period_s = real_scalar('period_s', period_s)
        if period_s <= 0.0:
            raise ValueError(f'period_s must be positive, got {period_s:g} s')
        self._sample_periods[row] = period_s
        shortest = min(self._sample_periods.values())
        if self._sampler is None or shortest != self._sampler.period_s:
            self._sampler = PublishDecimator(shortest, slack_s=0.5 * self.period_s)

    def _sample(self, clock_s: float, feedback: Optional[tuple[FloatArray, FloatArray]] = None,
                measured_pa: Optional[FloatArray] = None,
                active: Optional[BoolArray] = None) -> None:
        """Keep the feedback when the sampler says so, at the loop clock's own time.

        A loop that catches up a long clock jump in one call thereby still leaves its states
        at their own times, for nodes to publish with the right stamps. ``feedback``,
        ``measured_pa`` and ``active`` are the state at ``clock_s``; the last period's when
        not given.
        """
        if self._sampler is None or not self._sampler.due(clock_s):
            return
        if feedback is None:
            feedback, measured_pa = self.current_feedback(), self.measured_pa
            active = self.controller.active
        # measured_pa and active: given together with feedback
        self._keep(clock_s, feedback, cast(FloatArray, measured_pa), cast(BoolArray, active))

    def _hold_samples(self, end_s: float, feedback: tuple[FloatArray, FloatArray],
                      measured_pa: FloatArray) -> None:
        """Keep the states due inside a quiet span that ended at ``end_s``, as last measured.

        A quiet span (every panel resting, valves shut) reads the sensors once, at its start:
        a state due inside it is that reading, held (a sample and hold), so that the states
        still come at their rate.
        """
        sampler = self._sampler
        while sampler is not None and sampler.next_due_s is not None and \
                sampler.next_due_s < end_s - sampler.slack_s:
            due_s = sampler.next_due_s
            sampler.due(due_s)
            self._keep(due_s, feedback, measured_pa, self._resting_flags)

    def _keep(self, time_s: float, feedback: tuple[FloatArray, FloatArray],
              measured_pa: FloatArray, active: BoolArray) -> None:
        self._sequence += 1
        closure, fold_angle = feedback
        self.samples.append(LoopSample(self._sequence, time_s, closure.copy(), fold_angle.copy(),
                                       measured_pa.copy(), active.copy()))

    def samples_since(self, sequence: int, limit: Optional[int] = None) -> list[LoopSample]:
        """Return the kept :class:`LoopSample` objects after ``sequence``, oldest first.

        Costs the number of samples returned, not the number kept: sequences count up by one,
        so the newest ``last - sequence`` samples are the ones wanted. ``limit``: at most that
        many, the newest.
        """
        if not self.samples or self.samples[-1].sequence <= sequence:
            return []
        count = min(self.samples[-1].sequence - sequence, len(self.samples),
                    len(self.samples) if limit is None else limit)
        return list(islice(reversed(self.samples), count))[::-1]

    # -- the loop --------------------------------------------------------------------------

    def _resting(self) -> bool:
        """Every panel at rest in its hold band (valves shut), setpoints unchanged."""
        controller = self.controller
        last = controller.last_command
        return (self.quiet_periods > 1 and controller.parameters.hold_band_pa > 0.0
                and self._rested_setpoint is not None
                and np.array_equal(self._setpoint, self._rested_setpoint)
                and not np.any(last.fill_opening) and not np.any(last.vent_opening)
                and np.array_equal(controller.reference_gauge_pa, controller.target_gauge_pa))

    def _period(self, dt_s: float) -> ValveCommand:
        self._rested_setpoint = self._setpoint.copy()
        self.measured_pa = self.driver.read_pressure_pa()
        if self.driver.comms_lost:  # before the step, which then takes the safe action
            self.controller.latch_fault(Fault.COMMS_LOST)
        command = self.controller.step(dt_s, self._setpoint, self.measured_pa,
                                       self.driver.read_supply_pa())
        if self.regulators is None:
            self.driver.write_valves(command.fill_opening, command.vent_opening)
        else:
            self.driver.write_outputs(command.fill_opening, command.vent_opening,
                                      self.regulators.update(command, self.measured_pa))
        self._feedback = None
        return command

    # -- feedback --------------------------------------------------------------------------

    def current_feedback(self) -> tuple[FloatArray, FloatArray]:
        """Closure and fold angle (N,) of the last period, computed once per period."""
        if self._feedback is None:
            closure, fold_angle = np.empty(len(self)), np.empty(len(self))
            self.controller.feedback(closure, fold_angle)
            self._feedback = (closure, fold_angle)
        return self._feedback

    @property
    def gauge_pa(self) -> FloatArray:
        """The loop's filtered cushion pressure (N,) [Pa gauge]."""
        return self.controller.filtered_gauge_pa.copy()

    @property
    def closure(self) -> FloatArray:
        """Closure (N,) the static map gives for the filtered measured pressure."""
        return self.current_feedback()[0].copy()

    @property
    def fold_angle_rad(self) -> FloatArray:
        """Flap fold angle at the crease apex (N,) [rad], from :attr:`closure`."""
        return self.current_feedback()[1].copy()

    @property
    def fault(self) -> npt.NDArray[np.object_]:
        """Latched circuit fault of each panel (N,), :class:`~.pressure_loop.Fault` objects."""
        return self.controller.fault.copy()

    def reset_faults(self, panels: Optional[PanelSelection] = None) -> None:
        """Clear latched circuit faults; see :meth:`PressureController.reset_faults`."""
        self.controller.reset_faults(panels)

    @property
    def free_air_used_nl(self) -> FloatArray:
        """Air drawn from the supply per panel [NL], where the driver measures it, else NaN."""
        used = getattr(self.driver, 'free_air_used_m3', None)
        return np.full(len(self), np.nan) if used is None else used * 1e3

    def close(self) -> None:
        """Shut the valves: the panels keep their air (a held position) until vented."""
        self.driver.close()


def _regulators(controller: PressureController,
                driver: CushionDriver) -> Optional[RegulatorSetpoints]:
    """Return the RegulatorSetpoints of a driver with regulated channels, None for valves."""
    regulated = np.asarray(driver.regulated)
    if not np.any(regulated):
        return None
    if controller.parameters.hold_band_pa <= 0.0:
        # At rest the valve model must expect no flow: the regulator, not the loop, holds.
        raise ValueError('a driver with pressure regulators needs hold_band_pa > 0 (three '
                         "sensor sigmas, and more than the regulator's accuracy)")
    return RegulatorSetpoints(controller, regulated)


def _positive(name: str, value: float, largest: float) -> float:
    value = real_scalar(name, value)
    if not 0.0 < value <= largest:
        raise ValueError(f'{name} must lie in (0, {largest:g}], got {value:g}')
    return value


def compile_kernels() -> None:
    """Compile the kernels simulated loops run, or load them from the cache, before they run.

    Compiling takes tens of CPU seconds the first time after a change to the model (then the
    cache has them, see :mod:`flectofold_model._compiled`): a process calls this while it
    starts, not in its first loop call. Processes starting together compile once.
    """
    from flectofold_model._compiled import compile_lock
    with compile_lock():
        model = ActuationModel([DEMONSTRATOR_ACTUATED])
        cushion_map = CushionMap(model, samples=3)
        plant = PneumaticPlant(DEMONSTRATOR_PLANT, cushion_map, 1, integrator='embedded')
        loops = PanelLoops(model, SimulatedCushions(plant), 0.1,
                           ControllerParameters(hold_band_pa=1.0), quiet_period_s=0.2,
                           cushion_map=cushion_map)
        loops.request_sample_period(0, 0.1)
        loops.advance_to(0.0)
        loops.advance_to(0.3)


def facade_loops(facade: 'Facade', panel_ids: Iterable[str], control_period_s: float = 0.1,
                 parameters: ControllerParameters = ControllerParameters(),
                 circuit: PlantParameters = DEMONSTRATOR_PLANT, seed: int = 0,
                 quiet_period_s: Optional[float] = None, max_call_s: Optional[float] = None,
                 driver: Optional[CushionDriver] = None, trace: bool = True) -> PanelLoops:
    """Build :class:`PanelLoops` for some panels of a facade on one simulated circuit.

    Each panel is actuated like its kind's preset module (the quad demonstrator or the
    hexagonal module, see :func:`~flectofold_model.actuation.kinds.actuated_like`);
    ``panel_ids`` must name panels of ``facade`` (``ValueError`` lists what is there
    otherwise). The plant is the compiled engine (``PneumaticPlant(integrator='embedded')``);
    panels of one module geometry share one static table. ``driver``: a
    :class:`CushionDriver` with one channel per panel instead (real valves; ``circuit`` and
    ``seed`` are then unused). The cushion map is the one the facade's description chooses
    (:func:`~flectofold_model.structure.facade_map.facade_cushion_map`, ``trace`` as there).
    """
    model, cushion_map = facade_actuation(facade, panel_ids, trace)
    if driver is None:
        driver = SimulatedCushions(facade_plant(model, cushion_map, circuit, seed))
    return PanelLoops(model, driver, control_period_s, parameters,
                      quiet_period_s=quiet_period_s, cushion_map=cushion_map,
                      max_call_s=max_call_s)


def facade_actuation(facade: 'Facade', panel_ids: Iterable[str],
                     trace: bool = True) -> tuple[StaticActuationModel, CushionMap]:
    """Return the actuation model and its cushion map for ``panel_ids`` of ``facade``.

    Each panel is actuated like its kind's preset module
    (:func:`~flectofold_model.actuation.kinds.actuated_like`); the map is the energy statics'
    or the structure's, as the description chooses
    (:func:`~flectofold_model.structure.facade_map.facade_cushion_map`, ``trace`` as there).
    """
    indices = panel_indices(facade, panel_ids)
    model = actuation_model_of(actuated_like(facade.panels[i]) for i in indices)
    return model, facade_cushion_map(facade, model, trace)


def facade_plant(model: StaticActuationModel, cushion_map: CushionMap,
                 circuit: PlantParameters = DEMONSTRATOR_PLANT, seed: int = 0) -> PneumaticPlant:
    """Return the simulated plant of ``model``'s panels on the compiled engine, a channel each."""
    return PneumaticPlant(circuit, cushion_map, len(model), seed=seed, integrator='embedded')


def panel_indices(facade: 'Facade', panel_ids: Iterable[str]) -> list[int]:
    """Positions of ``panel_ids`` in ``facade.panel_ids``; unknown or repeated ids raise."""
    panel_ids = list(panel_ids)
    if not panel_ids:
        raise ValueError('no panel ids given')
    known = set(facade.panel_ids)
    unknown = [p for p in panel_ids if p not in known]
    if unknown:
        raise ValueError(f'unknown panel id(s) {", ".join(map(str, unknown))} in facade '
                         f'{facade.name!r}, which has {facade.panel_ids[0]} .. '
                         f'{facade.panel_ids[-1]}')
    if len(set(panel_ids)) != len(panel_ids):
        raise ValueError('a panel id is given twice')
    position = {panel_id: i for i, panel_id in enumerate(facade.panel_ids)}
    return [position[p] for p in panel_ids]
