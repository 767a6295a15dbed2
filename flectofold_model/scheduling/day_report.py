"""A facade's day: sun, shading choices, the schedule, what it achieved, baselines, the limit.

For a facade description and a date, every ``step_s`` of the local day:

1. the sun (NREL SPA, :mod:`~flectofold_model.environment`) and the clear-sky direct normal
   irradiance (pvlib's Ineichen model with its bundled turbidity data, offline), which is
   also the day's DNI;
2. each panel's blocked fraction of direct sun at every candidate closure, by ray casting
   against its own folded mesh (:mod:`~flectofold_model.shading`), and its view fraction;
3. the desired closures of the facade's controller (``control.controller``,
   :data:`~.predictive.DEFAULT_CONTROLLER` when not named):

   ``predictive``
       :class:`~.predictive.PredictiveController`, planned at every step over its horizon
       from the day's clear-sky DNI (the step's DNI is its measurement), as the annual
       report runs it; the scheduler's DNI gate is not used;
   ``target``
       among the candidates, the one with the most view whose blocked fraction meets
       ``shading_target`` at every sunlit instant of the look-ahead window
       ``[t, t + look_ahead_s]`` (the Beckhoff pattern: a position that stays good until the
       next allowed move); where none does, the one that blocks most at its worst instant;
       panels without direct sun in the window take the most view; with the DNI gate;
4. the scheduler (:mod:`.scheduler`): deadband, dwell, rate limit, daily cap, DNI gate, the
   air budget and its fill cap;
5. the achieved figures (row ``scheduled``), the same for the controller the facade does not
   run (row ``target rule`` or ``predictive``), for the two static baselines, always open
   (closure 0, flat) and always closed (closure 1, folded), and the ``limit``: the most view
   any schedule within the scheduler's limits keeps at scheduled's blocking, with the whole
   day known (:mod:`.frontier`; the air bucket and the parallel fills relaxed, so it is an
   upper bound). Each row's gap is the view it gives up against the limit at its own
   blocking.

What closure means for light: a Flectofold panel lies in the facade surface, so an **open**
(flat) panel covers its footprint and blocks all direct sun, while a **closed** (folded) panel
uncovers most of it: view and daylight come with closure. The figures report both sides:
the share of the direct sun on sunlit footprints that is blocked, and the view fraction over
daylight hours.
"""

from dataclasses import dataclass
import math
from types import SimpleNamespace
from typing import Callable, cast, Optional, TYPE_CHECKING, Union

import numpy as np

from flectofold_model._validate import BoolArray, FloatArray, IntArray, PathLike
from flectofold_model.environment import sun
from flectofold_model.environment.clear_sky import clear_sky_dni
from flectofold_model.facade.footprint import footprint_weights
from flectofold_model.kinematics.kinds import AnyFoldModel, fold_model_of
from flectofold_model.scheduling.facade_schedule import full_close_air_nl, scheduler_parameters
from flectofold_model.scheduling.frontier import (ClosureProblem, frontier, Limit, limit_at,
                                                  Limits, Point)
from flectofold_model.scheduling.predictive import DEFAULT_CONTROLLER, PlanInputs
from flectofold_model.scheduling.report_common import (limit_gaps, OTHER_ROW,
                                                       predictive_desired)
from flectofold_model.scheduling.scheduler import Scheduler, SchedulerParameters
from flectofold_model.shading.ray_casting import blocked_fraction, choose_candidate, view_fraction

if TYPE_CHECKING:  # the facade's and matplotlib's modules load when used
    from matplotlib.axes import Axes

    from flectofold_model.facade.description import Facade

CANDIDATE_CLOSURES = np.linspace(0.0, 1.0, 11)


