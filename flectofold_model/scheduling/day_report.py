"""A facade's day: sun, shading choices, the schedule and what it achieved, against baselines.

For a facade description and a date, every ``step_s`` of the local day:

1. the sun (NREL SPA, :mod:`~flectofold_model.environment`) and the clear-sky direct normal
   irradiance (pvlib's Ineichen model with its bundled turbidity data, offline);
2. each panel's blocked fraction of direct sun at every candidate closure, by ray casting
   against its own folded mesh (:mod:`~flectofold_model.shading`), and its view fraction;
3. the desired closure: among the candidates, the one with the most view whose blocked
   fraction meets ``shading_target`` at every sunlit instant of the look-ahead window
   ``[t, t + look_ahead_s]`` (the Beckhoff pattern: a position that stays good until the
   next allowed move); where none does, the one that blocks most at its worst instant;
   panels without direct sun in the window take the most view;
4. the scheduler (:mod:`.scheduler`): deadband, dwell, rate limit, daily cap, DNI gate, the
   air budget and its fill cap;
5. the achieved figures, and the same figures for the two static baselines, always open
   (closure 0, flat) and always closed (closure 1, folded).

What closure means for light: a Flectofold panel lies in the facade surface, so an **open**
(flat) panel covers its footprint and blocks all direct sun, while a **closed** (folded) panel
uncovers most of it: view and daylight come with closure. The figures report both sides:
the share of the direct sun on sunlit footprints that is blocked, and the view fraction over
daylight hours.
"""

from dataclasses import dataclass
import math

import numpy as np

from flectofold_model.environment import sun
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_model.scheduling.facade_schedule import full_close_air_nl, scheduler_parameters
from flectofold_model.scheduling.scheduler import Scheduler
from flectofold_model.shading.ray_casting import blocked_fraction, choose_candidate, view_fraction

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
    peak_fills: int
    """Most panels filling at once."""


@dataclass(frozen=True)
class DayReport:
    """The day of a facade, with the schedule and both baselines."""

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

    def lines(self):
        """Return the summary as text lines."""
        lines = [f'day report {self.date}: {self.closure.shape[1]} panels, '
                 f'{len(self.local_hours)} steps, sun up {np.sum(self.elevation_deg > 0)} steps']
        header = (f'{"":<15}{"blocked direct":>15}{"view (daylight)":>17}'
                  f'{"moves/panel":>13}{"air [NL]":>10}{"peak fills":>12}')
        lines.append(header)
        for name, outcome in (('scheduled', self.scheduled), ('always open', self.always_open),
                              ('always closed', self.always_closed)):
            lines.append(f'{name:<15}{outcome.blocked_direct_fraction:>15.3f}'
                         f'{outcome.view_fraction:>17.3f}{outcome.actuations_per_panel:>13.1f}'
                         f'{outcome.air_nl:>10.0f}{outcome.peak_fills:>12d}')
        return lines


def simulate_day(facade, date_iso, step_s=300.0, samples=24, progress=None):
    """Run ``facade`` through the local day ``date_iso`` ('YYYY-MM-DD'); see the module doc.

    The facade's panels are all quad panels or all hexagonal ones; each is cast against its
    own kind's mesh. ``samples`` is the resolution across each footprint (``3 samples`` scan
    lines, see :mod:`.shading`). ``progress``: called with a line of text before each long
    step.
    """
    say = progress or (lambda text: None)
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
    say('scheduling the day and its two baselines')
    target = facade.control.get('shading_target', 0.9)
    window = int(round(facade.control.get('look_ahead_s', 0.0) / step_s))
    parameters = scheduler_parameters(facade)
    desired = _desired(blocked, view, sunlit, target, window)
    closure, filling, air = _schedule(facade, parameters, epochs, desired, dni)
    daylight = position.above_horizon
    weight = np.where(sunlit, dni[:, None] * np.clip(sun_panel[..., 2], 0, None), 0.0)
    achieved = _interpolate(blocked, closure)
    scheduled = Outcome(
        blocked_direct_fraction=_weighted(achieved, weight),
        view_fraction=float(np.mean(_interpolate(np.broadcast_to(view, blocked.shape),
                                                 closure)[daylight])),
        actuations_per_panel=float(np.mean(_moves(closure))), air_nl=float(np.sum(air)),
        peak_fills=int(np.max(np.sum(filling, axis=1))))
    full_close = full_close_air_nl(facade)
    baselines = [Outcome(blocked_direct_fraction=_weighted(blocked[..., index], weight),
                         view_fraction=float(np.mean(view[:, index])) if daylight.any()
                         else 0.0, actuations_per_panel=0.0, air_nl=air_nl, peak_fills=0)
                 for index, air_nl in ((0, 0.0), (-1, float(np.sum(full_close))))]
    offset_hours = (epochs - epochs[0]) / 3600.0
    return DayReport(date=date_iso, local_hours=offset_hours,
                     elevation_deg=np.degrees(position.apparent_elevation_rad), dni_w_m2=dni,
                     closure=closure, blocked=np.where(sunlit, achieved, 0.0), sunlit=sunlit,
                     blocked_open=blocked[..., 0], blocked_closed=blocked[..., -1],
                     scheduled=scheduled, always_open=baselines[0],
                     always_closed=baselines[1])


