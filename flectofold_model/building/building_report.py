"""The room behind the facade over a weather file: EnergyPlus, the controller in its loop.

For a facade, a room (:class:`~.energyplus_model.Room`) and an EPW file, each strategy of
:data:`~.facade_loop.STRATEGIES` (and ``no facade``) is one EnergyPlus run of the room
(:func:`~.energyplus_model.shoebox_epjson`). At every EnergyPlus zone time step (10 min)
a callback asks :class:`~.facade_loop.FacadeInTheLoop` for the facade's transmittance over
the step, decided by the same code as the coordinator from the step's sun and the weather
file's own weather (read by :func:`~flectofold_model.environment.read_weather`, interpolated
to the step's middle), and writes it to the facade's ``Schedule:Compact`` through the runtime
actuator; the energies come from EnergyPlus's SQLite output (:func:`~.energyplus_model.run`).
During EnergyPlus's warm-up days (the first day repeated) the facade repeats what it does on
the first day (a copy of the loop run through that day beforehand), as a static schedule
would; the loop itself starts with the run period.

Figures per strategy: cooling, heating and lighting energy per m2 of floor [kWh/m2] (also by
month), peak sensible cooling per m2 of floor [W/m2], solar radiation transmitted by the window
[kWh], the mean transmittance the facade gave over daylight steps, moves per panel and air
[NL]; with ``daylight``, the room's daylight and glare by Radiance (:mod:`.daylight`) at the
closures the facade held each step: sDA, ASE, UDI, glare hours. The ``room-aware`` row then
also prices daylight and glare at each candidate closure (:class:`.daylight.CandidateDaylight`).
"""

import copy
import dataclasses
from dataclasses import dataclass
import math
import os
import tempfile
import time
from typing import Any, Callable, cast, Mapping, Optional, Sequence

import numpy as np

from flectofold_model._validate import BoolArray, FloatArray, PathLike
from flectofold_model.building.daylight import CandidateDaylight, DaylightFigures
from flectofold_model.building.energyplus_model import (GROUND_ALBEDO, GROUND_SCHEDULE,
                                                        IDEAL_LOADS, Room, run, RunPeriod,
                                                        shoebox_epjson)
from flectofold_model.building.facade_loop import FacadeInTheLoop, StepResult, STRATEGIES
from flectofold_model.environment.sun import Site
from flectofold_model.environment.weather import REFERENCE_YEAR, Weather, weather_at
from flectofold_model.facade.description import Facade
from flectofold_model.scheduling.facade_schedule import representative_panel
from flectofold_model.shading.table import ShadingTable

#: The rows of the report: the strategies and the room without a facade.
ROWS = ('no facade',) + tuple(s for s in STRATEGIES if s != 'predictive')
#: The facade's transmittance schedule in the EnergyPlus document.
SCHEDULE = 'FacadeTransmittance'
#: The facade in the EnergyPlus document: 0.05 m before the wall (the panels' standoff of
#: the ray casting), 3 m beyond the room's wall on every side (the facade goes on).
SHADE_OFFSET_M = 0.05
SHADE_MARGIN_M = 3.0
_SECONDS_PER_DAY = 86400.0


@dataclass(frozen=True)
class StrategyRoom:
    """One strategy's room figures over the run period."""

    name: str
    cooling_kwh_m2: float
    heating_kwh_m2: float
    lighting_kwh_m2: float
    peak_cooling_w_m2: float
    transmitted_solar_kwh: float
    window_absorbed_kwh: float
    """Solar radiation the window's glazing absorbs [kWh]."""
    mean_transmittance: float
    """Mean transmittance given over the steps with the sun up (1 without a facade)."""
    moves_per_panel: float
    air_nl: float
    elapsed_s: float
    """Wall-clock time of the run [s] (EnergyPlus and the facade's loop)."""
    transmittance: np.ndarray
    """(S,) the transmittance written at each run-period step, in order (empty: none)."""
    ground_reflectance: np.ndarray
    """(S,) the ground reflectance seen through the facade written at each step."""
    steps: np.ndarray
    """(S,) step of the year of each written value (0: the first 10 min of 1 January)."""
    closure: Optional[np.ndarray] = None
    """(S,) the facade's mean closure over each step (footprint-weighted; empty: none)."""
    monthly_kwh_m2: Optional[dict] = None
    """``cooling``, ``heating``, ``lighting``: (12,) per calendar month [kWh/m2 of floor]."""
    daylight: Optional[DaylightFigures] = None
    """The row's :class:`~.daylight.DaylightFigures` (None: daylight not computed)."""


