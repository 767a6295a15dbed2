"""Sun vector in, one closure per panel out: what a facade coordinator runs every period.

:class:`FacadeSchedule` joins a facade description, a :class:`~.shading_table.ShadingTable`
and the :class:`~.scheduler.Scheduler`. Each :meth:`FacadeSchedule.step` takes the sun as an
ENU unit vector (or the sun vectors of a look-ahead window), optional direct irradiance, wind
speed and a fault mask; it chooses each panel's desired closure from the table (the most view
that blocks ``shading_target`` of the direct sun) and hands it to the scheduler, which applies
faults, storm lockout, overrides, the DNI gate, dwell, deadband, rate limit, daily cap and the
air budget.

The table is built once for a representative panel, the facade's median panel by area: the
panels of one facade differ by millimetres, and the table's own interpolation error (about
0.01 in blocked fraction) is of the same order.

The target rule judges each candidate over a look-ahead window: the sun now, then the sun at
the next ``floor(look_ahead_s / period_s)`` multiples of ``control.period_s`` in UTC Unix time
(:func:`look_ahead_times`), where an ephemeris of that step has them cached. The schedule
also owns the coordinator's account of the storm latch (:class:`~.storm.StormEvents`).
"""

from dataclasses import fields
import math
from typing import cast, Optional, TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray
from flectofold_model.actuation import (actuated_like, actuation_model_of,
                                        ATMOSPHERIC_PRESSURE_PA, DEMONSTRATOR_PLANT)
from flectofold_model.environment.clear_sky import ClearSkyDni
from flectofold_model.environment.ephemeris import SunEphemeris
from flectofold_model.facade.footprint import representative_panel
from flectofold_model.scheduling.predictive import (DEFAULT_CONTROLLER, plan_inputs, PlanInputs,
                                                    PredictiveController,
                                                    PredictiveParameters)
from flectofold_model.scheduling.scheduler import Scheduler, ScheduleResult, SchedulerParameters
from flectofold_model.scheduling.storm import StormEvents
from flectofold_model.shading.table import ShadingTable
from flectofold_model.structure.facade_map import structural_close_air_nl

if TYPE_CHECKING:  # the facade's module loads when used
    from flectofold_model.facade.description import Facade


def scheduler_parameters(facade: 'Facade') -> SchedulerParameters:
    """Build the :class:`SchedulerParameters` named in a facade's ``control`` section."""
    names = {f.name for f in fields(SchedulerParameters)}
    return SchedulerParameters(**{k: v for k, v in facade.control.items() if k in names})


def full_close_air_nl(facade: 'Facade') -> FloatArray:
    """Free air [NL] that closes each panel from open, actuated like its kind's preset.

    ``(p_closed V_closed - p_atm V_open) / p_atm`` with absolute pressures and the tubing's dead
    volume, from the static actuation model of each panel's own geometry, or from the
    structural map of the facade's median panel (or of each panel) when its description
    chooses that
    (:func:`~flectofold_model.structure.facade_map.structural_close_air_nl`).
    """
    dead = DEMONSTRATOR_PLANT.dead_volume_m3
    if facade.cushion_map != 'energy':
        return structural_close_air_nl(facade, dead)
    model = actuation_model_of(actuated_like(panel) for panel in facade.panels)
    closed = (ATMOSPHERIC_PRESSURE_PA + model.closed_pressure_pa) * (
        model.cushion_volume_m3(model.fold.closed_shape) + dead)
    opened = ATMOSPHERIC_PRESSURE_PA * (model.cushion_volume_m3(model.fold.open_shape) + dead)
    return (closed - opened) / ATMOSPHERIC_PRESSURE_PA * 1e3


def look_ahead_steps(period_s: float, look_ahead_s: float) -> int:
    """Return the number of decision periods a look-ahead window reaches past now.

    ``floor(look_ahead_s / period_s)``, with 1e-9 of slack so that a window of a whole number
    of periods counts all of them.

    Parameters
    ----------
    period_s : float
        Decision period [s], ``> 0``.
    look_ahead_s : float
        Length of the window [s]; 0 or less: none.

    Returns
    -------
    int
    """
    return max(0, math.floor(look_ahead_s / period_s + 1e-9))