@dataclass(frozen=True)
class Outcome:
    """Figures of one way of running the facade through the day."""

    blocked_direct_fraction: float
    """Direct sun on sunlit footprints that the panels blocked, irradiance-weighted."""
    view_fraction: float
    """Mean view fraction of the panels over daylight hours (sun above the horizon)."""
    actuations_per_panel: float
    """Mean number of moves a panel started."""
    air_nl: float
    """Free air spent on closing moves [NL]."""
    peak_fills: Optional[int]
    """Most panels filling at once; None for the limit, which relaxes the parallel fills."""


@dataclass(frozen=True)
class DayReport:
    """The day of a facade: the schedule, the other controller, both baselines, the limit."""

    date: str
    local_hours: np.ndarray
    elevation_deg: np.ndarray
    dni_w_m2: np.ndarray
    closure: np.ndarray
    """(T, N) commanded closure."""
    blocked: np.ndarray
    """(T, N) blocked fraction at the commanded closure (0 where not sunlit)."""
    sunlit: np.ndarray
    blocked_open: np.ndarray
    """(T, N) blocked fraction of the always-open baseline."""
    blocked_closed: np.ndarray
    """(T, N) blocked fraction of the always-closed baseline."""
    scheduled: Outcome
    always_open: Outcome
    always_closed: Outcome
    controller: str = DEFAULT_CONTROLLER
    """The facade's controller, run as ``scheduled``."""
    other_name: str = ''
    """Row of the controller the facade does not run: 'target rule' or 'predictive'."""
    other: Optional[Outcome] = None
    other_closure: Optional[np.ndarray] = None
    """(T, N) commanded closure of the other controller."""
    limit: Optional[Limit] = None
    """The :class:`~.frontier.Limit` at scheduled's blocking with the scheduler's limits;
    None when no schedule within them blocks as much (it should not happen)."""
    limit_outcome: Optional[Outcome] = None
    """The ``limit`` row: its schedule's blocking, the limit's upper bound of view."""
    incident_direct_kwh_m2: float = math.nan
    """Direct sun on sunlit footprints, footprint-weighted mean over panels [kWh/m2]."""
    daylight_h: float = math.nan
    """Hours with the sun above the horizon."""
    on_limit_axes: Optional[dict[str, tuple[float, float]]] = None
    """Per row, (blocked direct fraction, view fraction) as the limit weighs them (see
    :func:`_problem_figures`): what the gaps and the PNG's frontier panel use."""
    gaps: Optional[dict[str, float]] = None
    """Per row but the limit, the view fraction it gives up against the limit with the
    scheduler's limits at its own blocking (NaN where no schedule within them blocks as
    much)."""
    frontier_limited: tuple[Point, ...] = ()
    """Supported points (:class:`~.frontier.Point`) of the limit with the scheduler's
    limits."""

    def rows(self) -> list[tuple[str, Outcome]]:
        """Return (name, :class:`Outcome`) of every row, in the order printed."""
        rows = [('scheduled', self.scheduled)]
        if self.other is not None:
            rows.append((self.other_name, self.other))
        rows += [('always open', self.always_open), ('always closed', self.always_closed)]
        if self.limit_outcome is not None:
            rows.append(('limit', self.limit_outcome))
        return rows

    def fractions(self, blocked_direct_kwh_m2: float,
                  view_weighted_h: float) -> tuple[float, float]:
        """Return (blocked direct fraction, view fraction) of figures as the limit weighs them.

        Blocked energy [kWh/m2] over the incident direct energy, view-weighted hours [h] over
        daylight hours.
        """
        return _fractions(blocked_direct_kwh_m2, view_weighted_h,
                          self.incident_direct_kwh_m2, self.daylight_h)

    def lines(self) -> list[str]:
        """Return the summary as text lines."""
        lines = [f'day report {self.date}: {self.closure.shape[1]} panels, '
                 f'{len(self.local_hours)} steps, sun up {np.sum(self.elevation_deg > 0)} steps'
                 f'; scheduled: the {self.controller} controller']
        header = (f'{"":<15}{"blocked direct":>15}{"view (daylight)":>17}'
                  f'{"moves/panel":>13}{"air [NL]":>10}{"peak fills":>12}'
                  f'{"gap view":>10}{"gap [%]":>9}')
        lines.append(header)
        for name, outcome in self.rows():
            gap = (self.gaps or {}).get(name, math.nan)
            view = (self.on_limit_axes or {}).get(name, (math.nan, math.nan))[1]
            share = gap / (view + gap) if view + gap > 0 else math.nan
            fills = '-' if outcome.peak_fills is None else f'{outcome.peak_fills:d}'
            lines.append(f'{name:<15}{outcome.blocked_direct_fraction:>15.3f}'
                         f'{outcome.view_fraction:>17.3f}{outcome.actuations_per_panel:>13.1f}'
                         f'{outcome.air_nl:>10.0f}{fills:>12}{_number(gap, 10, 3)}'
                         f'{_number(100 * share, 9, 1)}')
        lines.extend(self.limit_lines())
        return lines

    def limit_lines(self) -> list[str]:
        """Return the lines that say what the limit is and how exactly it is known."""
        if self.limit is None:
            return ["limit: no schedule within the scheduler's limits blocks as much as "
                    'scheduled']
        limit = self.limit
        blocked, upper = self.fractions(limit.blocked_direct_kwh_m2,
                                        limit.view_weighted_upper_h)
        lower = self.fractions(0.0, limit.view_weighted_lower_h)[1]
        return [f"limit: with the whole day known and the scheduler's limits, no schedule "
                f'that blocks {blocked:.3f} of the direct sun ({limit.blocked_direct_kwh_m2:.3f}'
                f' kWh/m2) keeps a view fraction above {upper:.3f}; one keeps {lower:.3f} '
                f"(the row's moves and air; bracket {limit.width_h:.3f} h; it would exceed "
                f'the air bucket in {limit.air_bound_exceeded_steps} steps)',
                'gap view: view fraction a row gives up against the limit at its own '
                "blocking ([%] of the limit's view); blocked and view as the limit weighs "
                "them (footprint shares, the panels' mean view)"]


