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

import numpy as np

from flectofold_model._validate import real_scalar
from flectofold_model.environment.clear_sky import clear_sky_dni
from flectofold_model.environment.sun import solar_position
from flectofold_model.scheduling.facade_schedule import FacadeSchedule, look_ahead_steps


def decision_times(facade, epoch_s):
    """POSIX times (D,) [s] of the decisions from local midnight to ``epoch_s`` (included)."""
    epoch = real_scalar('epoch_s', epoch_s)
    period = float(facade.control.get('period_s', 60.0))
    offset_s = facade.utc_offset_h * 3600.0
    midnight = math.floor((epoch + offset_s) / 86400.0) * 86400.0 - offset_s
    count = math.floor((epoch - midnight) / period + 1e-9) + 1
    return midnight + period * np.arange(count)


def scheduled_closure(facade, epoch_s, table=None):
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
    result = None
    for index, now in enumerate(decisions):
        window = sun[index:index + ahead + 1] if ahead else sun[index]
        result = schedule.step(float(now), window, dni_w_m2=float(dni[index]))
    return np.asarray(result.closure, dtype=float)