@dataclass(frozen=True)
class BuildingReport:
    """Every strategy's room over a weather file's dates."""

    facade_name: str
    source: str
    room: Room
    run_period: tuple
    """((begin month, day), (end month, day)), local standard time."""
    rows: tuple

    def figures(self, name: str) -> StrategyRoom:
        """Return the :class:`StrategyRoom` of row ``name``."""
        for row in self.rows:
            if row.name == name:
                return row
        raise KeyError(name)

    def lines(self) -> list[str]:
        """Return the table as text lines, each figure named with its unit."""
        (m0, d0), (m1, d1) = self.run_period
        floor = self.room.width_m * self.room.depth_m
        lines = [f'building report: {self.facade_name} before a {self.room.width_m:g} x '
                 f'{self.room.depth_m:g} x {self.room.height_m:g} m office ({floor:g} m2 floor, '
                 f'window-to-wall {self.room.window_to_wall:g}, facing '
                 f'{self.room.azimuth_deg:g} deg) on {self.source}, {m0:02d}-{d0:02d} to '
                 f'{m1:02d}-{d1:02d}',
                 f'{"":<14}{"cooling":>9}{"heating":>9}{"lighting":>10}{"peak cool":>11}'
                 f'{"solar in":>10}{"mean tau":>10}{"moves":>8}{"air":>9}{"run":>7}',
                 f'{"":<14}{"[kWh/m2]":>9}{"[kWh/m2]":>9}{"[kWh/m2]":>10}{"[W/m2]":>11}'
                 f'{"[kWh]":>10}{"[-]":>10}{"/panel":>8}{"[NL]":>9}{"[s]":>7}']
        for r in self.rows:
            lines.append(f'{r.name:<14}{r.cooling_kwh_m2:>9.2f}{r.heating_kwh_m2:>9.2f}'
                         f'{r.lighting_kwh_m2:>10.2f}{r.peak_cooling_w_m2:>11.1f}'
                         f'{r.transmitted_solar_kwh:>10.1f}{r.mean_transmittance:>10.3f}'
                         f'{r.moves_per_panel:>8.1f}{r.air_nl:>9.0f}{r.elapsed_s:>7.0f}')
        lines += [
            'cooling, heating: ideal loads, sensible, per m2 of floor; lighting: daylight-'
            'dimmed electric light; peak cool: the largest 10-min sensible cooling rate per m2',
            'solar in: solar radiation the window transmits into the room; mean tau: the '
            "facade's transmittance over the steps with the sun up (beam and diffuse mixed "
            'by irradiance); moves, air: as in the annual report']
        lit = [r for r in self.rows if r.daylight is not None]
        if lit:
            office_hours = cast(DaylightFigures, lit[0].daylight).office_hours
            lines += [f'daylight and glare, Radiance, {office_hours} office '
                      'hours (08-18 local standard time)',
                      f'{"":<14}{"sDA300":>8}{"ASE1000":>9}{"UDI":>7}{"<100":>7}{"> 2000":>8}'
                      f'{"mean E":>8}{"glare":>7}{"GA":>7}{"sun seen":>10}',
                      f'{"":<14}{"[%]":>8}{"[%]":>9}{"[%]":>7}{"[%]":>7}{"[%]":>8}'
                      f'{"[lx]":>8}{"[h]":>7}{"[%]":>7}{"[h]":>10}']
            for r in lit:
                d = cast(DaylightFigures, r.daylight)
                lines.append(f'{r.name:<14}{100 * d.sda:>8.1f}{100 * d.ase:>9.1f}'
                             f'{100 * d.udi:>7.1f}{100 * d.udi_short:>7.1f}'
                             f'{100 * d.udi_exceeded:>8.1f}{d.mean_lx:>8.0f}'
                             f'{d.glare_hours:>7d}{100 * d.glare_autonomy:>7.1f}'
                             f'{d.sun_in_view_hours:>10d}')
            lines += ["sDA300/50% and ASE1000,250h after IES LM-83 (ASE with the row's own "
                      'facade), UDI 100-2000 lx and its shares below and above; glare: hours '
                      'with DGP >= 0.40 at a seated eye 2 m from the window facing it, GA its '
                      "glare autonomy (hours below); sun seen: hours the sun's disc is in "
                      'that view']
        return lines