def simulate_day(facade: 'Facade', date_iso: str, step_s: float = 300.0, samples: int = 24,
                 progress: Optional[Callable[[str], None]] = None) -> DayReport:
    """Run ``facade`` through the local day ``date_iso`` ('YYYY-MM-DD'); see the module doc.

    The facade's panels are all quad panels or all hexagonal ones; each is cast against its
    own kind's mesh. ``samples`` is the resolution across each footprint (``3 samples`` scan
    lines, see :mod:`.shading`). ``progress``: called with a line of text before each long
    step.
    """
    say = progress or (lambda text: None)
    # The instants of the day: midnight + k step_s, each the start of its step (the
    # scheduler decides there and the sun then holds for the step).
    epochs = sun.day_epochs(date_iso, facade.utc_offset_h, step_s)
    position = sun.solar_position(epochs, facade.site)
    dni = clear_sky_dni(epochs, facade.site)
    sun_panel = facade.sun_in_panel_frames(position.enu)
    sunlit = (sun_panel[..., 2] > 0) & position.above_horizon[:, None]
    fold = fold_model_of(facade.panels)
    say(f'casting rays: {len(facade)} panels at {int(np.count_nonzero(sunlit.any(axis=1)))} '
        f'sunlit instants of {len(epochs)}, every closure candidate')
    blocked = _blocked_table(fold, sun_panel, sunlit, samples)
    view = _view_table(fold, samples)
    daylight = position.above_horizon
    cos_incidence = np.where(sunlit, sun_panel[..., 2], 0.0)
    weights = footprint_weights(facade)
    # (K,) view of the limit and the predictive controller: the panels' footprint-weighted
    # mean (the panels of a facade differ by about 0.01).
    mean_view = weights @ view
    controller = facade.control.get('controller', DEFAULT_CONTROLLER)
    other = 'target' if controller == 'predictive' else 'predictive'
    names = {controller: 'scheduled', other: OTHER_ROW[other]}
    say(f'scheduling the day: the {controller} controller, the {other} controller and two '
        'baselines')
    parameters = scheduler_parameters(facade)
    target = facade.control.get('shading_target', 0.9)
    window = int(round(facade.control.get('look_ahead_s', 0.0) / step_s))
    inputs = PlanInputs(cos_incidence=cos_incidence, blocked=blocked, daylight=daylight,
                        clear_dni_w_m2=dni, step_h=np.full(len(epochs), step_s / 3600.0))
    # predictive_desired reads only a shading table's closures and view
    table = SimpleNamespace(closures=CANDIDATE_CLOSURES, view=mean_view)
    runs = {
        'target': lambda: _schedule(facade, parameters, epochs,
                                    _desired(blocked, view, sunlit, target, window), dni),
        'predictive': lambda: _schedule(facade, parameters, epochs, predictive_desired(
            facade, table, inputs, dni, step_s, parameters), None)}
    weight = np.where(sunlit, dni[:, None] * np.clip(sun_panel[..., 2], 0, None), 0.0)
    outcomes, closures = {}, {}
    for name in (controller, other):
        closure, filling, air = runs[name]()
        closures[names[name]] = closure
        outcomes[names[name]] = Outcome(
            blocked_direct_fraction=_weighted(interpolate(blocked, closure), weight),
            view_fraction=float(np.mean(interpolate(np.broadcast_to(view, blocked.shape),
                                                    closure)[daylight])),
            actuations_per_panel=float(np.mean(_moves(closure))), air_nl=float(np.sum(air)),
            peak_fills=int(np.max(np.sum(filling, axis=1))))
    full_close = full_close_air_nl(facade)
    baselines = [Outcome(blocked_direct_fraction=_weighted(blocked[..., index], weight),
                         view_fraction=float(np.mean(view[:, index])) if daylight.any()
                         else 0.0, actuations_per_panel=0.0, air_nl=air_nl, peak_fills=0)
                 for index, air_nl in ((0, 0.0), (-1, float(np.sum(full_close))))]
    closures['always open'] = np.zeros(sunlit.shape)
    closures['always closed'] = np.ones(sunlit.shape)

    say("the limit: the best schedule with the whole day known, at each row's blocking")
    problem = ClosureProblem(
        closures=CANDIDATE_CLOSURES, direct_w_m2=dni[:, None] * cos_incidence, blocked=blocked,
        view=mean_view, daylight=daylight, step_s=step_s, start_s=epochs, weights=weights,
        air_nl=full_close)
    limits = Limits.of(problem, parameters, latched=np.zeros(len(epochs), bool))  # no wind
    figures = {name: _problem_figures(problem, closure) for name, closure in closures.items()}
    step_h = step_s / 3600.0
    incident = float(np.sum(problem.direct_w_m2 @ weights) * step_h / 1000.0)
    daylight_h = float(np.sum(daylight) * step_h)
    gaps = {name: _fractions(0.0, limit_gaps(problem, limits, figure)[0], incident, daylight_h)[1]
            for name, figure in figures.items()}
    try:
        limit = limit_at(problem, figures['scheduled'].blocked_direct_kwh_m2, limits)
    except ValueError:
        limit = limit_outcome = None
    if limit is not None:
        figures['limit'] = _Figures(blocked_direct_kwh_m2=limit.schedule.blocked_direct_kwh_m2,
                                    view_weighted_hours_h=limit.view_weighted_upper_h)
        closure = problem.closures[limit.schedule.levels]
        start = np.full((1, closure.shape[1]), problem.closures[limits.start_level])
        gained = np.maximum(np.diff(np.vstack([start, closure]), axis=0), 0.0)
        limit_blocked, limit_view = _fractions(figures['limit'].blocked_direct_kwh_m2,
                                               figures['limit'].view_weighted_hours_h,
                                               incident, daylight_h)
        limit_outcome = Outcome(blocked_direct_fraction=limit_blocked, view_fraction=limit_view,
                                actuations_per_panel=float(np.mean(_moves(closure))),
                                air_nl=float(np.sum(gained @ full_close)), peak_fills=None)
    on_axes = {name: _fractions(f.blocked_direct_kwh_m2, f.view_weighted_hours_h, incident,
                                daylight_h) for name, f in figures.items()}
    return DayReport(
        date=date_iso, local_hours=(epochs - epochs[0]) / 3600.0,
        elevation_deg=np.degrees(position.apparent_elevation_rad), dni_w_m2=dni,
        closure=closures['scheduled'],
        blocked=np.where(sunlit, interpolate(blocked, closures['scheduled']), 0.0),
        sunlit=sunlit, blocked_open=blocked[..., 0], blocked_closed=blocked[..., -1],
        scheduled=outcomes['scheduled'], always_open=baselines[0],
        always_closed=baselines[1], controller=controller, other_name=names[other],
        other=outcomes[names[other]], other_closure=closures[names[other]], limit=limit,
        limit_outcome=limit_outcome, incident_direct_kwh_m2=incident, daylight_h=daylight_h,
        on_limit_axes=on_axes, gaps=gaps, frontier_limited=tuple(frontier(problem, limits)))


