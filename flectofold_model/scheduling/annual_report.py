"""A facade over a weather file's dates: direct sun blocked, view, moves, storms and air.

The day report (:mod:`.day_report`) judges one clear-sky day; designers judge shading over a
year of measured or typical weather [1]_ [2]_. For a facade and a date range of a weather
file (:func:`~flectofold_model.environment.read_weather`), every ``step_min`` minutes (the
file's hour by default) :func:`annual_report` takes:

1. the file's weather at the middle of the step (:func:`~.weather.weather_at`: the file's own
   rows on hourly steps) and the sun then, seen from the **file's station** (NREL SPA); the
   facade keeps its own orientation and panels;
2. each panel's direct irradiance on its plane, ``DNI max(cos theta, 0)`` [W/m2], ``theta``
   the angle of incidence on the panel (sun in the panel frame); zero with the sun below the
   horizon;
3. the blocked fraction of that direct sun at every candidate closure, from the shading
   table of the facade's median panel (:class:`~.table.ShadingTable`, as the coordinator
   uses, within about 0.01 of ray casting), and the view fraction of each closure;
4. the commanded closures of four strategies (:data:`STRATEGIES`), then the figures of
   :class:`StrategyFigures`.

Strategies
----------
scheduled
    Ours: the coordinator's rule (the most view that blocks ``shading_target`` of the direct
    sun over the look-ahead window; ``default_closure`` while the DNI gate is off) through
    the :class:`~.scheduler.Scheduler` with the facade's limits, storm latch and air budget.
threshold
    A threshold-tracking controller modelled after the published description of the Al Bahr
    Towers' mashrabiya [3]_ (units unfold to shade when the sun strikes their face and fold
    away when it leaves): a panel goes to its shading position (closure 0, flat) when the
    direct irradiance on its plane exceeds ``threshold_on_w_m2`` and back to view (closure
    1) when it falls below ``threshold_off_w_m2`` (hysteresis; in between it keeps its
    state). The thresholds are ours, not published. It runs through the same scheduler (rate
    limit, dwell, daily cap, air budget, storm latch) without the DNI gate.
always open, always closed
    The day report's static baselines: closure 0 (flat, covering the footprint) and closure
    1 (folded); they never move, also not in a storm.

Closure and light (as in the day report): an **open** (flat) Flectofold panel covers its
footprint and blocks nearly all direct sun; a **closed** (folded) one uncovers most of it and
gives the view.

How the scheduler is stepped: each step's decision is made at the step's start; moves it
starts (rate-limited, waiting for air, at most ``max_parallel_fills`` at once) and storm
latch changes due within the step are followed by extra calls every ``period_s`` (the
coordinator's period) until they are done, so a coarse step does not hold 36 panels in a
six-at-a-time queue for hours. The closure reached then holds for the step's shading. The
hourly wind of the file, times ``gust_factor``, is the storm latch's sample for the step
(held until the next).

References
----------
.. [1] US DOE, EnergyPlus Weather File (EPW) Data Dictionary.
.. [2] Wilcox, S. and Marion, W., "Users Manual for TMY3 Data Sets", NREL/TP-581-43156, 2008.
.. [3] Karanouh, A. and Kerber, E., "Innovations in dynamic architecture: The Al-Bahr Towers
   design and delivery of complex facades", Journal of Facade Design and Engineering 3 (2015)
   185-221, doi:10.3233/FDE-150040.
"""

import dataclasses
from dataclasses import dataclass
import math
import re
from typing import Callable, cast, Mapping, Optional, TYPE_CHECKING, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, IntArray, PathLike
from flectofold_model.environment.clear_sky import clear_sky_dni
from flectofold_model.environment.sun import Site, solar_position
from flectofold_model.environment.weather import (into_reference_year, REFERENCE_YEAR,
                                                  site_distance_deg, Weather, weather_at)
from flectofold_model.facade.footprint import footprint_weights, representative_panel
from flectofold_model.scheduling.day_report import CANDIDATE_CLOSURES, interpolate
from flectofold_model.scheduling.facade_schedule import full_close_air_nl, scheduler_parameters
from flectofold_model.scheduling.frontier import (ClosureProblem, frontier, Limit, limit_at,
                                                  Limits, Point)
from flectofold_model.scheduling.predictive import DEFAULT_CONTROLLER, PlanInputs
from flectofold_model.scheduling.report_common import (limit_gaps, OTHER_ROW,
                                                       predictive_desired)
from flectofold_model.scheduling.scheduler import (Reason, Scheduler, ScheduleResult,
                                                   SchedulerParameters)
from flectofold_model.shading.ray_casting import choose_candidate, SUNLIT_MIN_SZ
from flectofold_model.shading.table import ShadingTable

if TYPE_CHECKING:  # the facade's and matplotlib's modules load when used
    from matplotlib.axes import Axes

    from flectofold_model.facade.description import Facade