def building_report(facade: Facade, weather: Weather, epw_path: PathLike, room: Room = Room(),
                    run_period: RunPeriod = ((1, 1), (12, 31)), rows: Sequence[str] = ROWS,
                    table: Optional[ShadingTable] = None, workdir: Optional[PathLike] = None,
                    progress: Optional[Callable[[str], None]] = None,
                    sky_diffuse: str = 'DetailedSkyDiffuseModeling',
                    daylight: Optional[Mapping[str, Any]] = None) -> BuildingReport:
    """Run the room behind ``facade`` under each row's strategy; see the module doc.

    ``weather`` is ``epw_path`` read by :func:`~flectofold_model.environment.read_weather`
    (the controller's weather); ``run_period`` ((month, day), (month, day)) inclusive, local
    standard time; ``workdir`` keeps the EnergyPlus outputs (one folder per row; a temporary
    folder when not given). ``daylight``: ``None`` for no daylight, or the keyword arguments
    of :class:`~.daylight.DaylightModel` (``{}`` for its defaults) to add each row's daylight
    and glare by Radiance, at the closures the row's facade held each step.
    """
    say = progress or (lambda text: None)
    if not isinstance(weather, Weather):
        raise TypeError(f'weather must be a Weather, got {type(weather).__name__}')
    if not isinstance(room, Room):
        raise TypeError(f'room must be a Room, got {type(room).__name__}')
    unknown = [r for r in rows if r not in ROWS and r not in ('predictive', 'room-aware')]
    if unknown:
        raise ValueError(f'unknown rows {unknown}; known: {", ".join(ROWS)}, predictive')
    station = Site(weather.latitude_deg, weather.longitude_deg, weather.altitude_m)
    if table is None:
        say('shading table of the median panel (about 7 s)')
        table = ShadingTable(representative_panel(facade))
    floor_m2 = room.width_m * room.depth_m
    light = None if daylight is None else _Daylight(facade, room, epw_path, daylight, say)
    results = []
    with tempfile.TemporaryDirectory() as scratch:
        base = workdir or scratch
        for name in rows:
            say(f'{name}: EnergyPlus over {run_period[0]} to {run_period[1]}')
            started = time.perf_counter()
            outdir = os.path.join(base, name.replace(' ', '_'))
            if name == 'no facade':
                figures = run(shoebox_epjson(room, SCHEDULE, shade=False, run_period=run_period,
                                             sky_diffuse=sky_diffuse), epw_path, outdir)
                callback = None
                loop = None
            else:
                candidates = None
                if name == 'room-aware' and light is not None:
                    candidates = light.candidates(table.closures)
                loop = FacadeInTheLoop(facade, name, station, _start_s(weather, run_period),
                                       table=table, window_azimuth_deg=room.azimuth_deg,
                                       daylight=candidates)
                callback = LoopCallback(loop, weather, SCHEDULE, _start_s(weather, run_period))
                figures = run(shoebox_epjson(room, SCHEDULE, run_period=run_period,
                                             sky_diffuse=sky_diffuse,
                                             shade_offset_m=SHADE_OFFSET_M,
                                             shade_margin_m=SHADE_MARGIN_M), epw_path,
                              outdir, callback=callback)
            floor_monthly = {k: v / floor_m2 for k, v in figures.monthly_kwh.items()}
            results.append(StrategyRoom(
                name=name, cooling_kwh_m2=figures.cooling_kwh / floor_m2,
                heating_kwh_m2=figures.heating_kwh / floor_m2,
                lighting_kwh_m2=figures.lighting_kwh / floor_m2,
                peak_cooling_w_m2=figures.peak_cooling_w / floor_m2,
                transmitted_solar_kwh=figures.transmitted_solar_kwh,
                window_absorbed_kwh=figures.window_absorbed_kwh,
                mean_transmittance=1.0 if callback is None else callback.mean_daylight(),
                moves_per_panel=0.0 if loop is None else float(loop.moves.mean()),
                air_nl=0.0 if loop is None else loop.air_nl + _static_air(name, facade),
                elapsed_s=time.perf_counter() - started,
                transmittance=np.array(callback.written if callback else []),
                ground_reflectance=np.array(callback.ground if callback else []),
                steps=np.array(callback.index if callback else [], dtype=np.int64),
                closure=np.array(callback.closure if callback else []),
                monthly_kwh_m2=floor_monthly))
    if light is not None:
        results = [dataclasses.replace(row, daylight=light.figures(row, run_period))
                   for row in results]
    return BuildingReport(facade_name=facade.name, source=weather.source, room=room,
                          run_period=tuple(run_period), rows=tuple(results))


