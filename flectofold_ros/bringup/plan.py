"""The plan of a facade's simulated day: its span, its processes and every node's parameters.

Pure (no rclpy): the ``facade`` command and ``launch/facade.launch.py`` both build their
processes from one :class:`DayPlan`, so the two bring up the same graph with the same
settings. Errors name the setting the way the caller's users spell it: ``plan_day`` takes a
``name`` function (``--speedup`` on the command line, ``speedup`` for launch arguments).
"""

from dataclasses import dataclass
import datetime
import math
import numbers
import os
import sys


#: Rate of the simulated /clock [Hz of wall time].
CLOCK_RATE_HZ = 50.0
#: The bringup holds the clock while a panel loop is more than this behind it [s simulated].
MAX_LAG_S = 300.0
#: Fastest and slowest speed-up a day may be run at.
SPEEDUP_RANGE = (1.0, 10000.0)


class PlanError(ValueError):
    """A day that cannot be planned; the message names the setting and the reason."""


@dataclass(frozen=True)
class DayPlan:
    """The simulated span and the settings every node gets from it."""

    facade_file: str
    """Facade description YAML, absolute; empty for the embedded demonstrator."""
    start_iso: str
    end_iso: str
    speedup: float
    panel_processes: int
    """Processes the panels are split over (0: in the bringup's own process)."""
    site: tuple
    """``(latitude_deg, longitude_deg, elevation_m)`` of the facade."""

    @property
    def start_epoch_s(self):
        return datetime.datetime.fromisoformat(self.start_iso).timestamp()

    @property
    def end_epoch_s(self):
        return datetime.datetime.fromisoformat(self.end_iso).timestamp()

    @property
    def clock_tick_s(self):
        """Simulated seconds per /clock message."""
        return self.speedup / CLOCK_RATE_HZ

    @property
    def setpoint_timeout_s(self):
        """Panel watchdog: 10 s, or at least twice MAX_LAG_S when a tick is longer than 1 s.

        The watchdog counts ROS time from the last setpoint a panel took. A panel process busy
        catching up its loops takes its queued setpoints only afterwards, by when the clock
        may have run up to MAX_LAG_S (plus the monitor's reaction) ahead: a shorter watchdog
        would vent panels for the simulation's own lag, not for a silent coordinator.
        """
        if self.clock_tick_s <= 1.0:
            return 10.0
        return max(10.0 * self.clock_tick_s, 2.0 * MAX_LAG_S)

    @property
    def publish_rate_hz(self):
        """Panel state: 10 Hz, or once per 10 clock ticks (5 Hz wall) when that is slower."""
        return min(10.0, 1.0 / (10.0 * self.clock_tick_s))

    @property
    def state_period_s(self):
        """Simulated seconds between two states a panel publishes."""
        return 1.0 / self.publish_rate_hz

    @property
    def setpoint_period_s(self):
        """Coordinator heartbeat: 1 s, 2 clock ticks, or a tenth of the panels' watchdog.

        The heartbeat only keeps the watchdog fed (a decision publishes its setpoints at
        once): ten per watchdog time is margin enough, and at 360x it spares the coordinator
        36 setpoints every other clock tick.
        """
        return max(1.0, 2.0 * self.clock_tick_s, self.setpoint_timeout_s / 10.0)

    # -- node parameters (plain values, as launch_ros and rclpy's Parameter both take) -------

    def sun_parameters(self, wait_for_panels=0, wait_for_sun_listeners=0):
        """Return the sun node's parameters; ``wait_for_*``: hold the start for the graph.

        The ``facade`` command holds the clock itself (the sun node is in its process); under
        ``ros2 launch`` the sun node is told what to wait for.
        """
        latitude, longitude, elevation = self.site
        return {'latitude_deg': latitude, 'longitude_deg': longitude, 'elevation_m': elevation,
                'mode': 'simulated', 'start_time': self.start_iso, 'end_time': self.end_iso,
                'speedup': self.speedup, 'clock_rate_hz': CLOCK_RATE_HZ,
                'start.wait_for_panels': wait_for_panels,
                'start.wait_for_sun_listeners': wait_for_sun_listeners}

    def weather_parameters(self, weather_file):
        return {'use_sim_time': True, 'weather_file': os.path.abspath(weather_file)}

    def panel_parameters(self):
        return {'use_sim_time': True, 'facade_file': self.facade_file,
                'setpoint_timeout_s': self.setpoint_timeout_s,
                'publish_rate_hz': self.publish_rate_hz}

    def coordinator_parameters(self):
        return {'use_sim_time': True, 'facade_file': self.facade_file,
                'setpoint_period_s': self.setpoint_period_s}

    def recorder_parameters(self, bag_path):
        return {'use_sim_time': True, 'output': str(bag_path)}

    def bridge_parameters(self, rrd_path, viewer):
        return {'use_sim_time': True, 'viewer': viewer, 'facade_file': self.facade_file,
                'rrd_path': str(rrd_path)}

    def panel_group_arguments(self, group):
        """``panel_group`` arguments (before ``--ros-args``) of panel process ``group``."""
        arguments = ['--group', f'{group}/{self.panel_processes}']
        return arguments + (['--facade', self.facade_file] if self.facade_file else [])

    # -- child processes of the facade command ---------------------------------------------

    def panel_group_command(self, group):
        return executable_command('panel_group', self.panel_group_arguments(group),
                                  self.panel_parameters())

    def recorder_command(self, bag_path):
        return executable_command('bag_recorder', [], self.recorder_parameters(bag_path))

    def bridge_command(self, rrd_path, viewer):
        return executable_command('rerun_bridge', [], self.bridge_parameters(rrd_path, viewer))

    def markers_parameters(self):
        return {'use_sim_time': True, 'facade_file': self.facade_file}

    def markers_command(self):
        return executable_command('facade_markers', [], self.markers_parameters())


