"""The closure a facade's own schedule commands at one instant of a clear day.

What the coordinator (``coordinator_node``) would command at that instant had it run since
the local midnight before it: every ``control.period_s`` from midnight (the facade's
``site.utc_offset_h`` clock) one :meth:`~.facade_schedule.FacadeSchedule.step` with the sun
(NREL SPA), the look-ahead window of ``control.look_ahead_s`` on the same grid, and the
clear-sky direct normal irradiance of the day report (:func:`.day_report.clear_sky_dni`), no
wind and no faults. The closure in force at the instant is that of the last decision at or
before it. The scheduler starts the day at ``control.default_closure``, as the day report
and the bringup do.
"""

import math
from typing import Any, cast, Optional, TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, real_scalar
from flectofold_model.environment.clear_sky import clear_sky_dni
from flectofold_model.environment.sun import solar_position
from flectofold_model.scheduling.facade_schedule import FacadeSchedule, look_ahead_steps
from flectofold_model.scheduling.scheduler import ScheduleResult
from flectofold_model.shading.table import ShadingTable

if TYPE_CHECKING:  # the facade's module loads when used
    from flectofold_model.facade.description import Facade


def decision_times(facade: 'Facade', epoch_s: float) -> npt.NDArray[np.floating[Any]]:
    """POSIX times (D,) [s] of the decisions from local midnight to ``epoch_s`` (included)."""
    epoch = real_scalar('epoch_s', epoch_s)
    period = float(facade.control.get('period_s', 60.0))
    offset_s = facade.utc_offset_h * 3600.0
    midnight = math.floor((epoch + offset_s) / 86400.0) * 86400.0 - offset_s
    count = math.floor((epoch - midnight) / period + 1e-9) + 1
    return midnight + period * np.arange(count)


def scheduled_closure(facade: 'Facade', epoch_s: float,
                      table: Optional[ShadingTable] = None) -> FloatArray:
    """Commanded closure (N,) of every panel at POSIX time ``epoch_s`` [s]; see the module doc.

    ``table`` is the schedule's :class:`~flectofold_model.shading.table.ShadingTable`
    (built for the facade's median panel when not given: about 8 s). Raises ``ValueError``
    for a time that is not finite or outside the solar position algorithm's years.
    """
    decisions = decision_times(facade, epoch_s)
    period = float(facade.control.get('period_s', 60.0))
    ahead = look_ahead_steps(period, float(facade.control.get('look_ahead_s', 0.0)))
    times = decisions[0] + period * np.arange(len(decisions) + ahead)
    sun = solar_position(times, facade.site).enu
    dni = clear_sky_dni(decisions, facade.site)
    schedule = FacadeSchedule(facade, start_s=float(decisions[0]), table=table)
    result: Optional[ScheduleResult] = None
    for index, now in enumerate(decisions):
        window = sun[index:index + ahead + 1] if ahead else sun[index]
        result = schedule.step(float(now), window, dni_w_m2=float(dni[index]))
    # the decisions run to the instant itself: at least one step
    return np.asarray(cast(ScheduleResult, result).closure, dtype=float)