@dataclass(frozen=True)
class _Figures:
    """A row's figures as the limit weighs them, named as :func:`.limit_gaps` reads."""

    blocked_direct_kwh_m2: float
    view_weighted_hours_h: float


def _fractions(blocked_direct_kwh_m2: float, view_weighted_h: float, incident_kwh_m2: float,
               daylight_h: float) -> tuple[float, float]:
    """(blocked direct fraction, view fraction) of figures as the limit weighs them."""
    blocked = blocked_direct_kwh_m2 / incident_kwh_m2 if incident_kwh_m2 > 0 else math.nan
    view = view_weighted_h / daylight_h if daylight_h > 0 else math.nan
    return blocked, view


def _problem_figures(problem: ClosureProblem, closure: FloatArray) -> _Figures:
    """Return the figures of closures (T, N) as the limit weighs them (:class:`_Figures`).

    Blocked direct [kWh/m2] and view-weighted hours [h], linear between candidates.

    Against the day report's own figures of the same closures: the blocked energy weighs
    each panel by its footprint share (the day report: each panel alike) and the view is the
    panels' mean view table (the day report: each panel's own). For a facade of equal panels
    both give the same fractions; the demonstrator's panels differ by about 5 % in area and
    0.01 in view, and on its June solstice at 600 s steps the fractions of every row differ
    by at most 7e-4 (blocked) and 5e-4 (view).
    """
    step_h = problem.step_s / 3600.0
    blocked = interpolate(problem.blocked, closure)
    energy = np.sum((problem.direct_w_m2 * blocked) @ problem.weights) * step_h / 1000.0
    view = np.interp(closure, problem.closures, problem.view)
    hours = np.sum((view * problem.daylight[:, None]) @ problem.weights) * step_h
    return _Figures(blocked_direct_kwh_m2=float(energy), view_weighted_hours_h=float(hours))