class _Daylight:
    """The rows' daylight by Radiance: one matrix model with the facade, one without."""

    def __init__(self, facade: Facade, room: Room, epw_path: PathLike, options: Mapping[str, Any],
                 say: Callable[[str], None]) -> None:
        from flectofold_model.building import daylight
        self.daylight = daylight
        say('daylight: sky and sun of every hour (gendaymtx)')
        self.skies = daylight.read_skies(epw_path)
        self.models = {'facade': daylight.DaylightModel(room, facade, progress=say, **options),
                       'bare': daylight.DaylightModel(room, None, progress=say, **options)}
        self.say = say

    def candidates(self, closures: FloatArray) -> CandidateDaylight:
        """Return the room-aware objective's :class:`~.daylight.CandidateDaylight`."""
        self.say('daylight: every closure state, for the room-aware objective')
        return self.daylight.CandidateDaylight(self.models['facade'], self.skies, closures)

    def figures(self, row: StrategyRoom, run_period: RunPeriod) -> DaylightFigures:
        """Return the row's :class:`~.daylight.DaylightFigures` at the closures it held."""
        if row.name == 'no facade':
            period = period_hours(run_period)
            year = self.models['bare'].year(self.skies,
                                            np.where(period[:, None], 1.0, np.nan))
        else:
            model = self.models['facade']
            self.say(f'daylight: {row.name}')
            year = model.year(self.skies, self.daylight.hourly_weights(
                model.states, row.steps, cast(np.ndarray, row.closure)))
        return self.daylight.daylight_figures(year)


def period_hours(run_period: RunPeriod) -> BoolArray:
    """(8760,) bool: the hours of the year within ``run_period`` (inclusive dates)."""
    days = np.cumsum((0, 31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30))
    (m0, d0), (m1, d1) = run_period
    first, last = days[m0 - 1] + d0 - 1, days[m1 - 1] + d1 - 1
    day = np.arange(8760) // 24
    return (day >= first) & (day <= last)


