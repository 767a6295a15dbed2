"""Facade scheduling of Flectofold panels: desired closure -> commanded closure under limits.

A facade coordinator calls :meth:`Scheduler.step` every control period (1-10 s) with one
*desired* closure per panel (0 open/flat, 1 closed; computed upstream from the sun and the
shading, already maximised over the look-ahead window by the caller, the Beckhoff pattern) and
the current conditions. The scheduler returns one *commanded* closure per panel that respects
the hardware and the occupants. Everything is vectorised over panels and deterministic: the
same calls give the same outputs, ties are broken by panel index.

Each panel is in one mode per call, by precedence **fault > storm > override > automatic**:

==========  ====================================================================================
fault       ``faulted`` panel: the commanded closure is left as it is, no air, never filling;
            any move in progress is dropped.
storm       storm latch set: ``storm_position`` at once, ignoring dwell, deadband, rate limit,
            daily cap and air budget (air it takes is still drawn, the bucket stops at zero).
            The latch (:class:`~.storm.StormLatch`) runs on timestamped gust samples.
override    a manual override that has not expired: its closure, through the rate limit, the
            air budget and the daily cap, but not the dwell or the deadband.
automatic   ``desired_closure`` while the DNI gate is on, ``default_closure`` while it is off;
            through deadband, dwell, daily cap, rate limit and air budget.
==========  ====================================================================================

**Storm and overrides.** When the latch trips every override ends; while it is set
:meth:`Scheduler.set_override` refuses new ones (:class:`OverrideRefused`): an override is
not kept to take effect after the storm. After the release the panels are scheduled
automatically. Feed wind samples as they arrive with :meth:`Scheduler.observe_wind` (or one
per call with ``step(wind_m_s=...)``) and evaluate a pending trip with
:meth:`Scheduler.advance_storm` at :attr:`Scheduler.storm_due_s`: the latch acts at its
instant, not at the next call of :meth:`Scheduler.step`.

**Moves.** A panel at rest starts a move when its target passes the checks of its mode; the
move runs to the goal latched then (a later change of the automatic target waits until the
move ends: the look-ahead is the caller's). A move that has not yet changed the closure (it
waits for air) is re-decided every call. A *move* counts, for the dwell and the daily cap,
when the commanded closure first changes after the panel was at rest; retargeting a running
move (a new override, the storm) does not count again. Storm moves count toward
:attr:`Scheduler.moves_today` (they wear the panel too) but are never stopped by the cap. A
panel leaving override mode stops where it is and is scheduled automatically from there.

**Air.** Only closing costs air, ``air_cost_nl_per_closure * delta_closure`` [NL]; venting
is free and always admitted. The supply is a token bucket of ``capacity_nl`` refilled at
``refill_nl_per_s``. Each call the closing requests are ranked: panels that filled in the
previous call first (a running fill keeps its slot), then by requested increase ``goal -
closure`` plus ``waited_s / aging_s``, then by panel index; they are admitted in that order
while the running total of their costs fits in the bucket and at most
``max_parallel_fills`` panels fill, and the first that does not fit stops the queue
(head-of-line, so a large request cannot be starved by small ones). The rest wait. One
call's increment never asks for more than the whole bucket, so every request eventually fits
while the bucket refills.

**Reasons.** Exactly one :class:`Reason` per panel per call, the one that decided the output:
``FAULT``; ``STORM``; in override mode ``DAILY_CAP``, else ``WAITING_FOR_AIR``, else
``RATE_LIMITED`` (moved, or could not move because no time passed, short of the goal), else
``OVERRIDE``; in automatic mode ``DEADBAND``, else ``DWELL``, else ``DAILY_CAP``, else
``WAITING_FOR_AIR``, else ``RATE_LIMITED``, else ``AUTO`` (gate on) or ``DNI_GATE`` (gate
off).

References for the defaults: Adaptive-Cover-Pro (Home Assistant cover automation): a minimum
position change of 2 % and a tolerance of 3 %; the Institut du Monde Arabe, Paris, whose
mechanical diaphragms failed from over-cycling, hence a cap of 20 moves per panel and day; a
100 L receiver cycling between 8 and 6 bar holds about 200 NL, refilled by a compressor of
100 NL/min; WMO-No. 8 (Guide to Instruments and Methods of Observation), sunshine is
DNI >= 120 W/m2. Times are in s (``now_s`` is UTC Unix time: the daily counter follows the
UTC day), wind speeds in m/s, irradiance in W/m2, air in normal litres (NL).
"""