def executable_command(name, arguments, parameters):
    """``python -m flectofold_ros NAME arguments --ros-args -p name:=value ...``."""
    command = [sys.executable, '-m', 'flectofold_ros', name, *arguments, '--ros-args']
    for name, value in parameters.items():
        command += ['-p', f'{name}:={ros_argument(value)}']
    return command


def ros_argument(value):
    """Write a parameter value as ``-p name:=value`` takes it (the value is YAML).

    Floats keep their point (an int would declare an integer), strings are single-quoted so
    that an empty one, or one YAML would read as another type, stays a string.
    """
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        return repr(float(value))
    text = str(value)
    return "'" + text.replace("'", "''") + "'"


def plan_day(facade, facade_file, date, start, end, speedup, panel_processes, *,
             least_processes=0, name=str):
    """Check the settings of a day against ``facade``; return its :class:`DayPlan`.

    Numbers may be given as text (launch arguments are). ``least_processes`` is 1 where the
    panels cannot run in the caller's process (launch). ``name`` turns a setting's name
    (``speedup``, ``panel_processes``, ``date``, ``start``, ``end``) into what the user typed.
    """
    speedup = _number(speedup, float, name('speedup'))
    low, high = SPEEDUP_RANGE
    if not (math.isfinite(speedup) and low <= speedup <= high):
        raise PlanError(f'{name("speedup")} must lie in [{low:g}, {high:g}], got {speedup:g}')
    groups = _number(panel_processes, int, name('panel_processes'))
    if not least_processes <= groups <= len(facade):
        raise PlanError(f'{name("panel_processes")} must lie in [{least_processes}, '
                        f'{len(facade)}] (the panels of {facade.name}), got {groups}')
    start_iso = _local_iso(date, start, facade.utc_offset_h, name, 'start')
    end_iso = _local_iso(date, end, facade.utc_offset_h, name, 'end')
    if end_iso <= start_iso:
        raise PlanError(f'{name("end")} {end} must be after {name("start")} {start}')
    site = facade.site
    return DayPlan(facade_file, start_iso, end_iso, speedup, groups,
                   (site.latitude_deg, site.longitude_deg, site.elevation_m))


def _number(value, kind, label):
    try:
        return kind(value)
    except (TypeError, ValueError):
        word = 'a number' if kind is float else 'a whole number'
        raise PlanError(f'{label} must be {word}, got {value!r}') from None


def _local_iso(date, clock_time, utc_offset_h, name, which):
    """ISO 8601 text of a local date and HH:MM at a UTC offset [h]."""
    try:
        day = datetime.date.fromisoformat(date)
    except (TypeError, ValueError):
        raise PlanError(f'{name("date")} {date!r} is not a date YYYY-MM-DD') from None
    try:
        hours, minutes = (int(part) for part in clock_time.split(':'))
        zone = datetime.timezone(datetime.timedelta(hours=utc_offset_h))
        moment = datetime.datetime(day.year, day.month, day.day, hours, minutes, tzinfo=zone)
    except (AttributeError, TypeError, ValueError):
        raise PlanError(f'{name(which)} {clock_time!r} is not a local time HH:MM') from None
    return moment.isoformat()


def local_time(epoch_s, utc_offset_h):
    """``YYYY-MM-DD HH:MM`` of a POSIX time at a UTC offset [h]."""
    zone = datetime.timezone(datetime.timedelta(hours=utc_offset_h))
    return datetime.datetime.fromtimestamp(epoch_s, zone).strftime('%Y-%m-%d %H:%M')