def clear_sky_dni(epochs, site):
    """Clear-sky direct normal irradiance [W/m2] at POSIX times (T,) [s]: pvlib's Ineichen.

    With pvlib's bundled Linke turbidity data (monthly climatology, offline).
    """
    import pandas as pd
    from pvlib.location import Location
    times = pd.to_datetime(epochs, unit='s', utc=True)
    location = Location(site.latitude_deg, site.longitude_deg, altitude=site.elevation_m)
    return location.get_clearsky(times, model='ineichen')['dni'].to_numpy()


def _blocked_table(fold, sun_panel, sunlit, samples):
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


def _view_table(fold, samples):
    return np.stack([view_fraction(fold.batch, fold.state_from_closure(c).shape_parameter,
                                   samples=samples)
                     for c in CANDIDATE_CLOSURES], axis=-1)


def _desired(blocked, view, sunlit, target, window):
    """Pick the (T, N) desired closures by the shading rule over look-ahead windows.

    Each candidate is judged by its worst blocked fraction over the window's sunlit instants.
    """
    steps = blocked.shape[0]
    desired = np.empty(blocked.shape[:2])
    for t in range(steps):
        span = slice(t, min(steps, t + window + 1))
        lit = sunlit[span]
        worst = np.where(lit[..., None], blocked[span], np.inf).min(axis=0)
        any_lit = lit.any(axis=0)
        worst = np.where(any_lit[:, None], worst, 0.0)
        choice = choose_candidate(CANDIDATE_CLOSURES, worst, view, any_lit, target)
        desired[t] = CANDIDATE_CLOSURES[choice]
    return desired


def _schedule(facade, parameters, epochs, desired, dni):
    scheduler = Scheduler(len(facade), full_close_air_nl(facade), parameters,
                          initial_closure=parameters.default_closure, start_s=epochs[0])
    closure, filling, air = [], [], []
    for now, wanted, irradiance in zip(epochs, desired, dni):
        result = scheduler.step(now, wanted, dni_w_m2=irradiance)
        closure.append(result.closure)
        filling.append(result.filling)
        air.append(result.air_used_nl)
    return np.array(closure), np.array(filling), np.array(air)


def _interpolate(table, closure):
    """Values of a (T, N, C) table at closures (T, N), linear between candidates."""
    position = closure / (CANDIDATE_CLOSURES[1] - CANDIDATE_CLOSURES[0])
    lower = np.clip(np.floor(position).astype(int), 0, CANDIDATE_CLOSURES.size - 2)
    fraction = position - lower
    below = np.take_along_axis(table, lower[..., None], axis=-1)[..., 0]
    above = np.take_along_axis(table, lower[..., None] + 1, axis=-1)[..., 0]
    return below + fraction * (above - below)


def _weighted(values, weight):
    total = np.sum(weight)
    return float(np.sum(values * weight) / total) if total > 0 else math.nan


def _moves(closure):
    """Count the moves each panel started: a change after a still step (or at the start)."""
    changing = np.abs(np.diff(closure, axis=0)) > 1e-9
    still_before = np.vstack([np.ones((1, closure.shape[1]), bool), ~changing[:-1]])
    return np.sum(changing & still_before, axis=0)


def plot(report, path):
    """Write the day as a PNG: sun elevation and DNI, closure, blocked direct sun."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    figure, axes = pyplot.subplots(3, 1, figsize=(9, 8), sharex=True)
    hours = report.local_hours
    axes[0].plot(hours, report.elevation_deg, color='tab:orange', label='sun elevation')
    axes[0].set_ylabel('elevation [deg]')
    twin = axes[0].twinx()
    twin.plot(hours, report.dni_w_m2, color='tab:red', alpha=0.5, label='clear-sky DNI')
    twin.set_ylabel('DNI [W/m2]')
    axes[0].set_title(f'{report.date}: sun')
    mean = report.closure.mean(axis=1)
    axes[1].plot(hours, mean, color='tab:blue', label='mean closure')
    axes[1].fill_between(hours, report.closure.min(axis=1), report.closure.max(axis=1),
                         color='tab:blue', alpha=0.2, label='min-max')
    axes[1].set_ylabel('closure (0 open, 1 closed)')
    axes[1].set_ylim(-0.05, 1.05)
    axes[1].legend(loc='lower left')
    lit = report.sunlit.sum(axis=1)
    for values, colour, label in ((report.blocked, 'tab:green', 'scheduled'),
                                  (report.blocked_open, 'tab:gray', 'always open'),
                                  (report.blocked_closed, 'tab:purple', 'always closed')):
        share = np.divide(np.sum(values * report.sunlit, axis=1), lit,
                          out=np.full(lit.shape, np.nan), where=lit > 0)
        axes[2].plot(hours, share, color=colour, label=label)
    axes[2].set_ylabel('blocked direct sun\n(mean over sunlit panels)')
    axes[2].set_xlabel('local time [h]')
    axes[2].set_ylim(-0.05, 1.05)
    axes[2].legend(loc='lower left')
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    pyplot.close(figure)
    return path
