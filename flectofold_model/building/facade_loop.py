"""The facade in a building simulation's loop: one call per time step, one transmittance out.

A building simulation (EnergyPlus, :mod:`.energyplus_model`) asks at each of its time steps
what the facade in front of the window lets through. :class:`FacadeInTheLoop` answers the
way the coordinator would decide at that instant: the strategy's desired closures from the
step's sun and weather, through the facade's :class:`~flectofold_model.scheduling.Scheduler`
(storm latch, dwell, deadband, rate limit, daily cap, air bucket and parallel fills), with
extra calls every ``control.period_s`` while moves are under way within the step (as the
annual report steps it); then the beam and diffuse transmittance of the panels at the closures
reached (:mod:`.facade_optics`).

Strategies (:data:`STRATEGIES`): ``scheduled`` (the facade's own controller, the coordinator's
:class:`~flectofold_model.scheduling.FacadeSchedule`), ``predictive`` and ``target rule``
(either controller by name), ``room-aware`` (the predictive controller with the
:class:`~flectofold_model.scheduling.objective.RoomAware` objective: solar gain priced by the
room's cooling or heating at the last step, and the room's daylight and glare at each
candidate closure when they are known), ``threshold`` (the annual report's Al Bahr-like
rule: flat above ``on`` W/m2 of direct sun on the panel, folded below ``off``, run through the
same scheduler),
``always open`` (flat) and ``always closed`` (folded), which never move.

The sun is computed by the project's NREL SPA at the middle of the step, at the weather
file's station (the facade is moved there, keeping its orientation and panels), so that the
shading is the project's own; the simulation's own sun is not used.
"""

import dataclasses
import math
from typing import Callable, cast, Mapping, Optional, Sequence

import numpy as np

from flectofold_model._validate import FloatArray
from flectofold_model.building.facade_optics import (beam_transmittance, diffuse_transmittance,
                                                     effective_transmittance)
from flectofold_model.environment.ephemeris import SunEphemeris
from flectofold_model.environment.sun import Site
from flectofold_model.facade.description import Facade
from flectofold_model.facade.footprint import footprint_weights, representative_panel
from flectofold_model.scheduling.facade_schedule import FacadeSchedule
from flectofold_model.scheduling.objective import RoomAware
from flectofold_model.scheduling.predictive import PredictiveController
from flectofold_model.scheduling.scheduler import Reason
from flectofold_model.shading.ray_casting import SUNLIT_MIN_SZ
from flectofold_model.shading.table import ShadingTable

STRATEGIES = ('scheduled', 'predictive', 'target rule', 'threshold', 'always open',
              'always closed', 'room-aware')
_CONTROLLER = {'predictive': 'predictive', 'target rule': 'target',
               'room-aware': 'predictive'}
_MOVING = (Reason.RATE_LIMITED, Reason.WAITING_FOR_AIR)
#: The room-aware objective's prices of daylight and glare when the room's daylight is known
#: [W/m2] (msg_docs/building.md: how they were chosen).
ROOM_PRICES = {'daylight_value_w_m2': 60.0, 'glare_value_w_m2': 300.0}
#: ``daylight(start_s) -> (daylit, glare)`` of the room at the candidate closures.
RoomDaylight = Callable[[float], tuple[FloatArray, FloatArray]]


@dataclasses.dataclass
class StepResult:
    """What the facade let through over one step, and what it did."""

    transmittance: float
    """The facade's transmittance for the building model: beam and sky diffuse light mixed
    by their irradiance on the window."""
    beam: float
    diffuse: float
    closure: np.ndarray
    """(N,) closures held over the step."""
    sun_up: bool
    """The sun above the horizon at the step's middle."""