#: The rows of the report with the default controller (``target rule`` becomes
#: ``predictive`` on a facade that runs the target rule).
STRATEGIES = ('scheduled', 'target rule', 'threshold', 'always open', 'always closed', 'limit')
#: The threshold family: ``on`` thresholds [W/m2] and ``off / on`` ratios swept.
THRESHOLD_ON_W_M2 = (100.0, 200.0, 300.0, 400.0, 500.0)
THRESHOLD_OFF_RATIOS = (0.5, 0.8)
#: The target rule's family: ``shading_target`` swept.
SHADING_TARGETS = (0.5, 0.7, 0.8, 0.9, 0.95, 0.99)
#: A panel counts toward the view hours while its view fraction is at least this [-]; the
#: folded demonstrator module reaches 0.79, the flat one 0.
VIEW_LEVEL = 0.5
#: Time steps accepted [min]: divisors of the hour, 10 min or more (a year at 10 min holds
#: 52,560 steps of the (T, N, 11) blocked-fraction table, about 170 MB for 36 panels).
STEPS_MIN = (10, 12, 15, 20, 30, 60)
#: Ground reflectance for the diffuse figure (the usual default of 0.2).
GROUND_ALBEDO = 0.2
DAYS_PER_YEAR = 365.0
_MOVING = (Reason.RATE_LIMITED, Reason.WAITING_FOR_AIR)
_NUMBERS = (int, float, np.integer, np.floating)
_DATE = re.compile(r'^(?:\d{4}-)?(\d{2})-(\d{2})$')
#: A strategy's desired closures: (T, N), or ``desired(i, commanded_closure)`` (N,).
_Desired = Union[FloatArray, Callable[[int, FloatArray], FloatArray]]


class AnnualReportError(ValueError):
    """An annual report that cannot be made: bad dates, a range outside the file, a bad step."""


@dataclass(frozen=True)
class StrategyFigures:
    """What one strategy achieved over the range; energies per m2 of panel footprint."""

    name: str
    blocked_direct_kwh_m2: float
    """Direct sun on the panels' planes that the panels blocked [kWh/m2]."""
    blocked_direct_fraction: float
    """``blocked_direct_kwh_m2`` over the incident direct energy [-]."""
    view_hours_h: float
    """Daylight hours a panel's view fraction is at least :data:`VIEW_LEVEL`, mean over
    panels [h]."""
    view_weighted_hours_h: float
    """Daylight hours weighted by the view fraction, mean over panels: hours of full view
    [h]."""
    actuations_per_panel: float
    """Moves a panel started in the range, mean over panels."""
    actuations_per_panel_year: float
    """The same scaled to 365 days."""
    air_nl: float
    """Free air spent on closing moves [NL]; the static baselines: none, or one full close
    of every panel for always closed (as the day report)."""
    storm_closure: float
    """Mean commanded closure over the steps the storm latch was set (NaN without storm)."""
    monthly_blocked_kwh_m2: np.ndarray
    """(12,) blocked direct energy by local month [kWh/m2]."""
    monthly_actuations_per_panel: np.ndarray
    """(12,) moves started by local month, mean over panels."""