from dataclasses import dataclass, fields
import enum
import math
from numbers import Integral
from typing import NamedTuple, Optional

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import (BoolArray, FloatArray, in_range, IntArray, real_array,
                                        real_scalar)
from flectofold_model.scheduling.storm import StormLatch

SECONDS_PER_DAY = 86400.0
#: Slack when comparing a running total of air costs with the tokens left [NL].
_AIR_TOLERANCE_NL = 1e-9
#: A step that ends this close to its goal ends on it, so that rounding in the sum of many
#: rate-limited steps never leaves a sliver of a move to take a fill slot [closure].
_CLOSURE_TOLERANCE = 1e-12


class Reason(enum.Enum):
    """What decided a panel's commanded closure in one call of :meth:`Scheduler.step`."""

    AUTO = 'auto'
    DEADBAND = 'deadband'
    DWELL = 'dwell'
    RATE_LIMITED = 'rate_limited'
    WAITING_FOR_AIR = 'waiting_for_air'
    DAILY_CAP = 'daily_cap'
    OVERRIDE = 'override'
    STORM = 'storm'
    FAULT = 'fault'
    DNI_GATE = 'dni_gate'


class OverrideRefused(RuntimeError):
    """A manual override was refused: the storm latch is set."""


_REASONS = np.array(list(Reason), dtype=object)
_CODE = {reason: code for code, reason in enumerate(Reason)}
_AUTO_MODE, _OVERRIDE_MODE, _STORM_MODE, _FAULT_MODE = range(4)


class _Modes(NamedTuple):
    """The masks (N,) of one call's modes, and who was moving and goes on."""

    fault: np.ndarray
    storm: np.ndarray
    override: np.ndarray
    auto: np.ndarray
    mode: np.ndarray
    stop: np.ndarray
    """Panels that stop where they are: faulted, or whose override ended."""
    started: np.ndarray
    """Panels on a move that goes on."""


class _Moves(NamedTuple):
    """The moves of automatic and override panels in one call (N,)."""

    moving: np.ndarray
    closing: np.ndarray
    remaining: np.ndarray
    increment: np.ndarray
    """Closure a closing panel asks to add in this call."""
    requesting: np.ndarray