class FacadeInTheLoop:
    """One facade, one strategy, stepped by a building simulation's clock.

    Parameters
    ----------
    facade : Facade
    strategy : str
        One of :data:`STRATEGIES`.
    station : Site
        The weather file's station: the facade is moved there (orientation kept).
    start_s : float
        The first step's start [s, UTC Unix time].
    table : ShadingTable, optional
        Shading table of the facade's median panel (built when not given, seconds).
    window_azimuth_deg : float
        Azimuth of the window's outward normal [deg from north, clockwise]; the window is
        vertical. Used to weigh beam against diffuse light (:func:`effective_transmittance`).
    threshold_w_m2 : tuple
        (on, off) of the threshold strategy [W/m2].
    daylight : callable, optional
        ``daylight(start_s) -> (daylit, glare)``, each (K,) over the shading table's
        candidate closures, for the ``room-aware`` strategy
        (:class:`~.daylight.CandidateDaylight`); with it the objective prices daylight and
        glare at ``room_prices``.
    room_prices : dict, optional
        ``daylight_value_w_m2`` and ``glare_value_w_m2`` of
        :class:`~flectofold_model.scheduling.objective.RoomAware` (default
        :data:`ROOM_PRICES`).
    """

    def __init__(self, facade: Facade, strategy: str, station: Site, start_s: float,
                 table: Optional[ShadingTable] = None, window_azimuth_deg: float = 180.0,
                 threshold_w_m2: tuple[float, float] = (250.0, 150.0), gust_factor: float = 1.0,
                 daylight: Optional[RoomDaylight] = None,
                 room_prices: Optional[Mapping[str, float]] = None) -> None:
        if strategy not in STRATEGIES:
            raise ValueError(f'strategy must be one of {", ".join(STRATEGIES)}, got '
                             f'{strategy!r}')
        if not isinstance(station, Site):
            raise TypeError(f'station must be a Site, got {type(station).__name__}')
        control = dict(facade.control)
        if strategy in _CONTROLLER:
            control['controller'] = _CONTROLLER[strategy]
        self.facade = dataclasses.replace(facade, site=station, control=control)
        self.strategy = strategy
        self.table = table if table is not None else ShadingTable(
            representative_panel(self.facade))
        self.diffuse = diffuse_transmittance(self.table)
        self.weights = footprint_weights(self.facade)
        azimuth = math.radians(window_azimuth_deg)
        self.window_normal = np.array([math.sin(azimuth), math.cos(azimuth), 0.0])
        self.on_w_m2, self.off_w_m2 = (float(v) for v in threshold_w_m2)
        self.gust_factor = float(gust_factor)
        self.period_s = float(self.facade.control.get('period_s', 60.0))
        self._shading = np.zeros(len(self.facade), bool)  # the threshold rule's state
        self.schedule: Optional[FacadeSchedule] = None
        if strategy not in ('always open', 'always closed'):
            self.schedule = FacadeSchedule(self.facade, start_s=start_s, table=self.table,
                                           wind_timeout_s=3600.0)
        self.objective: Optional[RoomAware] = None
        self.daylight = daylight
        if strategy == 'room-aware':
            schedule = cast(FacadeSchedule, self.schedule)  # every strategy but always open/closed
            # room-aware runs the predictive controller (_CONTROLLER)
            predictive = cast(PredictiveController, schedule.predictive)
            settings = predictive.parameters
            prices = dict(ROOM_PRICES, **(room_prices or {})) if daylight is not None else {}
            self.objective = RoomAware(settings.view_value_w_m2, self.diffuse, **prices)
            predictive.objective = self.objective
        static = {'always open': 0.0, 'always closed': 1.0}.get(strategy)
        self.closure = np.full(len(self.facade), static if static is not None else
                               self.facade.control.get('default_closure', 0.0))
        self.moves = np.zeros(len(self.facade))
        self.air_nl = 0.0
        self._ephemeris: Optional[SunEphemeris] = None

    def step(self, start_s: float, step_s: float, dni_w_m2: float, dhi_w_m2: float,
             wind_m_s: float, room_w: Sequence[float] = (0.0, 0.0)) -> StepResult:
        """Decide over the step ``[start_s, start_s + step_s)`` [s]; return a StepResult.

        ``dni_w_m2``, ``dhi_w_m2`` the step's direct normal and diffuse horizontal
        irradiance [W/m2], ``wind_m_s`` its mean wind [m/s]; ``room_w`` the room's sensible
        cooling and heating rates at the last step [W] (the ``room-aware`` strategy's).
        """
        if self.objective is not None:
            light = self.daylight(start_s) if self.daylight is not None else (None, None)
            self.objective.observe(room_w[0], room_w[1], 0.5 * dhi_w_m2, *light)
        middle = start_s + step_s / 2.0
        if self._ephemeris is None or self._ephemeris.step_s != step_s:
            self._ephemeris = SunEphemeris(self.facade.site, step_s, batch=1440)
        sun = self._ephemeris.enu([middle])[0]
        up = bool(sun[2] > 0.0)
        if self.schedule is not None:
            self._schedule(start_s, step_s, sun if up else None, dni_w_m2,
                           wind_m_s * self.gust_factor)
        beam = beam_transmittance(self.facade, self.table, self.closure, sun, self.weights) \
            if up else 1.0
        diffuse = float(np.interp(self.closure, self.table.closures, self.diffuse)
                        @ self.weights)
        cosine = max(float(sun @ self.window_normal), 0.0) if up else 0.0
        # ground-reflected light is the building model's to attenuate by ``diffuse`` (its
        # ground reflectance seen through the facade): only the sky's diffuse is mixed here
        on_window_beam = dni_w_m2 * cosine
        on_window_diffuse = 0.5 * dhi_w_m2
        return StepResult(transmittance=effective_transmittance(beam, diffuse, on_window_beam,
                                                                on_window_diffuse),
                          beam=beam, diffuse=diffuse, closure=self.closure.copy(), sun_up=up)

    def _desired(self, sun: FloatArray, dni: float) -> FloatArray:
        """Return the threshold rule's desired closures (controllers decide in the schedule)."""
        in_panels = self.facade.sun_in_panel_frames(sun)
        lit = in_panels[:, 2] > SUNLIT_MIN_SZ
        direct = dni * np.where(lit, in_panels[:, 2], 0.0)
        self._shading = np.where(direct > self.on_w_m2, True,
                                 np.where(direct < self.off_w_m2, False, self._shading))
        return np.where(self._shading, 0.0, 1.0)

    def _schedule(self, start_s: float, step_s: float, sun: Optional[FloatArray], dni: float,
                  wind: float) -> None:
        schedule = cast(FacadeSchedule, self.schedule)  # called only with one
        scheduler = schedule.scheduler
        end = start_s + step_s
        now = start_s
        if self.strategy == 'threshold':
            desired = self._desired(sun, dni) if sun is not None else \
                self._desired(np.array([0.0, 0.0, -1.0]), 0.0)
            call = (lambda t, first: scheduler.step(t, desired, wind_m_s=wind if first
                                                    else None))
        else:
            call = (lambda t, first: schedule.step(
                t, sun, dni_w_m2=dni, wind_m_s=wind if first else None))
        previous = scheduler.commanded_closure.copy()
        moving = np.zeros(previous.size, bool)
        result = call(now, True)
        while True:
            changed = result.closure != previous
            self.moves += changed & ~moving
            moving = changed
            previous = result.closure
            self.air_nl += result.air_used_nl
            due = [math.inf]
            if any(reason in _MOVING for reason in result.reason):
                due.append(now + self.period_s)
            if scheduler.storm_due_s is not None and scheduler.storm_due_s > now:
                due.append(scheduler.storm_due_s)
            if min(due) >= end:
                break
            now = min(due)
            result = call(now, False)
        self.closure = np.asarray(result.closure, dtype=float)