@dataclass(frozen=True)
class AnnualReport:
    """A facade over a weather file's date range, with four strategies."""

    facade_name: str
    source: str
    first_date: str
    """Local (standard time) date of the range's first day, year of the file ignored."""
    last_date: str
    step_s: float
    range_days: float
    daylight_h: float
    """Hours with the sun above the horizon."""
    incident_direct_kwh_m2: float
    """Direct sun on the panels' planes, ``DNI cos(theta) dt`` summed, mean over panels
    [kWh/m2]."""
    incident_diffuse_kwh_m2: float
    """Diffuse sky (isotropic) and ground-reflected light on the panels' planes [kWh/m2]."""
    monthly_incident_kwh_m2: np.ndarray
    storm_wind_h: float
    """Hours the file's wind times ``gust_factor`` exceeds ``wind_on_m_s``."""
    storm_latched_h: float
    """Hours the scheduled strategy's storm latch was set."""
    wind_on_m_s: float
    gust_factor: float
    storm_position: float
    daily_move_cap: int
    cycle_budget_per_year: float
    """``daily_move_cap x 365`` moves per panel and year (an assumption, see the docs)."""
    threshold_w_m2: tuple[float, float]
    """(on, off) irradiance thresholds of the threshold strategy [W/m2]."""
    months: np.ndarray
    """(12,) bool: local months the range touches."""
    site_offset_deg: float
    """Great-circle distance between the facade's site and the file's station [deg]."""
    strategies: tuple[StrategyFigures, ...]
    """:class:`StrategyFigures` of scheduled, the other controller, threshold, always open,
    always closed and the limit (its view the limit's upper bound at scheduled's
    blocking)."""
    controller: str = DEFAULT_CONTROLLER
    """The facade's controller, run as ``scheduled``."""
    limit: Optional[Limit] = None
    """The :class:`~.frontier.Limit` at scheduled's blocking, with the scheduler's limits."""
    gaps: Optional[dict[str, tuple[float, ...]]] = None
    """Per strategy, (view-weighted hours it gives up against the limit with the
    scheduler's limits at its own blocking, the same against the limit without move
    limits) [h]."""
    families: tuple['FamilyMember', ...] = ()
    """:class:`FamilyMember` runs of the threshold family and the target rule's."""
    frontier_free: tuple[Point, ...] = ()
    """Supported points (:class:`~.frontier.Point`) of the limit without move limits."""
    frontier_limited: tuple[Point, ...] = ()
    """Supported points of the limit with the scheduler's limits."""

    def figures(self, name: str) -> StrategyFigures:
        """Return the :class:`StrategyFigures` of strategy ``name``."""
        for strategy in self.strategies:
            if strategy.name == name:
                return strategy
        raise KeyError(name)

    def lines(self) -> list[str]:
        """Return the summary as text lines, each figure named with its unit."""
        lines = [f'annual report: {self.facade_name} on {self.source}, local dates '
                 f'{self.first_date} to {self.last_date} ({self.range_days:.0f} days, '
                 f'step {self.step_s / 60:.0f} min)',
                 f'sun above the horizon {self.daylight_h:.0f} h; on the panel planes: direct '
                 f'{self.incident_direct_kwh_m2:.1f} kWh/m2, diffuse sky + ground '
                 f'{self.incident_diffuse_kwh_m2:.1f} kWh/m2',
                 f'storm: wind x {self.gust_factor:g} above {self.wind_on_m_s:g} m/s for '
                 f'{self.storm_wind_h:.0f} h; storm latch set {self.storm_latched_h:.1f} h '
                 f'(panels then at closure {self.storm_position:g}, vented flat)']
        if self.site_offset_deg > 1.0:
            lines.append(f'note: the station of the file is {self.site_offset_deg:.1f} deg '
                         'from the site of the facade; the sun is seen from the station')
        lines.append(f'{"":<14}{"blocked direct":>15}{"blocked":>9}{"view":>8}'
                     f'{"view-wtd":>10}{"moves":>8}{"moves/yr":>10}{"budget":>8}'
                     f'{"air":>10}{"storm":>7}{"gap":>8}{"gap":>8}{"gap free":>10}')
        lines.append(f'{"":<14}{"[kWh/m2]":>15}{"[-]":>9}{"[h]":>8}{"[h]":>10}'
                     f'{"/panel":>8}{"/panel":>10}{"used":>8}{"[NL]":>10}{"clos.":>7}'
                     f'{"[h]":>8}{"[%]":>8}{"[h]":>10}')
        for s in self.strategies:
            storm = '-' if math.isnan(s.storm_closure) else f'{s.storm_closure:.2f}'
            limited, free = (self.gaps or {}).get(s.name, (math.nan, math.nan))
            share = limited / (s.view_weighted_hours_h + limited) if limited == limited \
                and s.view_weighted_hours_h + limited > 0 else math.nan
            lines.append(f'{s.name:<14}{s.blocked_direct_kwh_m2:>15.1f}'
                         f'{s.blocked_direct_fraction:>9.3f}{s.view_hours_h:>8.0f}'
                         f'{s.view_weighted_hours_h:>10.0f}{s.actuations_per_panel:>8.0f}'
                         f'{s.actuations_per_panel_year:>10.0f}'
                         f'{s.actuations_per_panel_year / self.cycle_budget_per_year:>8.1%}'
                         f'{s.air_nl:>10.0f}{storm:>7}{_number(limited, 8, 0)}'
                         f'{_number(100 * share, 8, 1)}{_number(free, 10, 0)}')
        lines.extend(self.limit_lines())
        lines.extend(self.family_lines())
        lines.extend(self.legend())
        return lines

    def limit_lines(self) -> list[str]:
        """Return the lines that say how exactly the limit is known and what it needed."""
        if self.limit is None:
            return []
        limit = self.limit
        return [f"limit: with the whole weather known and the scheduler's limits, at "
                f'{limit.blocked_direct_kwh_m2:.1f} kWh/m2 blocked no schedule keeps more '
                f'than {limit.view_weighted_upper_h:.1f} h of weighted view; one that keeps '
                f'{limit.view_weighted_lower_h:.1f} h is shown (bracket {limit.width_h:.2f} h,'
                f' {limit.evaluations} values of view tried); its schedule would exceed the '
                f'air bucket in {limit.air_bound_exceeded_steps} steps (relaxed)']

    def family_lines(self) -> list[str]:
        """Return a line per family: its best member at scheduled's blocking, dominance."""
        if not self.families:
            return []
        scheduled = self.figures('scheduled')
        lines = []
        for family in ('threshold', 'target rule'):
            members = [m for m in self.families if m.family == family]
            if not members:
                continue
            dominating = [m.label for m in members if _dominates(m.figures, scheduled)]
            enough = [m for m in members
                      if m.figures.blocked_direct_kwh_m2 >= scheduled.blocked_direct_kwh_m2]
            best = max(enough, key=lambda m: m.figures.view_weighted_hours_h, default=None)
            lines.append(
                f'{family} family ({len(members)} members): '
                + (f'most view blocking at least as much as scheduled: {best.label}, '
                   f'{best.figures.view_weighted_hours_h:.0f} h, '
                   f'{best.figures.actuations_per_panel_year:.0f} moves/yr; ' if best
                   else 'none blocks as much as scheduled; ')
                + ('dominating scheduled: ' + (', '.join(dominating) or 'none')))
        return lines

    def legend(self) -> list[str]:
        """Return the lines that explain each column of :meth:`lines`."""
        on, off = self.threshold_w_m2
        return [
            'blocked direct: direct sun on the panel planes (DNI x cos incidence x dt) the '
            'panels blocked, per m2 of footprint; blocked: its share of the incident direct',
            f'view: daylight hours with view fraction >= {VIEW_LEVEL:g}; view-wtd: daylight '
            'hours x view fraction (hours of full view); both mean per panel',
            f'moves: moves a panel started; moves/yr: scaled to 365 days; budget used: of '
            f'{self.cycle_budget_per_year:.0f} moves/panel/yr ({self.daily_move_cap} a day, '
            'an assumed budget: no hinge fatigue life is published)',
            'air: free air of closing moves [normal litres]; storm clos.: mean closure while '
            'the storm latch was set (0 open/flat .. 1 closed/folded)',
            "gap: view-wtd hours given up against the limit with the scheduler's limits at "
            'the same blocking ([%] of the limit; negative only for the static baselines, '
            'which ignore the storm latch the limit obeys); gap free: the same against the '
            'limit without move limits',
            f"strategies: scheduled (the facade's controller, {self.controller}), "
            'predictive / target rule (the other controller), threshold (Al Bahr-like: flat '
            f'above {on:g} W/m2 direct on the panel, folded below {off:g}), always open '
            '(flat), always closed (folded), limit (the clairvoyant optimum within the '
            "scheduler's limits at scheduled's blocking)"]