@dataclass(frozen=True)
class SchedulerParameters:
    """Limits of the panels, the air supply, the storm latch and the sun gate.

    Defaults suit the demonstrator module on a 100 L receiver; see the module docstring for
    their sources.
    """

    deadband: float = 0.03
    """A still panel does not move for a change of its target smaller than this [closure]
    (Adaptive-Cover-Pro: minimum change 2 %, tolerance 3 %)."""
    min_dwell_s: float = 300.0
    """Least time between the starts of two moves of a panel [s]; 5-15 min suits a
    pneumatic panel with a 1-30 s fill."""
    rate_per_s: float = 0.02
    """Largest rate of change of the commanded closure [1/s]; a full stroke takes 50 s."""
    daily_move_cap: int = 20
    """Moves per panel and UTC day; once reached only the storm moves the panel (the
    Institut du Monde Arabe failed from over-cycling)."""
    capacity_nl: float = 200.0
    """Size of the air token bucket [NL]: a 100 L receiver cycling from 8 to 6 bar."""
    refill_nl_per_s: float = 100.0 / 60.0
    """Refill of the bucket [NL/s]: a compressor of 100 NL/min."""
    max_parallel_fills: int = 6
    """Most panels whose commanded closure increases in one call."""
    aging_s: float = 60.0
    """A closing request that has waited this long gains 1.0 (a full stroke) of priority over
    a fresh one, so nothing starves [s]."""
    wind_on_m_s: float = 10.0
    """Gust speed above which the storm latch trips [m/s]."""
    wind_off_m_s: float = 7.0
    """Gust speed below which the storm latch may release [m/s]."""
    storm_on_delay_s: float = 5.0
    """The wind must stay above ``wind_on_m_s`` this long to trip the latch [s]."""
    storm_off_delay_s: float = 900.0
    """The wind must stay below ``wind_off_m_s`` this long to release the latch [s]."""
    storm_position: float = 0.0
    """Closure of every healthy panel while the storm latch is set; 0 is vented and flat,
    the actuator's fail-safe, and costs no air [closure]."""
    override_duration_s: float = 7200.0
    """Life of a manual override when none is given [s]."""
    dni_on_w_m2: float = 120.0
    """Direct normal irradiance at which automatic shading starts [W/m2] (WMO sunshine)."""
    dni_off_w_m2: float = 100.0
    """Direct normal irradiance below which automatic shading stops [W/m2]."""
    default_closure: float = 0.0
    """Automatic target while the DNI gate is off [closure]."""

    def __post_init__(self) -> None:
        for field in fields(self):
            value = getattr(self, field.name)
            if field.name in ('daily_move_cap', 'max_parallel_fills'):
                if isinstance(value, (bool, np.bool_)) or not isinstance(value, Integral) \
                        or value < 1:
                    raise ValueError(f'{field.name} must be an integer >= 1, got {value!r}')
                object.__setattr__(self, field.name, int(value))
                continue
            value = real_scalar(field.name, value)
            if value < 0.0:
                raise ValueError(f'{field.name} must not be negative, got {value:g}')
            object.__setattr__(self, field.name, value)
        for name in ('rate_per_s', 'capacity_nl', 'aging_s', 'override_duration_s'):
            if getattr(self, name) <= 0.0:
                raise ValueError(f'{name} must be positive, got {getattr(self, name):g}')
        for name in ('deadband', 'storm_position', 'default_closure'):
            if getattr(self, name) > 1.0:
                raise ValueError(f'{name} must lie in [0, 1], got {getattr(self, name):g}')
        if self.wind_on_m_s <= self.wind_off_m_s:
            raise ValueError(f'wind_on_m_s={self.wind_on_m_s:g} m/s must exceed '
                             f'wind_off_m_s={self.wind_off_m_s:g} m/s')
        if self.dni_on_w_m2 <= self.dni_off_w_m2:
            raise ValueError(f'dni_on_w_m2={self.dni_on_w_m2:g} W/m2 must exceed '
                             f'dni_off_w_m2={self.dni_off_w_m2:g} W/m2')


@dataclass(frozen=True)
class ScheduleResult:
    """Output of one :meth:`Scheduler.step`."""

    closure: np.ndarray
    """Commanded closure of each panel (N,) [closure, 0 open .. 1 closed]."""
    reason: np.ndarray
    """What decided each panel's closure (N,), an object array of :class:`Reason`."""
    filling: np.ndarray
    """Panels whose commanded closure increased in this call (N,) bool."""
    air_used_nl: float
    """Air drawn from the bucket in this call [NL]."""
    tokens_nl: float
    """Air left in the bucket after this call [NL]."""