def _blocked_table(fold: AnyFoldModel, sun_panel: FloatArray, sunlit: BoolArray,
                   samples: int) -> FloatArray:
    """(T, N, C) blocked fraction at every candidate closure, computed only where sunlit."""
    states = [fold.state_from_closure(c).shape_parameter for c in CANDIDATE_CLOSURES]
    table = np.zeros(sun_panel.shape[:2] + (CANDIDATE_CLOSURES.size,))
    times, panels = np.nonzero(sunlit)
    if times.size == 0:
        return table
    batch = fold.batch.take(panels)
    for index, shape in enumerate(states):
        shading = blocked_fraction(batch, shape[panels], sun_panel[times, panels],
                                   samples=samples)
        table[times, panels, index] = shading.blocked_fraction
    return table


def _view_table(fold: AnyFoldModel, samples: int) -> FloatArray:
    return np.stack([view_fraction(fold.batch, fold.state_from_closure(c).shape_parameter,
                                   samples=samples)
                     for c in CANDIDATE_CLOSURES], axis=-1)


def _desired(blocked: FloatArray, view: FloatArray, sunlit: BoolArray, target: float,
             window: int) -> FloatArray:
    """Pick the (T, N) desired closures by the shading rule over look-ahead windows.

    Each candidate is judged by its worst blocked fraction over the window's sunlit instants.
    """
    steps = blocked.shape[0]
    desired = np.empty(blocked.shape[:2])
    for t in range(steps):
        span = slice(t, min(steps, t + window + 1))
        lit = sunlit[span]
        worst = np.where(lit[..., None], blocked[span], np.inf).min(axis=0)
        any_lit = cast(BoolArray, lit.any(axis=0))  # (N,): lit is (W, N)
        worst = np.where(any_lit[:, None], worst, 0.0)
        choice = choose_candidate(CANDIDATE_CLOSURES, worst, view, any_lit, target)
        desired[t] = CANDIDATE_CLOSURES[choice]
    return desired