def annual_report(facade: 'Facade', weather: Weather, first_date: Optional[str] = None,
                  last_date: Optional[str] = None, step_min: float = 60,
                  table: Optional[ShadingTable] = None, gust_factor: float = 1.0,
                  threshold_on_w_m2: float = 250.0, threshold_off_w_m2: float = 150.0,
                  progress: Optional[Callable[[str], None]] = None,
                  families: bool = True) -> AnnualReport:
    """Run ``facade`` through a weather file's dates under four strategies; see the module doc.

    Parameters
    ----------
    facade : Facade
        Quad or hexagonal panels; its ``control`` section sets the scheduler.
    weather : Weather
        From :func:`~flectofold_model.environment.read_weather`.
    first_date, last_date : str, optional
        Local dates (the file's standard time) 'YYYY-MM-DD' or 'MM-DD', both included; the
        year is ignored (a weather file is one reference year). Default: the file's first
        and last day.
    step_min : int
        Time step [min], one of :data:`STEPS_MIN`.
    table : ShadingTable, optional
        Shading table of the facade's panels over :data:`.day_report.CANDIDATE_CLOSURES`;
        built for the median panel when not given (about 7 s).
    gust_factor : float
        Factor from the file's hourly mean wind to the storm latch's gust, in [1, 3].
    threshold_on_w_m2, threshold_off_w_m2 : float
        Thresholds of the threshold strategy [W/m2], ``on > off >= 0``.
    progress : callable, optional
        Called with a line of text as each stage starts.
    families : bool
        Also run the threshold family (:data:`THRESHOLD_ON_W_M2` x
        :data:`THRESHOLD_OFF_RATIOS`) and the target rule's (:data:`SHADING_TARGETS`),
        about 1.5 s each for the demonstrator's year.

    Raises
    ------
    AnnualReportError
        For a bad step, dates that cannot be read, a range the file does not cover, or a
        bad option; TypeError for a facade or weather of the wrong type.
    """
    say = progress or (lambda text: None)
    families_wanted = bool(families)
    if not isinstance(weather, Weather):
        raise TypeError(f'weather must be a Weather, got {type(weather).__name__}')
    step_s = _step_s(step_min)
    _check_options(gust_factor, threshold_on_w_m2, threshold_off_w_m2)
    start, count, first, last = _range(weather, first_date, last_date, step_s)
    step = np.timedelta64(int(step_s), 's')
    middles = start + step / 2 + np.arange(count) * step
    epochs = middles.astype('datetime64[ns]').astype(np.int64) / 1e9
    sampled = weather_at(weather, middles)
    site = Site(weather.latitude_deg, weather.longitude_deg, weather.altitude_m)
    say(f'sun: {count} steps at {site.latitude_deg:.2f} deg, {site.longitude_deg:.2f} deg')
    position = solar_position(epochs, site)
    sun_panel = facade.sun_in_panel_frames(position.enu)
    sunlit = (sun_panel[..., 2] > SUNLIT_MIN_SZ) & position.above_horizon[:, None]
    direct = sampled['dni_w_m2'][:, None] * np.where(sunlit, sun_panel[..., 2], 0.0)
    if table is None:
        say('shading table of the median panel (about 7 s)')
        table = ShadingTable(representative_panel(facade), closures=CANDIDATE_CLOSURES)
    _check_table(table)
    blocked = table.blocked_fractions(sun_panel.reshape(-1, 3)).reshape(
        sun_panel.shape[:2] + (table.closures.size,)) * sunlit[..., None]
    context = _Context(facade=facade, step_s=step_s, epochs=epochs, middles=middles,
                       direct=direct, blocked=blocked, view=table.view,
                       daylight=position.above_horizon, weights=footprint_weights(facade),
                       months=_local_months(middles, weather.utc_offset_h))
    parameters = scheduler_parameters(facade)
    wind = sampled['wind_speed_m_s'] * gust_factor
    problem = ClosureProblem(
        closures=CANDIDATE_CLOSURES, direct_w_m2=direct, blocked=blocked, view=table.view,
        daylight=position.above_horizon, step_s=step_s, start_s=epochs - step_s / 2.0,
        weights=context.weights, air_nl=full_close_air_nl(facade))
    controller = facade.control.get('controller', DEFAULT_CONTROLLER)
    clear = clear_sky_dni(epochs, site)
    inputs = PlanInputs(cos_incidence=np.where(sunlit, sun_panel[..., 2], 0.0),
                        blocked=blocked, daylight=position.above_horizon,
                        clear_dni_w_m2=clear, step_h=np.full(count, step_s / 3600.0))
    target_desired = _desired(facade, blocked, table.view, sunlit, step_s)
    controllers: dict[str, tuple[Callable[[], _Desired], Optional[FloatArray]]] = {
        'predictive': (lambda: predictive_desired(facade, table, inputs, sampled['dni_w_m2'],
                                                  step_s, parameters), None),
        'target': (lambda: target_desired, sampled['dni_w_m2'])}
    other = 'target' if controller == 'predictive' else 'predictive'
    strategies, runs = [], {}
    for name, make, dni in (
            ('scheduled', *controllers[controller]),
            (OTHER_ROW[other], *controllers[other]),
            ('threshold', lambda: _threshold_desired(direct, threshold_on_w_m2,
                                                     threshold_off_w_m2), None)):
        say(f'{name}: scheduler over {count} steps')
        runs[name] = _run_scheduler(context, parameters, make(), dni, wind,
                                    lambda share: say(f'{name}: {share:.0%} of the steps'))
        strategies.append(_figures(context, name, runs[name]))
    full_close = float(np.sum(full_close_air_nl(facade)))
    for name, closure, air in (('always open', 0.0, 0.0), ('always closed', 1.0, full_close)):
        # Static: never moved, also not in a storm; judged over the scheduled run's storms.
        static = _Run(closure=np.full(direct.shape, closure), starts=np.zeros(direct.shape),
                      air_nl=air, latched=runs['scheduled'].latched, latched_s=0.0)
        strategies.append(_figures(context, name, static))
    say("the limit: the best schedule with the whole weather known, at each strategy's "
        'blocking')
    limits = Limits.of(problem, parameters, runs['scheduled'].latched)
    scheduled = strategies[0]
    limit = limit_at(problem, scheduled.blocked_direct_kwh_m2, limits)
    limit_run = _limit_run(problem, limits, limit.schedule, runs['scheduled'])
    strategies.append(dataclasses.replace(
        _figures(context, 'limit', limit_run),
        view_weighted_hours_h=limit.view_weighted_upper_h))
    gaps = {s.name: limit_gaps(problem, limits, s) for s in strategies}
    families = ()
    if families_wanted:
        families = _families(context, problem, limits, parameters, wind, sampled, facade,
                             blocked, table, sunlit, direct, say)
    diffuse = _diffuse_on_panels(facade, sampled)
    dt_h = step_s / 3600.0
    incident = _per_panel_mean(direct * dt_h / 1000.0, context.weights)
    return AnnualReport(
        facade_name=facade.name, source=weather.source, first_date=first, last_date=last,
        step_s=step_s, range_days=count * step_s / 86400.0,
        daylight_h=float(np.sum(position.above_horizon) * dt_h),
        incident_direct_kwh_m2=float(np.sum(incident)),
        incident_diffuse_kwh_m2=float(np.sum(
            _per_panel_mean(diffuse * dt_h / 1000.0, context.weights))),
        monthly_incident_kwh_m2=_by_month(incident, context.months),
        storm_wind_h=float(np.sum(wind > parameters.wind_on_m_s) * dt_h),
        storm_latched_h=runs['scheduled'].latched_s / 3600.0, wind_on_m_s=parameters.wind_on_m_s,
        gust_factor=float(gust_factor), storm_position=parameters.storm_position,
        daily_move_cap=parameters.daily_move_cap,
        cycle_budget_per_year=parameters.daily_move_cap * DAYS_PER_YEAR,
        threshold_w_m2=(float(threshold_on_w_m2), float(threshold_off_w_m2)),
        months=np.bincount(context.months, minlength=12) > 0,
        site_offset_deg=site_distance_deg(facade.site, site), strategies=tuple(strategies),
        controller=controller, limit=limit, gaps=gaps, families=families,
        frontier_free=tuple(frontier(problem)),
        frontier_limited=tuple(frontier(problem, limits)))