class Scheduler:
    """Commanded closures of N panels from desired ones, one call per control period.

    Parameters
    ----------
    count : int
        Number of panels N, ``>= 1``.
    air_cost_nl_per_closure : array-like
        Air a panel takes to close fully from open, scalar or (N,) [NL per unit closure],
        ``>= 0``; about 16 NL for the demonstrator module.
    parameters : SchedulerParameters
        Limits; the defaults suit the demonstrator.
    zones : array-like of int, optional
        Zone label of each panel (N,), for :meth:`set_override` and :meth:`clear_override`
        by zone.
    initial_closure : array-like
        Commanded closure the panels start from, scalar or (N,), in [0, 1].
    storm_latched : bool
        Storm latch to start with, as saved from :attr:`storm_latched` by a coordinator
        that restarts.
    wind_timeout_s : float
        A wind sample counts until the next one but at most this long [s], ``> 0`` (see
        :class:`~.storm.StormLatch`).
    start_s : float
        Clock at construction [s, UTC Unix time]; the first :meth:`step` integrates the
        rate limit and the bucket refill from here and may not be earlier.

    Notes
    -----
    The bucket starts full and the DNI gate off: automatic shading starts when the DNI first
    reaches ``dni_on_w_m2`` (or at once while ``dni_w_m2`` is not given).
    """

    def __init__(self, count: int, air_cost_nl_per_closure: npt.ArrayLike,
                 parameters: SchedulerParameters = SchedulerParameters(),
                 zones: Optional[npt.ArrayLike] = None, initial_closure: npt.ArrayLike = 0.0,
                 storm_latched: bool = False, start_s: float = 0.0,
                 wind_timeout_s: float = 60.0) -> None:
        if isinstance(count, (bool, np.bool_)) or not isinstance(count, Integral) or count < 1:
            raise ValueError(f'count must be a positive integer, got {count!r}')
        if not isinstance(parameters, SchedulerParameters):
            raise TypeError(
                f'parameters must be SchedulerParameters, got {type(parameters).__name__}')
        if not isinstance(storm_latched, (bool, np.bool_)):
            raise TypeError(f'storm_latched must be a bool, got {storm_latched!r}')
        # The attributes' types written out: mypy knows no int as an Integral, so it takes the
        # rest of this method for unreachable and would infer none of them.
        self.parameters: SchedulerParameters = parameters
        self._count: int = int(count)
        self._air_cost: FloatArray = self._per_panel(
            'air_cost_nl_per_closure', air_cost_nl_per_closure, 0.0, np.inf, ' NL',
            high_open=True)
        self._zones: Optional[IntArray] = None if zones is None else self._check_zones(zones)
        self._commanded: FloatArray = self._per_panel('initial_closure', initial_closure, 0.0,
                                                      1.0)
        self._now_s: float = real_scalar('start_s', start_s)
        self._day: int = math.floor(self._now_s / SECONDS_PER_DAY)
        self._storm: StormLatch = StormLatch(parameters, wind_timeout_s, storm_latched,
                                             self._now_s)
        self._gate_on: bool = False
        self._tokens_nl: float = parameters.capacity_nl
        self._goal: FloatArray = self._commanded.copy()
        self._started: BoolArray = np.zeros(count, dtype=bool)
        self._filling: BoolArray = np.zeros(count, dtype=bool)
        self._waiting_since_s: FloatArray = np.full(count, np.nan)
        self._last_move_s: FloatArray = np.full(count, -np.inf)
        self._moves: npt.NDArray[np.int64] = np.zeros(count, dtype=np.int64)
        self._override_closure: FloatArray = np.full(count, np.nan)
        self._override_until_s: FloatArray = np.full(count, -np.inf)
        self._mode: npt.NDArray[np.int8] = np.full(count, _AUTO_MODE, dtype=np.int8)

    def __len__(self) -> int:
        return self._count

    @property
    def storm_latched(self) -> bool:
        """Whether the storm latch is set (save it to restore a restarted coordinator)."""
        return self._storm.latched

    @property
    def storm_due_s(self) -> Optional[float]:
        """Instant the storm latch trips or releases if no other sample comes [s]; or None."""
        return self._storm.due_s

    @property
    def storm_changed_s(self) -> Optional[float]:
        """Instant of the storm latch's last trip or release [s]; None before the first."""
        return self._storm.changed_s

    @property
    def storm_time_s(self) -> float:
        """Latest instant the storm latch was evaluated at [s]; later calls may not be earlier."""
        return self._storm.now_s

    @property
    def last_step_s(self) -> float:
        """Instant of the last :meth:`step` [s]; ``start_s`` before the first."""
        return self._now_s

    @property
    def earliest_step_s(self) -> float:
        """Earliest instant the next :meth:`step` may be at [s].

        Neither before the last step nor before the storm latch's latest evaluation.
        """
        return max(self._now_s, self._storm.now_s)

    def wind_m_s(self, now_s: float) -> Optional[float]:
        """Return the wind sample that counts at ``now_s`` [m/s]; None if none or stale."""
        return self._storm.wind_m_s(now_s)

    def observe_wind(self, wind_m_s: float, at_s: float) -> bool:
        """Take a gust sample [m/s, >= 0] on its arrival at ``at_s`` [s]; return the latch.

        The trip (or release) timer starts at ``at_s``; a trip ends every override. The
        commanded closures change at the next :meth:`step`, which a caller makes at once
        when the latch changed. ``at_s`` may not be earlier than :attr:`storm_time_s`.
        """
        self._storm.sample(wind_m_s, at_s)
        self._after_storm()
        return self._storm.latched

    def advance_storm(self, now_s: float) -> bool:
        """Evaluate the storm latch at ``now_s`` [s] on the last sample; return the latch."""
        self._storm.advance(now_s)
        self._after_storm()
        return self._storm.latched

    def _after_storm(self) -> None:
        if self._storm.latched:
            self._override_closure[:] = np.nan
            self._override_until_s[:] = -np.inf

    @property
    def dni_gate_on(self) -> bool:
        """Whether the DNI gate lets automatic shading through (last reading given)."""
        return self._gate_on

    @property
    def commanded_closure(self) -> FloatArray:
        """Commanded closure of each panel after the last call (N,) [closure]."""
        return self._commanded.copy()

    @property
    def tokens_nl(self) -> float:
        """Air left in the bucket [NL]."""
        return self._tokens_nl

    @property
    def moves_today(self) -> npt.NDArray[np.int64]:
        """Moves each panel started in the UTC day of the last call (N,) int."""
        return self._moves.copy()

    def set_override(self, closure: float, now_s: float, panels: Optional[npt.ArrayLike] = None,
                     zone: Optional[int] = None, duration_s: Optional[float] = None) -> None:
        """Hold panels at a closure until ``now_s + duration_s``; replaces older overrides.

        Parameters
        ----------
        closure : float
            Closure to hold, in [0, 1].
        now_s : float
            Time of the request [s, UTC Unix time], not before the last :meth:`step`.
        panels : int, sequence of int or bool array (N,), optional
            Panels to override. Give exactly one of ``panels`` and ``zone``.
        zone : int, optional
            Zone label (see the constructor's ``zones``) whose panels to override.
        duration_s : float, optional
            Life of the override [s], ``> 0``; ``override_duration_s`` when not given.

        Raises
        ------
        OverrideRefused
            If the storm latch is set at ``now_s``: the override is not kept.
        """
        selected = self._select(panels, zone, everything_if_none=False)
        closure = real_scalar('closure', closure)
        in_range('closure', np.asarray(closure), 0.0, 1.0)
        now = real_scalar('now_s', now_s)
        if now < self._now_s:
            raise ValueError(f'now_s must not go backwards: got {now:.3f} s after a step at '
                             f'{self._now_s:.3f} s')
        if duration_s is None:
            duration = self.parameters.override_duration_s
        else:
            duration = real_scalar('duration_s', duration_s)
            if duration <= 0.0:
                raise ValueError(f'duration_s must be positive, got {duration:g} s')
        if self.advance_storm(now):
            since = self._storm.changed_s
            raise OverrideRefused('storm latch set' + ('' if since is None else
                                                       f' since {since:.1f} s')
                                  + ': an override is not kept for after the storm')
        self._override_closure[selected] = closure
        self._override_until_s[selected] = now + duration

    def clear_override(self, panels: Optional[npt.ArrayLike] = None,
                       zone: Optional[int] = None) -> None:
        """End the overrides of ``panels`` or of ``zone``, or of every panel if neither given.

        A panel moving toward its override closure stops where it is; the automatic schedule
        takes it from there at the next :meth:`step`.
        """
        selected = self._select(panels, zone, everything_if_none=True)
        self._override_closure[selected] = np.nan
        self._override_until_s[selected] = -np.inf

    def step(self, now_s: float, desired_closure: npt.ArrayLike, wind_m_s: Optional[float] = None,
             dni_w_m2: Optional[float] = None,
             faulted: Optional[npt.ArrayLike] = None) -> ScheduleResult:
        """Advance to ``now_s`` and return the commanded closure of every panel.

        Parameters
        ----------
        now_s : float
            Time of this call [s, UTC Unix time]; must not go backwards.
        desired_closure : array-like
            Automatic target of each panel, scalar or (N,), in [0, 1].
        wind_m_s : float, optional
            Gust wind speed sampled at ``now_s`` [m/s], ``>= 0`` (:meth:`observe_wind`).
            When not given the last sample counts on until it is stale.
        dni_w_m2 : float, optional
            Direct normal irradiance [W/m2], ``>= 0``. When not given the DNI gate counts as
            on for this call and keeps its stored state.
        faulted : array-like of bool, optional
            Panels to leave alone (N,); none when not given.

        Returns
        -------
        ScheduleResult
            Commanded closures, reasons, filling panels and the air used and left.

        Raises
        ------
        ValueError
            If ``now_s`` goes backwards or an input has the wrong shape or lies outside its
            range; the message names the input.
        TypeError
            If an input is not a number, or ``faulted`` is not boolean.
        """
        now, desired, wind, dni, fault = self._check_step(now_s, desired_closure, wind_m_s,
                                                          dni_w_m2, faulted)
        elapsed_s, gate_on = self._advance_clock(now, wind, dni)
        modes = self._modes(now, fault)
        goal, codes = self._decide(now, desired, gate_on, modes)
        new, moves = self._rate_limit(modes, goal, codes, elapsed_s)
        new, air_used_nl = self._admission(now, modes, goal, new, moves, codes)
        return self._commit(modes, goal, new, codes, air_used_nl)

    def _advance_clock(self, now: float, wind: Optional[float],
                       dni: Optional[float]) -> tuple[float, bool]:
        """Phase 1: the day's move counter, the air bucket, the storm latch and the DNI gate."""
        parameters = self.parameters
        elapsed_s = now - self._now_s
        self._now_s = now
        day = math.floor(now / SECONDS_PER_DAY)
        if day != self._day:
            self._moves[:] = 0
            self._day = day
        self._tokens_nl = min(parameters.capacity_nl,
                              self._tokens_nl + parameters.refill_nl_per_s * elapsed_s)
        self._update_storm(now, wind)
        return elapsed_s, self._update_gate(dni)

    def _modes(self, now: float, fault: BoolArray) -> _Modes:
        """Phase 2: each panel's mode, by precedence fault > storm > override > automatic."""
        live = self._override_until_s > now
        self._override_closure[~live] = np.nan
        self._override_until_s[~live] = -np.inf
        storm = ~fault & self._storm.latched
        override = ~fault & ~storm & live
        auto = ~(fault | storm | override)
        mode = np.select([fault, storm, override], [_FAULT_MODE, _STORM_MODE, _OVERRIDE_MODE],
                         _AUTO_MODE).astype(np.int8)
        # A faulted panel, or one whose override has ended, stops where it is.
        stop = fault | (auto & (self._mode == _OVERRIDE_MODE))
        return _Modes(fault=fault, storm=storm, override=override, auto=auto, mode=mode,
                      stop=stop, started=self._started & ~stop)

    def _decide(self, now: float, desired: FloatArray, gate_on: bool,
                modes: _Modes) -> tuple[FloatArray, IntArray]:
        """Phase 3: each panel's goal and the reason code of its decision."""
        parameters = self.parameters
        closure = self._commanded
        fault, storm, override, auto = modes.fault, modes.storm, modes.override, modes.auto
        goal = np.where(modes.stop, closure, self._goal)
        at_rest = ~modes.started
        codes = np.select([fault, storm, override],
                          [_CODE[Reason.FAULT], _CODE[Reason.STORM], _CODE[Reason.OVERRIDE]],
                          _CODE[Reason.AUTO] if gate_on else _CODE[Reason.DNI_GATE])
        capped = self._moves >= parameters.daily_move_cap

        # Automatic panels at rest: deadband, then dwell, then the daily cap.
        target = desired if gate_on else np.full(self._count, parameters.default_closure)
        gap = np.abs(target - closure)
        deciding = auto & at_rest & (gap > 0.0)
        small = deciding & (gap < parameters.deadband)
        dwelling = deciding & ~small & (now - self._last_move_s < parameters.min_dwell_s)
        auto_capped = deciding & ~small & ~dwelling & capped
        held = small | dwelling | auto_capped
        codes[small] = _CODE[Reason.DEADBAND]
        codes[dwelling] = _CODE[Reason.DWELL]
        codes[auto_capped] = _CODE[Reason.DAILY_CAP]
        goal = np.where(auto & at_rest, np.where(deciding & ~held, target, closure), goal)

        # Override panels: their closure, unless a new move would pass the daily cap.
        override_capped = override & at_rest & (self._override_closure != closure) & capped
        codes[override_capped] = _CODE[Reason.DAILY_CAP]
        goal = np.where(override, np.where(override_capped, closure, self._override_closure),
                        goal)

        # Storm: straight to the storm position; it may draw air but never waits for it.
        return np.where(storm, parameters.storm_position, goal), codes

    def _rate_limit(self, modes: _Modes, goal: FloatArray, codes: IntArray,
                    elapsed_s: float) -> tuple[FloatArray, _Moves]:
        """Phase 4: storm panels jump, opening moves step by the rate limit, closing ones ask.

        Returns the new closures so far and the closing requests (:class:`_Moves`).
        """
        parameters = self.parameters
        closure = self._commanded
        new = np.where(modes.storm, parameters.storm_position, closure)
        moving = (modes.auto | modes.override) & (goal != closure)
        remaining = goal - closure
        limit = parameters.rate_per_s * elapsed_s
        opening = moving & (remaining < 0.0)
        new = np.where(opening, np.where(-remaining <= limit + _CLOSURE_TOLERANCE, goal,
                                         closure - limit), new)
        closing = moving & (remaining > 0.0)
        with np.errstate(divide='ignore'):
            affordable_step = parameters.capacity_nl / self._air_cost
        increment = np.minimum(limit, affordable_step)
        increment = np.where(closing, np.where(remaining <= increment + _CLOSURE_TOLERANCE,
                                               remaining, increment), 0.0)
        return new, _Moves(moving=moving, closing=closing, remaining=remaining,
                           increment=increment, requesting=closing & (increment > 0.0))

    def _admission(self, now: float, modes: _Modes, goal: FloatArray, new: FloatArray,
                   moves: _Moves, codes: IntArray) -> tuple[FloatArray, float]:
        """Phase 5: the air bucket and the fill slots admit closing moves; the rest wait."""
        parameters = self.parameters
        closure = self._commanded
        storm_air_nl = float(np.sum(self._air_cost[modes.storm]
                                    * np.maximum(parameters.storm_position
                                                 - closure[modes.storm], 0.0)))
        admitted, fill_air_nl = self._admit(now, moves.requesting, moves.remaining,
                                            moves.increment)
        new = np.where(admitted, np.where(moves.increment == moves.remaining, goal,
                                          closure + moves.increment), new)
        waiting = moves.requesting & ~admitted
        codes[moves.moving & (new != goal)] = _CODE[Reason.RATE_LIMITED]
        codes[waiting] = _CODE[Reason.WAITING_FOR_AIR]
        # A wait goes on while the request stands (a call with no time elapsed keeps it).
        self._waiting_since_s = np.where(
            waiting, np.where(np.isnan(self._waiting_since_s), now, self._waiting_since_s),
            np.where(moves.closing & ~moves.requesting, self._waiting_since_s, np.nan))
        return new, storm_air_nl + fill_air_nl

    def _commit(self, modes: _Modes, goal: FloatArray, new: FloatArray, codes: IntArray,
                air_used_nl: float) -> ScheduleResult:
        """Phase 6: count the moves started, keep the state, draw the air; the result."""
        closure = self._commanded
        changed = new != closure
        starts = changed & ~modes.started
        self._moves += starts
        self._last_move_s = np.where(starts, self._now_s, self._last_move_s)
        self._started = (modes.started | changed) & (new != goal)
        self._filling = new > closure
        self._goal = goal
        self._mode = modes.mode
        self._commanded = new
        self._tokens_nl = max(0.0, self._tokens_nl - air_used_nl)
        return ScheduleResult(closure=new.copy(), reason=_REASONS[codes],
                              filling=self._filling.copy(), air_used_nl=air_used_nl,
                              tokens_nl=self._tokens_nl)

    def _admit(self, now: float, requesting: BoolArray, remaining: FloatArray,
               increment: FloatArray) -> tuple[BoolArray, float]:
        """Choose the closing requests the bucket and the fill slots allow this call."""
        parameters = self.parameters
        admitted = np.zeros(self._count, dtype=bool)
        index = np.flatnonzero(requesting)
        if index.size == 0:
            return admitted, 0.0
        cost = self._air_cost[index] * increment[index]
        since = self._waiting_since_s[index]
        waited_s = np.where(np.isnan(since), 0.0, now - since)
        priority = remaining[index] + waited_s / parameters.aging_s
        order = np.lexsort((index, -priority, ~self._filling[index]))
        total = np.cumsum(cost[order])
        fits = total <= self._tokens_nl + _AIR_TOLERANCE_NL
        count = index.size if fits.all() else int(np.argmin(fits))
        count = min(count, parameters.max_parallel_fills)
        admitted[index[order[:count]]] = True
        return admitted, float(total[count - 1]) if count else 0.0

    def _update_storm(self, now: float, wind: Optional[float]) -> None:
        if wind is None:
            self._storm.advance(now)
        else:
            self._storm.sample(wind, now)
        self._after_storm()

    def _update_gate(self, dni: Optional[float]) -> bool:
        if dni is None:
            return True
        if self._gate_on and dni < self.parameters.dni_off_w_m2:
            self._gate_on = False
        elif not self._gate_on and dni >= self.parameters.dni_on_w_m2:
            self._gate_on = True
        return self._gate_on

    def _check_step(self, now_s: float, desired_closure: npt.ArrayLike, wind_m_s: Optional[float],
                    dni_w_m2: Optional[float], faulted: Optional[npt.ArrayLike]
                    ) -> tuple[float, FloatArray, Optional[float], Optional[float], BoolArray]:
        now = real_scalar('now_s', now_s)
        last_s = self.earliest_step_s
        if now < last_s:
            raise ValueError(f'now_s must not go backwards: got {now:.3f} s after '
                             f'{last_s:.3f} s')
        desired = self._per_panel('desired_closure', desired_closure, 0.0, 1.0)
        readings: list[Optional[float]] = []
        for name, value, unit in (('wind_m_s', wind_m_s, ' m/s'),
                                  ('dni_w_m2', dni_w_m2, ' W/m2')):
            if value is not None:
                value = real_scalar(name, value)
                in_range(name, np.asarray(value), 0.0, np.inf, unit, high_open=True)
            readings.append(value)
        if faulted is None:
            fault = np.zeros(self._count, dtype=bool)
        else:
            fault = np.asarray(faulted)
            if fault.dtype != np.bool_:
                raise TypeError(f'faulted must be a bool mask, got dtype {fault.dtype}')
            if fault.shape != (self._count,):
                raise ValueError(f'faulted must have shape ({self._count},), '
                                 f'got shape {fault.shape}')
            fault = fault.copy()
        return now, desired, readings[0], readings[1], fault

    def _per_panel(self, name: str, value: npt.ArrayLike, low: float, high: float, unit: str = '',
                   high_open: bool = False) -> FloatArray:
        array = real_array(name, value)
        if array.ndim == 0:
            array = np.full(self._count, float(array))
        elif array.shape != (self._count,):
            raise ValueError(f'{name} must be a scalar or have shape ({self._count},), '
                             f'got shape {array.shape}')
        else:
            array = array.copy()
        return in_range(name, array, low, high, unit, high_open=high_open)

    def _check_zones(self, zones: npt.ArrayLike) -> IntArray:
        array = np.asarray(zones)
        if array.dtype.kind not in 'iu':
            raise TypeError(f'zones must be integer labels, got dtype {array.dtype}')
        if array.shape != (self._count,):
            raise ValueError(f'zones must have shape ({self._count},), got shape {array.shape}')
        return array.copy()

    def _select(self, panels: Optional[npt.ArrayLike], zone: Optional[int],
                everything_if_none: bool) -> BoolArray:
        """Bool mask (N,) of the panels named by ``panels`` or by ``zone``."""
        if panels is not None and zone is not None:
            raise ValueError('give panels or zone, not both')
        if panels is None and zone is None:
            if everything_if_none:
                return np.ones(self._count, dtype=bool)
            raise ValueError('give exactly one of panels and zone')
        if zone is not None:
            if self._zones is None:
                raise ValueError(f'zone={zone!r} given but the scheduler has no zones')
            if isinstance(zone, (bool, np.bool_)) or not isinstance(zone, Integral):
                raise TypeError(f'zone must be an integer label, got {zone!r}')
            mask = self._zones == zone
            if not mask.any():
                raise ValueError(f'zone {zone} has no panels')
            return mask
        array = np.asarray(panels)
        if array.size == 0:
            raise ValueError('panels selects no panel')
        if array.dtype == np.bool_:
            if array.shape != (self._count,):
                raise ValueError(f'panels as a mask must have shape ({self._count},), '
                                 f'got shape {array.shape}')
            return array.copy()
        if array.dtype.kind not in 'iu':
            raise TypeError(f'panels must be integer indices or a bool mask, '
                            f'got dtype {array.dtype}')
        index = array.ravel()
        if index.min() < 0 or index.max() >= self._count:
            raise ValueError(f'panels must be indices in [0, {self._count}), '
                             f'got {index.min()}..{index.max()}')
        mask = np.zeros(self._count, dtype=bool)
        mask[index] = True
        return mask