def _schedule(facade: 'Facade', parameters: SchedulerParameters, epochs: FloatArray,
              desired: Union[FloatArray, Callable[[int, FloatArray], FloatArray]],
              dni: Optional[FloatArray]) -> tuple[FloatArray, BoolArray, FloatArray]:
    """Step the scheduler once at each instant of the day.

    ``desired``: (T, N) desired closures, or a callable ``desired(i, commanded_closure)``
    (N,) as :func:`.annual_report._run_scheduler` takes; ``dni`` (T,) [W/m2] feeds the DNI
    gate, None leaves it on.
    """
    scheduler = Scheduler(len(facade), full_close_air_nl(facade), parameters,
                          initial_closure=parameters.default_closure, start_s=epochs[0])
    decide = desired if callable(desired) else (lambda i, closure: desired[i])
    closure, filling, air = [], [], []
    for i, now in enumerate(epochs):
        wanted = decide(i, scheduler.commanded_closure)
        result = scheduler.step(now, wanted, dni_w_m2=None if dni is None else dni[i])
        closure.append(result.closure)
        filling.append(result.filling)
        air.append(result.air_used_nl)
    return np.array(closure), np.array(filling), np.array(air)


def interpolate(table: FloatArray, closure: FloatArray) -> FloatArray:
    """Values of a (T, N, C) table at closures (T, N), linear between candidates."""
    position = closure / (CANDIDATE_CLOSURES[1] - CANDIDATE_CLOSURES[0])
    lower = np.clip(np.floor(position).astype(int), 0, CANDIDATE_CLOSURES.size - 2)
    fraction = position - lower
    below = np.take_along_axis(table, lower[..., None], axis=-1)[..., 0]
    above = np.take_along_axis(table, lower[..., None] + 1, axis=-1)[..., 0]
    return below + fraction * (above - below)


def _weighted(values: FloatArray, weight: FloatArray) -> float:
    total = np.sum(weight)
    return float(np.sum(values * weight) / total) if total > 0 else math.nan


def _moves(closure: FloatArray) -> IntArray:
    """Count the moves each panel started: a change after a still step (or at the start)."""
    changing = np.abs(np.diff(closure, axis=0)) > 1e-9
    still_before = np.vstack([np.ones((1, closure.shape[1]), bool), ~changing[:-1]])
    return np.sum(changing & still_before, axis=0)


def _number(value: float, width: int, decimals: int) -> str:
    return f'{"-":>{width}}' if value != value else f'{value:>{width}.{decimals}f}'


#: Colours of the rows in the PNG.
COLOURS = {'scheduled': 'tab:green', 'target rule': 'tab:blue', 'predictive': 'tab:blue',
           'always open': 'tab:gray', 'always closed': 'tab:purple', 'limit': 'black'}