@dataclass(frozen=True)
class _Context:
    facade: 'Facade'
    step_s: float
    epochs: np.ndarray
    middles: np.ndarray
    direct: np.ndarray
    """(T, N) direct irradiance on each panel's plane [W/m2]."""
    blocked: np.ndarray
    """(T, N, C) blocked fraction per candidate closure."""
    view: np.ndarray
    daylight: np.ndarray
    weights: np.ndarray
    months: np.ndarray
    """(T,) local month index 0-11 of each step."""


@dataclass(frozen=True)
class _Run:
    closure: np.ndarray
    """(T, N) closure each step holds after its calls."""
    starts: np.ndarray
    """(T, N) moves started during each step."""
    air_nl: float
    latched: np.ndarray
    """(T,) storm latch set at the end of each step."""
    latched_s: float


def _step_s(step_min: float) -> float:
    if isinstance(step_min, bool) or not isinstance(step_min, _NUMBERS):
        raise AnnualReportError(f'step must be a number of minutes, got {step_min!r}')
    if not math.isfinite(step_min) or step_min not in STEPS_MIN:
        raise AnnualReportError(f'step must be one of {", ".join(map(str, STEPS_MIN))} min '
                                f'(a divisor of the hour of a weather file), got {step_min:g}')
    return float(step_min) * 60.0


def _check_options(gust_factor: float, on: float, off: float) -> None:
    for name, value in (('gust_factor', gust_factor), ('threshold_on_w_m2', on),
                        ('threshold_off_w_m2', off)):
        if isinstance(value, bool) or not isinstance(value, _NUMBERS) \
                or not math.isfinite(value):
            raise AnnualReportError(f'{name} must be a finite number, got {value!r}')
    if not 1.0 <= gust_factor <= 3.0:
        raise AnnualReportError(f'gust_factor must lie in [1, 3], got {gust_factor:g}')
    if not on > off >= 0.0:
        raise AnnualReportError(f'thresholds need on > off >= 0 W/m2, got on {on:g}, '
                                f'off {off:g}')


def _parse_date(text: str, what: str) -> np.datetime64:
    match = _DATE.match(str(text).strip())
    if match is None:
        raise AnnualReportError(f'{what} date must be YYYY-MM-DD or MM-DD, got {text!r}')
    try:
        return np.datetime64(f'{REFERENCE_YEAR}-{match.group(1)}-{match.group(2)}', 'D')
    except ValueError:
        raise AnnualReportError(f'{what} date {text!r} is not a date of the reference year '
                                'of a weather file (no 29 February)') from None