class LoopCallback:
    """The EnergyPlus callback that runs the facade's loop and actuates its transmittance.

    EnergyPlus calls it at the start of every zone time step; its clock is the weather
    file's local standard time, the step ``[hour + (k - 1) dt, hour + k dt)`` of day
    ``month/day`` (``k`` the zone time step number, ``dt`` the zone time step).
    """

    def __init__(self, loop: FacadeInTheLoop, weather: Weather, schedule_name: str, start_s: float,
                 step_s: float = 600.0) -> None:
        self.loop = loop
        self.weather = weather
        self.schedule_name = schedule_name
        self.handle: Optional[int] = None
        self.ground_handle: Optional[int] = None
        self.load_handles: Optional[list[int]] = None
        self.written: list[float] = []
        """Transmittance written at each run-period step, in order."""
        self.sun_up: list[bool] = []
        self.closure: list[float] = []
        """The facade's footprint-weighted mean closure over each run-period step."""
        self.ground: list[float] = []
        """Ground reflectance written at each run-period step, in order."""
        self.index: list[int] = []
        """Step of the year (0 = the first 10 minutes of 1 January) of each written value."""
        # the first day, by a copy of the loop, for EnergyPlus's warm-up days
        self._step_s = step_s
        preview = copy.deepcopy(loop)
        self._first_day = [self._step(preview, start_s + k * step_s, step_s)
                           for k in range(int(round(86400.0 / step_s)))]

    def __call__(self, api: Any, state: Any) -> None:
        """Set the facade's transmittance for the step that starts now."""
        exchange = api.exchange
        if not exchange.api_data_fully_ready(state):
            return
        if self.handle is None:
            self.handle = exchange.get_actuator_handle(state, 'Schedule:Compact',
                                                       'Schedule Value', self.schedule_name)
            self.ground_handle = exchange.get_actuator_handle(
                state, 'Schedule:Compact', 'Schedule Value', GROUND_SCHEDULE)
            if self.handle < 0 or self.ground_handle < 0:
                raise RuntimeError(f'no Schedule:Compact actuators named '
                                   f'{self.schedule_name!r} and {GROUND_SCHEDULE!r}')
            self.load_handles = [exchange.get_variable_handle(
                state, f'Zone Ideal Loads Zone Sensible {kind} Rate', IDEAL_LOADS)
                for kind in ('Cooling', 'Heating')]
        step_h = exchange.zone_time_step(state)
        step_s = step_h * 3600.0
        if abs(step_s - self._step_s) > 1e-6:
            raise RuntimeError(f'the zone time step is {step_s:g} s, the loop was made for '
                               f'{self._step_s:g} s')
        in_day = exchange.hour(state) * int(round(3600.0 / step_s)) \
            + exchange.zone_time_step_number(state) - 1
        if exchange.warmup_flag(state):
            result = self._first_day[in_day]
            exchange.set_actuator_value(state, self.handle, result.transmittance)
            exchange.set_actuator_value(state, self.ground_handle,
                                        GROUND_ALBEDO * result.diffuse)
            return
        local_h = in_day * step_h
        start_s = _epoch_s(exchange.month(state), exchange.day_of_month(state), local_h,
                           self.weather.utc_offset_h)
        room = tuple(exchange.get_variable_value(state, h) if h >= 0 else 0.0
                     for h in cast(list[int], self.load_handles))  # set on the first call
        result = self._step(self.loop, start_s, step_s, room)
        self.index.append((exchange.day_of_year(state) - 1) * int(round(86400.0 / step_s))
                          + in_day)
        exchange.set_actuator_value(state, self.handle, result.transmittance)
        exchange.set_actuator_value(state, self.ground_handle, GROUND_ALBEDO * result.diffuse)
        self.written.append(result.transmittance)
        self.ground.append(GROUND_ALBEDO * result.diffuse)
        self.sun_up.append(result.sun_up)
        self.closure.append(float(result.closure @ self.loop.weights))

    def _step(self, loop: FacadeInTheLoop, start_s: float, step_s: float,
              room: Sequence[float] = (0.0, 0.0)) -> StepResult:
        middle = np.array([np.datetime64(int(round((start_s + step_s / 2) * 1e9)), 'ns')])
        sampled = weather_at(self.weather, middle)
        return loop.step(start_s, step_s, float(sampled['dni_w_m2'][0]),
                         float(sampled['dhi_w_m2'][0]), float(sampled['wind_speed_m_s'][0]),
                         room)

    def mean_daylight(self) -> float:
        """Mean transmittance written over the steps with the sun up."""
        written = np.array(self.written)[np.array(self.sun_up, dtype=bool)]
        return float(written.mean()) if written.size else math.nan


def _epoch_s(month: int, day: int, local_h: float, utc_offset_h: float) -> float:
    date = np.datetime64(f'{REFERENCE_YEAR}-{month:02d}-{day:02d}', 's')
    return float(date.astype(np.int64)) + (local_h - utc_offset_h) * 3600.0


def _start_s(weather: Weather, run_period: RunPeriod) -> float:
    (month, day), _ = run_period
    return _epoch_s(month, day, 0.0, weather.utc_offset_h)


def _static_air(name: str, facade: Facade) -> float:
    from flectofold_model.scheduling.facade_schedule import full_close_air_nl
    return float(np.sum(full_close_air_nl(facade))) if name == 'always closed' else 0.0