def plot(report: DayReport, path: PathLike) -> PathLike:
    """Write the day as a PNG: sun, closure, blocked direct sun, and the rows against the limit.

    The last panel draws the frontier of view against blocked direct sun (the limit with the
    scheduler's limits, a line through its supported points) and every row as a point, all
    as the limit weighs them.
    """
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    figure = pyplot.figure(figsize=(9, 12))
    grid = figure.add_gridspec(4, 1, height_ratios=(1, 1, 1, 1.4))
    axes = [figure.add_subplot(grid[0])]
    axes += [figure.add_subplot(grid[i], sharex=axes[0]) for i in (1, 2)]
    hours = report.local_hours
    axes[0].plot(hours, report.elevation_deg, color='tab:orange', label='sun elevation')
    axes[0].set_ylabel('elevation [deg]')
    twin = axes[0].twinx()
    twin.plot(hours, report.dni_w_m2, color='tab:red', alpha=0.5, label='clear-sky DNI')
    twin.set_ylabel('DNI [W/m2]')
    axes[0].set_title(f'{report.date}: sun')
    mean = report.closure.mean(axis=1)
    axes[1].plot(hours, mean, color=COLOURS['scheduled'],
                 label=f'mean closure, scheduled ({report.controller})')
    axes[1].fill_between(hours, report.closure.min(axis=1), report.closure.max(axis=1),
                         color=COLOURS['scheduled'], alpha=0.2, label='min-max')
    if report.other_closure is not None:
        axes[1].plot(hours, report.other_closure.mean(axis=1), color=COLOURS['target rule'],
                     linestyle='--', label=f'mean closure, {report.other_name}')
    axes[1].set_ylabel('closure (0 open, 1 closed)')
    axes[1].set_ylim(-0.05, 1.05)
    axes[1].legend(loc='lower left', fontsize=8)
    lit = report.sunlit.sum(axis=1)
    for values, colour, label in ((report.blocked, COLOURS['scheduled'], 'scheduled'),
                                  (report.blocked_open, COLOURS['always open'], 'always open'),
                                  (report.blocked_closed, COLOURS['always closed'],
                                   'always closed')):
        share = np.divide(np.sum(values * report.sunlit, axis=1), lit,
                          out=np.full(lit.shape, np.nan), where=lit > 0)
        axes[2].plot(hours, share, color=colour, label=label)
    axes[2].set_ylabel('blocked direct sun\n(mean over sunlit panels)')
    axes[2].set_xlabel('local time [h]')
    axes[2].set_ylim(-0.05, 1.05)
    axes[2].legend(loc='lower left')
    _plot_frontier(figure.add_subplot(grid[3]), report)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    pyplot.close(figure)
    return path


def _plot_frontier(axes: 'Axes', report: DayReport) -> None:
    """Draw the limit's frontier and the rows as points: view against blocked direct sun."""
    if report.frontier_limited:
        line = np.array([report.fractions(p.blocked_direct_kwh_m2, p.view_weighted_h)
                         for p in report.frontier_limited])
        axes.plot(line[:, 0], line[:, 1], color='black', linewidth=1,
                  label="limit (whole day known, scheduler's limits)")
    for name, (blocked, view) in (report.on_limit_axes or {}).items():
        axes.plot(blocked, view, 'o', color=COLOURS.get(name, 'tab:red'),
                  markerfacecolor='none' if name == 'limit' else None)
        # the limit lies near scheduled: its label goes below, the others' above
        axes.annotate(name, (blocked, view), textcoords='offset points',
                      xytext=(5, -12) if name == 'limit' else (5, 5), fontsize=8)
    axes.set_xlabel('blocked direct sun (share of the direct sun on the panels)')
    axes.set_ylabel('view fraction\n(mean over daylight)')
    axes.set_title('what each row gives against the limit', fontsize=10)
    axes.legend(loc='lower left', fontsize=8)