def _range(weather: Weather, first_date: Optional[str], last_date: Optional[str],
           step_s: float) -> tuple[np.datetime64, int, str, str]:
    """Start (UTC), step count and the local first and last dates of the range."""
    offset = np.timedelta64(int(round(weather.utc_offset_h * 60)), 'm')
    half = np.timedelta64(30, 'm')
    covered_from = weather.time_utc[0] - half
    covered_to = weather.time_utc[-1] + half
    first_day = (covered_from + offset).astype('datetime64[D]')
    last_day = (covered_to + offset - np.timedelta64(1, 'm')).astype('datetime64[D]')
    full_year = (covered_to - covered_from) >= np.timedelta64(365, 'D')
    if full_year:
        first_day = np.datetime64(f'{REFERENCE_YEAR}-01-01', 'D')
        last_day = np.datetime64(f'{REFERENCE_YEAR}-12-31', 'D')
    first = first_day if first_date is None else _parse_date(first_date, 'first')
    last = last_day if last_date is None else _parse_date(last_date, 'last')
    if last < first:
        raise AnnualReportError(f'last date {str(last)[5:]} is before the first {str(first)[5:]}'
                                ' (a range does not wrap over the new year)')
    start = first.astype('datetime64[ns]') - offset
    end = (last + 1).astype('datetime64[ns]') - offset
    if not full_year and (start < covered_from or end > covered_to):
        raise AnnualReportError(
            f'{weather.source}: the file covers local dates {str(first_day)[5:]} to '
            f'{str(last_day)[5:]}, not {str(first)[5:]} to {str(last)[5:]}')
    count = int((end - start) / np.timedelta64(int(step_s), 's'))
    return start, count, str(first)[5:], str(last)[5:]


def _check_table(table: ShadingTable) -> None:
    if not isinstance(table, ShadingTable):
        raise TypeError(f'table must be a ShadingTable, got {type(table).__name__}')
    if table.closures.shape != CANDIDATE_CLOSURES.shape or \
            not np.allclose(table.closures, CANDIDATE_CLOSURES):
        raise AnnualReportError('table must be built over the candidate closures of the day '
                                'report (0, 0.1, ..., 1)')


def _per_panel_mean(values: FloatArray, weights: FloatArray) -> FloatArray:
    """(T,) footprint-weighted mean over panels of (T, N) values."""
    return values @ weights


def _local_months(middles: npt.NDArray[np.datetime64], utc_offset_h: float) -> IntArray:
    local = into_reference_year(middles + np.timedelta64(int(round(utc_offset_h * 60)), 'm'))
    return (local.astype('datetime64[M]').astype(int) % 12).astype(np.intp)


def _by_month(values: FloatArray, months: IntArray) -> FloatArray:
    # float with weights (the stubs say int)
    return cast(FloatArray, np.bincount(months, weights=values, minlength=12))


def _desired(facade: 'Facade', blocked: FloatArray, view: FloatArray, sunlit: BoolArray,
             step_s: float, target: Optional[float] = None) -> FloatArray:
    """(T, N) closures of the target rule, judged over the look-ahead window."""
    target = facade.control.get('shading_target', 0.9) if target is None else target
    window = int(round(facade.control.get('look_ahead_s', 0.0) / step_s))
    worst = np.where(sunlit[..., None], blocked, np.inf)
    any_lit = sunlit.copy()
    for shift in range(1, window + 1):
        later = np.where(sunlit[shift:, ..., None], blocked[shift:], np.inf)
        worst[:-shift] = np.minimum(worst[:-shift], later)
        any_lit[:-shift] |= sunlit[shift:]
    worst = np.where(any_lit[..., None], worst, 0.0)
    steps, count, size = worst.shape
    choice = choose_candidate(CANDIDATE_CLOSURES, worst.reshape(-1, size),
                              np.broadcast_to(view, (steps * count, size)),
                              any_lit.reshape(-1), target)
    return CANDIDATE_CLOSURES[choice].reshape(steps, count)


def _threshold_desired(direct: FloatArray, on_w_m2: float, off_w_m2: float) -> FloatArray:
    """(T, N) closures of the threshold rule: 0 (shade) above ``on``, 1 (view) below ``off``.

    Between the thresholds a panel keeps its last state; it starts in view.
    """
    steps = np.arange(direct.shape[0])[:, None]
    event = np.where(direct > on_w_m2, 1, np.where(direct < off_w_m2, 0, -1))
    last = np.maximum.accumulate(np.where(event >= 0, steps, -1), axis=0)
    state = np.take_along_axis(event, np.maximum(last, 0), axis=0)
    shading = (last >= 0) & (state == 1)
    return np.where(shading, 0.0, 1.0)


