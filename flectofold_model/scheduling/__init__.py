"""Scheduling the array: desired closures -> commanded closures under the facade's limits.

- :mod:`.scheduler`: the per-period decision under dwell, deadband, rate limit, daily cap, air
  budget, storm latch and DNI gate (:class:`Scheduler`);
- :mod:`.storm`: the storm latch on wind samples, and a coordinator's account of its trips and
  releases;
- :mod:`.facade_schedule`: sun vector -> commanded closure per panel of a facade;
- :mod:`.day_report`: a facade's day, what its schedule achieved, against two baselines;
- :mod:`.scheduled_closure`: the closure the schedule commands at one instant of a clear day.
"""

from flectofold_model.scheduling.day_report import DayReport, simulate_day
from flectofold_model.scheduling.facade_schedule import FacadeSchedule
from flectofold_model.scheduling.scheduler import (Reason, Scheduler, ScheduleResult,
                                                   SchedulerParameters)

__all__ = ['DayReport', 'FacadeSchedule', 'Reason', 'ScheduleResult', 'Scheduler',
           'SchedulerParameters', 'simulate_day']