def look_ahead_times(now_s: float, period_s: float, look_ahead_s: float) -> list[float]:
    """Return the instants after ``now_s`` of a look-ahead window on the decision grid.

    The grid is the multiples of ``period_s`` in UTC Unix time; the window takes the
    :func:`look_ahead_steps` multiples that follow ``now_s`` (strictly: a decision on the
    grid does not repeat its own instant).

    Parameters
    ----------
    now_s : float
        Instant of the decision [s, UTC Unix time].
    period_s : float
        Decision period [s], ``> 0``.
    look_ahead_s : float
        Length of the window [s]; 0 or less: none.

    Returns
    -------
    list of float
        The instants [s], increasing; empty when the window is shorter than one period.
    """
    first = math.floor(now_s / period_s) + 1
    return [(first + k) * period_s for k in range(look_ahead_steps(period_s, look_ahead_s))]


class FacadeSchedule:
    """The per-period decision of a facade: sun vector -> commanded closure per panel.

    Parameters
    ----------
    facade : Facade
        The facade; its ``control`` section gives the limits, the controller, the decision
        period (``period_s``, default 60 s) and the look-ahead (``look_ahead_s``, default 0 s).
    start_s : float
        Clock at construction [s, UTC Unix time]; no step may be earlier.
    table : ShadingTable, optional
        The representative panel's table; built (seconds) when not given.
    wind_timeout_s : float
        A wind sample counts until the next one but at most this long [s], ``> 0``.
    """

    def __init__(self, facade: 'Facade', start_s: float = 0.0,
                 table: Optional[ShadingTable] = None, wind_timeout_s: float = 60.0) -> None:
        self.facade = facade
        self.period_s = float(facade.control.get('period_s', 60.0))
        """Decision period [s]: the step of the look-ahead grid."""
        self.look_ahead_s = float(facade.control.get('look_ahead_s', 0.0))
        """Length of the target rule's look-ahead window [s]."""
        self.shading_target = facade.control.get('shading_target', 0.9)
        self.table = table if table is not None else ShadingTable(representative_panel(facade))
        if not isinstance(self.table, ShadingTable):
            raise TypeError(f'table must be a ShadingTable, got {type(self.table).__name__}')
        self.parameters = scheduler_parameters(facade)
        air_nl = full_close_air_nl(facade)
        self.scheduler = Scheduler(len(facade), air_nl, self.parameters,
                                   initial_closure=self.parameters.default_closure,
                                   start_s=start_s, wind_timeout_s=wind_timeout_s)
        self.storm = StormEvents(self.scheduler)
        """The coordinator's account of the scheduler's storm latch."""
        self.controller = facade.control.get('controller', DEFAULT_CONTROLLER)
        """'predictive' (the receding-horizon plan) or 'target' (the target rule)."""
        self._grid_ephemeris = SunEphemeris(facade.site, self.period_s)
        self.predictive: Optional[PredictiveController] = None
        if self.controller == 'predictive':
            settings = PredictiveParameters.of(facade.control)
            self.predictive = PredictiveController(self.table.closures, self.table.view,
                                                   air_nl, settings,
                                                   deadband=self.parameters.deadband)
            self._ephemeris = SunEphemeris(facade.site, settings.plan_step_s)
            self._clear_sky = ClearSkyDni(facade.site, settings.plan_step_s)

    def desired_closure(self, sun_enu: npt.ArrayLike) -> FloatArray:
        """Desired closure (N,) for a sun vector (3,) or a look-ahead window (W, 3) in ENU."""
        sun = _checked_sun(sun_enu)
        in_panels = self.facade.sun_in_panel_frames(sun)
        return self.table.choose(in_panels, self.shading_target)

    def sun_window(self, now_s: float, sun_enu: npt.ArrayLike) -> npt.ArrayLike:
        """Return the sun the target rule judges at ``now_s`` [s, UTC Unix time].

        The sun now ``sun_enu`` (3,) in ENU, followed by the ephemeris at the
        :func:`look_ahead_times` of the decision grid: an array (W, 3), W >= 1, under the
        target rule with ``look_ahead_s > 0``; otherwise ``sun_enu`` itself.
        """
        if self.look_ahead_s <= 0.0 or self.controller != 'target':
            return sun_enu
        now = np.asarray(sun_enu, dtype=float).reshape(1, 3)
        times = look_ahead_times(now_s, self.period_s, self.look_ahead_s)
        return np.vstack([now, self._grid_ephemeris.enu(times)]) if times else now

    def plan_inputs(self, now_s: float, sun_enu: npt.ArrayLike) -> PlanInputs:
        """Return the predictive controller's view of the horizon from ``now_s``.

        ``now_s`` [s, UTC Unix time]; the sun now (3,) ENU, then the ephemeris on the plan
        grid (multiples of ``plan_step_s``) up to ``horizon_s``.
        """
        # called only with the predictive controller
        settings = cast(PredictiveController, self.predictive).parameters
        step_s = settings.plan_step_s
        first = math.floor(now_s / step_s) + 1
        times = [(first + j) * step_s for j in range(settings.steps(step_s) - 1)]
        sun = np.asarray(sun_enu, dtype=float).reshape(1, 3)
        if times:
            sun = np.vstack([sun, self._ephemeris.enu(times)])
        steps = np.array([times[0] - now_s if times else step_s] + [step_s] * len(times))
        clear = self._clear_sky.at(np.array([now_s] + times, dtype=float))
        return plan_inputs(self.facade, self.table, sun, clear, steps)

    def step(self, now_s: float, sun_enu: Optional[npt.ArrayLike],
             dni_w_m2: Optional[float] = None, wind_m_s: Optional[float] = None,
             faulted: Optional[npt.ArrayLike] = None) -> ScheduleResult:
        """Commanded closures for this period, with the reasons (see :class:`ScheduleResult`).

        ``sun_enu`` None (no sun known): each panel's desired closure is its commanded one,
        so automatic panels hold while a storm still moves the rest. The predictive
        controller takes the first vector of a window (the sun now) and the ephemeris
        ahead; it replaces the DNI gate (the scheduler's gate is not fed). The step is noted
        in :attr:`storm` as a decision on the latch as the step leaves it.
        """
        if self.predictive is None:
            desired = (self.scheduler.commanded_closure if sun_enu is None
                       else self.desired_closure(sun_enu))
            result = self.scheduler.step(now_s, desired, wind_m_s=wind_m_s,
                                         dni_w_m2=dni_w_m2, faulted=faulted)
        else:
            if sun_enu is None:
                desired = self.scheduler.commanded_closure
            else:
                now = _checked_sun(sun_enu).reshape(-1, 3)[0]
                desired = self.predictive.desired(self.scheduler.commanded_closure,
                                                  self.plan_inputs(float(now_s), now),
                                                  dni_now_w_m2=dni_w_m2)
            result = self.scheduler.step(now_s, desired, wind_m_s=wind_m_s, faulted=faulted)
        self.storm.stepped()
        return result


def _checked_sun(sun_enu: npt.ArrayLike) -> FloatArray:
    sun = np.asarray(sun_enu, dtype=float)
    if sun.shape[-1:] != (3,) or sun.ndim not in (1, 2) or not np.all(np.isfinite(sun)):
        raise ValueError(f'sun_enu must be finite, of shape (3,) or (W, 3), got {sun.shape}')
    norm = np.linalg.norm(sun, axis=-1)
    if np.any(np.abs(norm - 1.0) > 1e-6):
        raise ValueError('sun_enu must be unit vectors toward the sun')
    return sun