def _run_scheduler(context: _Context, parameters: SchedulerParameters,
                   desired: _Desired, dni: Optional[FloatArray], wind: FloatArray,
                   report_share: Callable[[float], None]) -> _Run:
    """Step the scheduler through the range; follow moves and latch changes within a step."""
    facade, step_s = context.facade, context.step_s
    period_s = float(facade.control.get('period_s', 60.0))
    starts_s = context.epochs - step_s / 2.0
    scheduler = Scheduler(len(facade), full_close_air_nl(facade), parameters,
                          initial_closure=parameters.default_closure, start_s=starts_s[0],
                          wind_timeout_s=1.5 * step_s)
    steps = len(starts_s)
    shape = context.direct.shape
    closure = np.empty(shape)
    starts = np.zeros(shape)
    latched = np.zeros(steps, bool)
    previous = scheduler.commanded_closure.copy()
    moving = np.zeros(len(facade), bool)
    air_nl, latched_s = 0.0, 0.0
    quarter = max(1, steps // 4)
    decide = desired if callable(desired) else (lambda i, closure: desired[i])
    for i in range(steps):
        if i and i % quarter == 0 and i < steps - quarter / 2:
            report_share(i / steps)
        now, end = starts_s[i], starts_s[i] + step_s
        irradiance = None if dni is None else dni[i]
        wanted = decide(i, scheduler.commanded_closure)
        result = scheduler.step(now, wanted, wind_m_s=wind[i], dni_w_m2=irradiance)
        while True:
            changed = result.closure != previous
            starts[i] += changed & ~moving
            moving = changed
            previous = result.closure
            air_nl += result.air_used_nl
            was_latched = scheduler.storm_latched
            due = _next_call(scheduler, result, now, period_s)
            latched_s += (min(due, end) - now) * was_latched
            if due >= end:
                break
            now = due
            result = scheduler.step(now, wanted, dni_w_m2=irradiance)
        closure[i] = result.closure
        latched[i] = scheduler.storm_latched
    return _Run(closure=closure, starts=starts, air_nl=air_nl, latched=latched,
                latched_s=latched_s)


@dataclass(frozen=True)
class FamilyMember:
    """One member of a baseline family and its figures."""

    family: str
    """'threshold' or 'target rule'."""
    label: str
    """Its setting, e.g. 'on 300 / off 150 W/m2' or 'target 0.9'."""
    figures: StrategyFigures


def _families(context: _Context, problem: ClosureProblem, limits: Limits,
              parameters: SchedulerParameters, wind: FloatArray, sampled: Mapping[str, FloatArray],
              facade: 'Facade', blocked: FloatArray, table: ShadingTable, sunlit: BoolArray,
              direct: FloatArray, say: Callable[[str], None]) -> tuple[FamilyMember, ...]:
    members = []
    runs: list[tuple[str, str, Callable[..., FloatArray], Optional[FloatArray]]] = [
            ('threshold', f'on {on:g} / off {on * ratio:g} W/m2',
             lambda on=on, ratio=ratio: _threshold_desired(direct, on, on * ratio), None)
            for on in THRESHOLD_ON_W_M2 for ratio in THRESHOLD_OFF_RATIOS]
    runs += [('target rule', f'target {target:g}',
              lambda target=target: _desired(facade, blocked, table.view, sunlit,
                                             context.step_s, target), sampled['dni_w_m2'])
             for target in SHADING_TARGETS]
    for index, (family, label, make, dni) in enumerate(runs):
        say(f'families: {family} {label} ({index + 1} of {len(runs)})')
        run = _run_scheduler(context, parameters, make(), dni, wind, lambda share: None)
        members.append(FamilyMember(family=family, label=label,
                                    figures=_figures(context, family, run)))
    return tuple(members)


def _limit_run(problem: ClosureProblem, limits: Limits, schedule: Point, scheduled: _Run) -> _Run:
    """Make the limit's schedule a run: moves and air counted from its levels."""
    closure = problem.closures[schedule.levels]
    start = np.full((1, closure.shape[1]), problem.closures[limits.start_level])
    change = np.diff(np.vstack([start, closure]), axis=0)
    return _Run(closure=closure, starts=(change != 0).astype(float),
                air_nl=float(np.sum(np.maximum(change, 0.0) @ problem.air_nl)),
                latched=scheduled.latched, latched_s=scheduled.latched_s)


def _dominates(a: StrategyFigures, b: StrategyFigures) -> bool:
    """Return whether ``a`` is as good as ``b`` in blocking, view and moves, better in one."""
    at_least = (a.blocked_direct_kwh_m2 >= b.blocked_direct_kwh_m2
                and a.view_weighted_hours_h >= b.view_weighted_hours_h
                and a.actuations_per_panel <= b.actuations_per_panel)
    better = (a.blocked_direct_kwh_m2 > b.blocked_direct_kwh_m2
              or a.view_weighted_hours_h > b.view_weighted_hours_h
              or a.actuations_per_panel < b.actuations_per_panel)
    return at_least and better


def _number(value: float, width: int, decimals: int) -> str:
    if value != value:
        return f'{"-":>{width}}'
    value = round(value, decimals) + 0.0  # no '-0'
    return f'{value:>{width}.{decimals}f}'


def _next_call(scheduler: Scheduler, result: ScheduleResult, now: float,
               period_s: float) -> float:
    """Instant of the next call within a step: a move under way, or a latch change due."""
    candidates = [math.inf]
    if any(reason in _MOVING for reason in result.reason):
        candidates.append(now + period_s)
    due = scheduler.storm_due_s
    if due is not None and due > now:
        candidates.append(due)
    return min(candidates)


def _figures(context: _Context, name: str, run: _Run) -> StrategyFigures:
    dt_h = context.step_s / 3600.0
    achieved = interpolate(context.blocked, run.closure)
    blocked = _per_panel_mean(context.direct * achieved * dt_h / 1000.0, context.weights)
    incident = float(np.sum(context.direct @ context.weights) * dt_h / 1000.0)
    view = np.interp(run.closure, CANDIDATE_CLOSURES, context.view)
    daylight = context.daylight[:, None]
    moves = run.starts @ context.weights
    days = len(context.epochs) * context.step_s / 86400.0
    total_moves = float(np.sum(moves))
    storm = float(np.mean(run.closure[run.latched])) if run.latched.any() else math.nan
    return StrategyFigures(
        name=name, blocked_direct_kwh_m2=float(np.sum(blocked)),
        blocked_direct_fraction=float(np.sum(blocked)) / incident if incident > 0 else math.nan,
        view_hours_h=float(np.sum(((view >= VIEW_LEVEL) & daylight) @ context.weights) * dt_h),
        view_weighted_hours_h=float(np.sum((view * daylight) @ context.weights) * dt_h),
        actuations_per_panel=total_moves,
        actuations_per_panel_year=total_moves * DAYS_PER_YEAR / days, air_nl=run.air_nl,
        storm_closure=storm, monthly_blocked_kwh_m2=_by_month(blocked, context.months),
        monthly_actuations_per_panel=_by_month(moves, context.months))


def _diffuse_on_panels(facade: 'Facade', sampled: Mapping[str, FloatArray]) -> FloatArray:
    """(T, N) isotropic sky diffuse and ground-reflected irradiance on each panel [W/m2].

    ``DHI (1 + cos beta) / 2 + albedo GHI (1 - cos beta) / 2``, ``beta`` the panel's tilt
    from horizontal (the isotropic sky model); a view of the panels' blocking of it is not
    computed.
    """
    up = facade.panel_to_enu[:, 2, 2]
    return (sampled['dhi_w_m2'][:, None] * (1 + up) / 2
            + GROUND_ALBEDO * sampled['ghi_w_m2'][:, None] * (1 - up) / 2)


def plot(report: AnnualReport, path: PathLike) -> PathLike:
    """Write a PNG: the frontiers and the strategies; monthly blocked direct sun; moves.

    The first panel draws blocked direct energy against view-weighted hours: the limits,
    the families and every strategy as a point.
    """
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    months = np.flatnonzero(report.months)
    names = ['Jan', 'Feb', 'Mar', 'Apr', 'May', 'Jun', 'Jul', 'Aug', 'Sep', 'Oct', 'Nov',
             'Dec']
    colours = {'scheduled': 'tab:green', 'target rule': 'tab:olive', 'predictive': 'tab:olive',
               'threshold': 'tab:orange', 'always open': 'tab:gray',
               'always closed': 'tab:purple', 'limit': 'black'}
    figure, axes = pyplot.subplots(3, 1, figsize=(10, 13),
                                   gridspec_kw={'height_ratios': [1.4, 1, 1]})
    _plot_frontiers(report, axes[0], colours)
    bars = [s for s in report.strategies if s.name != 'limit']
    width = 0.8 / len(bars)
    for index, strategy in enumerate(bars):
        x = np.arange(months.size) + (index - (len(bars) - 1) / 2) * width
        axes[1].bar(x, strategy.monthly_blocked_kwh_m2[months], width,
                    color=colours.get(strategy.name), label=strategy.name)
        axes[2].bar(x, strategy.monthly_actuations_per_panel[months], width,
                    color=colours.get(strategy.name), label=strategy.name)
    axes[1].plot(np.arange(months.size), report.monthly_incident_kwh_m2[months], 'k_',
                 markersize=20, label='incident direct')
    axes[1].set_ylabel('blocked direct sun [kWh/m2]\n(per m2 of panel footprint)')
    axes[1].legend(loc='upper center', fontsize=8, ncol=6)
    axes[1].set_ylim(0, 1.2 * max(1e-9, float(np.max(report.monthly_incident_kwh_m2))))
    axes[2].set_ylabel('moves started per panel')
    top = max(max(float(np.max(s.monthly_actuations_per_panel)) for s in bars), 1)
    axes[2].set_ylim(0, 1.3 * top)
    axes[2].set_title(f'cycle budget (assumed): {report.daily_move_cap} moves a day, '
                      f'{report.cycle_budget_per_year:.0f} a year, about '
                      f'{report.cycle_budget_per_year / 12:.0f} a month', fontsize=9)
    for axis in axes[1:]:
        axis.set_xticks(np.arange(months.size))
        axis.set_xticklabels([names[m] for m in months])
    axes[2].set_xlabel('month (local standard time of the weather file)')
    axes[2].legend(loc='upper center', fontsize=8, ncol=5)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    pyplot.close(figure)
    return path


def _plot_frontiers(report: AnnualReport, axis: 'Axes', colours: Mapping[str, str]) -> None:
    """Blocked direct energy against view-weighted hours: limits, families, strategies."""
    for points, style, label in (
            (report.frontier_free, 'k:', 'limit without move limits'),
            (report.frontier_limited, 'k-', "limit with the scheduler's limits")):
        if points:
            axis.plot([p.view_weighted_h for p in points],
                      [p.blocked_direct_kwh_m2 for p in points], style, lw=1.2, label=label)
    for family, colour in (('threshold', 'tab:orange'), ('target rule', 'tab:olive')):
        members = sorted((m.figures for m in report.families if m.family == family),
                         key=lambda f: f.view_weighted_hours_h)
        if members:
            axis.plot([f.view_weighted_hours_h for f in members],
                      [f.blocked_direct_kwh_m2 for f in members], 'o--', color=colour,
                      markersize=3, lw=0.8, alpha=0.7, label=f'{family} family')
    for strategy in report.strategies:
        marker = 'x' if strategy.name == 'limit' else 'o'
        axis.plot(strategy.view_weighted_hours_h, strategy.blocked_direct_kwh_m2, marker,
                  color=colours.get(strategy.name), markersize=8)
        axis.annotate(f' {strategy.name}', (strategy.view_weighted_hours_h,
                                            strategy.blocked_direct_kwh_m2), fontsize=8)
    axis.set_xlabel('view-weighted daylight hours, mean per panel [h]')
    axis.set_ylabel('blocked direct sun [kWh/m2]')
    axis.set_title(f'{report.facade_name} on {report.source}\nlocal dates '
                   f'{report.first_date} to {report.last_date}, step '
                   f'{report.step_s / 60:.0f} min: every schedule lies below the limit',
                   fontsize=10)
    axis.grid(alpha=0.3)
    axis.legend(loc='lower left', fontsize=8)
