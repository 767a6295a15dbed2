"""Bring up a whole facade: sun, coordinator and every panel, through a simulated day.

``ros2 run flectofold_ros facade`` (or ``./run``): the embedded 6 x 6 demonstrator in
Stuttgart through the June solstice at 360 x. The sun node is the clock; the coordinator and
the panel nodes run on ``use_sim_time``. Panels run in this process on one events executor and
one vectorised loop, or split over ``--panel-processes`` child processes (``panel_group``).
A progress line while it runs, a summary at the end; Ctrl-C stops everything cleanly.
"""

import argparse
from dataclasses import dataclass
import datetime
import math
import os
import resource
import signal
import subprocess
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from flectofold_model.facade import DEFAULT_FACADE, FacadeError, load_facade
from flectofold_ros.coordinator_node import CoordinatorNode
from flectofold_ros.panel_node import start_panels
from flectofold_ros.spinning import make_executor, spin_until
from flectofold_ros.sun_position_node import SunPositionNode

CLOCK_RATE_HZ = 50.0
CATCH_UP_WAIT_S = 60.0
MAX_LAG_S = 300.0
START_WAIT_S = 60.0
#: After the graph shows every subscription, the publishers in other processes still have to
#: match them: the clock starts this much later [s of wall time].
MATCH_SETTLE_S = 1.0
PANEL_STATE = ('joint_states', 'pressure', 'closure')


@dataclass(frozen=True)
class DayPlan:
    """The simulated span and the settings every node gets from it."""

    facade_file: str
    start_iso: str
    end_iso: str
    speedup: float

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
    def setpoint_period_s(self):
        """Coordinator heartbeat: 1 s, or 2 clock ticks."""
        return max(1.0, 2.0 * self.clock_tick_s)


def local_iso(date, clock_time, utc_offset_h):
    """ISO 8601 text of a local date and HH:MM at a UTC offset [h]."""
    day = datetime.date.fromisoformat(date)
    hours, minutes = (int(part) for part in clock_time.split(':'))
    zone = datetime.timezone(datetime.timedelta(hours=utc_offset_h))
    return datetime.datetime(day.year, day.month, day.day, hours, minutes,
                             tzinfo=zone).isoformat()


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='facade', description=__doc__.split('\n')[0])
    parser.add_argument('--facade', default='', help='facade YAML (default: the embedded '
                        '6 x 6 anticlastic demonstrator)')
    parser.add_argument('--date', default='2026-06-21', help='local date of the day')
    parser.add_argument('--start', default='12:00', help='local start time HH:MM')
    parser.add_argument('--end', default='15:00', help='local end time HH:MM')
    parser.add_argument('--speedup', type=float, default=360.0,
                        help='simulated seconds per wall second (default 360)')
    parser.add_argument('--panel-processes', type=int, default=2,
                        help='host the panels in this many child processes (default 2; '
                             '0: all in this process)')
    parser.add_argument('--progress-period', type=float, default=5.0,
                        help='wall seconds between progress lines')
    parser.add_argument('--record', action='store_true',
                        help='record a bag (MCAP) of /facade/**, /diagnostics and /clock')
    parser.add_argument('--rerun', nargs='?', const='auto', default=None, metavar='VIEWER',
                        help='stream the 3D facade to Rerun and save an .rrd; VIEWER: auto '
                             '(spawn a viewer when a display is set; the default), spawn, '
                             'none (file only) or a gRPC URL rerun+http://127.0.0.1:9876/proxy')
    parser.add_argument('--out', default='out',
                        help='directory for the bag and the .rrd (default out/); each run '
                             'gets a folder, out/latest points to the newest')
    return parser.parse_args(argv)


def build_plan(options, facade):
    """Check the options against the facade and return the :class:`DayPlan`."""
    if not 1.0 <= options.speedup <= 10000.0 or not math.isfinite(options.speedup):
        raise ValueError(f'--speedup must lie in [1, 10000], got {options.speedup:g}')
    if not 0 <= options.panel_processes <= len(facade):
        raise ValueError(f'--panel-processes must lie in [0, {len(facade)}], '
                         f'got {options.panel_processes}')
    try:
        start = local_iso(options.date, options.start, facade.utc_offset_h)
        end = local_iso(options.date, options.end, facade.utc_offset_h)
    except ValueError as error:
        raise ValueError(f'--date/--start/--end: {error}') from None
    if end <= start:
        raise ValueError(f'--end {options.end} must be after --start {options.start}')
    return DayPlan(options.facade, start, end, options.speedup)


def sun_parameters(plan, facade):
    site = facade.site
    return [Parameter('latitude_deg', value=site.latitude_deg),
            Parameter('longitude_deg', value=site.longitude_deg),
            Parameter('elevation_m', value=site.elevation_m),
            Parameter('mode', value='simulated'), Parameter('start_time', value=plan.start_iso),
            Parameter('end_time', value=plan.end_iso), Parameter('speedup', value=plan.speedup),
            Parameter('clock_rate_hz', value=CLOCK_RATE_HZ)]


def panel_parameters(plan):
    return [Parameter('use_sim_time', value=True),
            Parameter('facade_file', value=plan.facade_file),
            Parameter('setpoint_timeout_s', value=plan.setpoint_timeout_s),
            Parameter('publish_rate_hz', value=plan.publish_rate_hz)]


def coordinator_parameters(plan):
    return [Parameter('use_sim_time', value=True),
            Parameter('facade_file', value=plan.facade_file),
            Parameter('setpoint_period_s', value=plan.setpoint_period_s)]


def recorder_command(bag_path):
    return [sys.executable, '-m', 'flectofold_ros.bag_recorder', '--ros-args',
            '-p', 'use_sim_time:=true', '-p', f'output:={bag_path}']


def bridge_command(plan, rrd_path, viewer):
    command = [sys.executable, '-m', 'flectofold_ros.rerun_bridge', '--ros-args',
               '-p', 'use_sim_time:=true', '-p', f'rrd_path:={rrd_path}',
               '-p', f'viewer:={viewer}']
    if plan.facade_file:
        command += ['-p', f'facade_file:={plan.facade_file}']
    return command


def run_directory(out, plan):
    """Create ``out/<day>_<start>-<end>_<wall time>/`` and point ``out/latest`` at it."""
    start = datetime.datetime.fromisoformat(plan.start_iso)
    end = datetime.datetime.fromisoformat(plan.end_iso)
    name = (f'{start:%Y-%m-%d_%H%M}-{end:%H%M}_'
            f'{datetime.datetime.now():%Y%m%d-%H%M%S}')
    directory = os.path.join(out, name)
    try:
        os.makedirs(directory)
        latest = os.path.join(out, 'latest')
        if os.path.islink(latest):
            os.remove(latest)
        if not os.path.exists(latest):
            os.symlink(name, latest)
    except OSError as error:
        raise ValueError(f'--out {out}: cannot create {directory}: {error.strerror}') from None
    return directory


def panel_group_command(plan, group, groups):
    """Return the command line of one child process hosting a slice of the panels."""
    command = [sys.executable, '-m', 'flectofold_ros.panel_group', '--group', f'{group}/{groups}']
    if plan.facade_file:
        command += ['--facade', plan.facade_file]
    command += ['--ros-args', '-p', 'use_sim_time:=true',
                '-p', f'setpoint_timeout_s:={plan.setpoint_timeout_s}',
                '-p', f'publish_rate_hz:={plan.publish_rate_hz}']
    return command


class Monitor(Node):
    """Collects every panel's diagnostics, prints progress and ends the day."""

    def __init__(self, sun, coordinator, facade, progress_period_s):
        super().__init__('facade_monitor', namespace='/facade')
        self.sun, self.coordinator, self.facade = sun, coordinator, facade
        self.done = False
        self.panels = {}
        self.started = time.monotonic()
        self.finished_at = None
        self.holds, self.held_s, self.held_since = 0, 0.0, None
        self.starting = True
        self.observers = 0
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_diagnostics, 100)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(progress_period_s, self.print_progress, clock=steady)
        self.create_timer(0.25, self._check_finished, clock=steady)

    def _on_diagnostics(self, message):
        for status in message.status:
            if status.hardware_id in self.coordinator.facade.panel_ids:
                values = {item.key: item.value for item in status.values}
                values['level'] = int.from_bytes(status.level, 'little') \
                    if isinstance(status.level, bytes) else int(status.level)
                self.panels[status.hardware_id] = values

    def _hold_clock_for_laggards(self):
        """Hold simulated time while a panel loop is more than MAX_LAG_S behind it."""
        loop_times = self.numbers('loop_time_s')
        lagging = len(loop_times) == len(self.facade) and \
            self.sun.sim_epoch_s - min(loop_times) > MAX_LAG_S
        if lagging and not self.sun.paused:
            self.holds += 1
            self.held_since = time.monotonic()
        elif not lagging and self.sun.paused:
            self.held_s += time.monotonic() - self.held_since
        self.sun.paused = lagging

    def ready(self):
        """Every panel publishes; the coordinator and every observer (bridge, recorder) listen.

        Until then the bringup holds the clock at the start of the day, so nothing misses it.
        """
        if self.count_subscribers('/facade/sun') < 1 + self.observers:
            return False
        return all(self.count_publishers(topic) >= 1
                   and self.count_subscribers(topic) >= self.observers
                   for panel_id in self.facade.panel_ids
                   for topic in (f'/facade/{panel_id}/{name}' for name in PANEL_STATE))

    def start_day(self):
        self.starting = False
        self.sun.paused = False
        self.started = time.monotonic()

    def _check_finished(self):
        if self.starting:
            return
        self._hold_clock_for_laggards()
        if self.sun.finished and self.finished_at is None:
            self.finished_at = time.monotonic()
        if self.finished_at is None:
            return
        # Panels behind the clock catch up (their loops are integrated, not skipped): wait
        # until every one reports the end of the day, or give up after CATCH_UP_WAIT_S.
        loop_times = self.numbers('loop_time_s')
        caught_up = len(loop_times) == len(self.facade) and \
            min(loop_times) >= self.sun.sim_epoch_s - 1.0
        waited = time.monotonic() - self.finished_at
        if (caught_up and waited > 1.5) or waited > CATCH_UP_WAIT_S:
            self.done = True

    def numbers(self, key):
        return [float(values[key]) for values in self.panels.values() if key in values]

    def print_progress(self):
        if self.starting:
            up = sum(self.count_publishers(f'/facade/{p}/closure') >= 1
                     for p in self.facade.panel_ids)
            heard = min(self.count_subscribers(f'/facade/{p}/closure')
                        for p in self.facade.panel_ids)
            print(f'[{time.monotonic() - self.started:6.1f} s] starting: panels up {up}/'
                  f'{len(self.facade)}, observers subscribed {heard}/{self.observers}, '
                  f'sun listeners {self.count_subscribers("/facade/sun")}/'
                  f'{1 + self.observers}', flush=True)
            return
        local = _local_time(self.sun.sim_epoch_s, self.facade.utc_offset_h)
        closures = self.numbers('closure')
        commanded = self.coordinator.commanded
        loop_times = self.numbers('loop_time_s')
        lag = self.sun.sim_epoch_s - min(loop_times) if loop_times else math.nan
        faults = sum(1 for v in self.panels.values() if v.get('fault', 'none') != 'none')
        mean = sum(closures) / len(closures) if closures else math.nan
        wanted = f'{commanded.mean():.2f}' if commanded is not None else '-'
        print(f'[{time.monotonic() - self.started:6.1f} s] sim {local} | panels reporting '
              f'{len(self.panels)}/{len(self.facade)} | closure {mean:.2f} (commanded '
              f'{wanted}) | faults {faults} | loop lag {lag:.0f} s sim', flush=True)


def _local_time(epoch_s, utc_offset_h):
    zone = datetime.timezone(datetime.timedelta(hours=utc_offset_h))
    return datetime.datetime.fromtimestamp(epoch_s, zone).strftime('%Y-%m-%d %H:%M')


def summary_lines(monitor, plan, wall_s, interrupted, process_wall_s=None):
    """Return the end-of-run summary: the day's figures, then CPU and memory.

    ``wall_s`` is the day's wall time (the speed-up); ``process_wall_s``, the whole run's,
    start-up included, over which the CPU time was spent (default ``wall_s``).
    """
    process_wall_s = wall_s if process_wall_s is None else process_wall_s
    facade, coordinator = monitor.facade, monitor.coordinator
    sim_s = monitor.sun.sim_epoch_s - datetime.datetime.fromisoformat(plan.start_iso).timestamp()
    usage = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = usage.ru_utime + usage.ru_stime + children.ru_utime + children.ru_stime
    lines = [f'{facade.name}: {"interrupted" if interrupted else "day finished"} at '
             f'{_local_time(monitor.sun.sim_epoch_s, facade.utc_offset_h)} (local)',
             f'  simulated {sim_s / 3600:.2f} h in {wall_s:.1f} s wall: '
             f'{sim_s / max(wall_s, 1e-9):.0f}x real time (asked {plan.speedup:g}x)',
             f'  panels reporting: {len(monitor.panels)}/{len(facade)}; clock held '
             f'{monitor.holds} times, {monitor.held_s:.1f} s wall, for panel loops more than '
             f'{MAX_LAG_S:g} s behind']
    if coordinator.schedule is not None:
        moves = coordinator.schedule.scheduler.moves_today
        lines.append(f'  coordinator: {coordinator.decisions} decisions, moves per panel '
                     f'{moves.mean():.1f} (max {moves.max()}), peak parallel fills '
                     f'{coordinator.peak_filling}, air budget {coordinator.air_used_nl:.0f} NL')
    if monitor.panels:
        closure = monitor.numbers('closure')
        tracked = monitor.numbers('tracked_closure')
        error = max(abs(a - b) for a, b in zip(closure, tracked)) if tracked else math.nan
        air = sum(monitor.numbers('free_air_used_nl'))
        faults = sorted({v['fault'] for v in monitor.panels.values()} - {'none'})
        rejected = sum(monitor.numbers('setpoints_rejected'))
        timeouts = sum(1 for v in monitor.panels.values()
                       if v.get('setpoint_state') == 'setpoint_timeout')
        lines += [f'  panels: air drawn {air:.0f} NL ({air / len(monitor.panels):.1f} NL per '
                  f'panel), final |closure - setpoint| max {error:.3f}',
                  f'  faults: {", ".join(faults) or "none"}; setpoints rejected {rejected:.0f};'
                  f' panels in setpoint timeout {timeouts}']
    lines.append(f'  CPU {cpu_s:.1f} s in {process_wall_s:.0f} s '
                 f'({cpu_s / max(process_wall_s, 1e-9):.2f} cores); peak RSS '
                 f'{usage.ru_maxrss / 1024:.0f} MB this process'
                 + (f', {children.ru_maxrss / 1024:.0f} MB largest child'
                    if children.ru_maxrss else ''))
    return lines


def _stop_children(children, timeout_s=10.0):
    for child in children:
        if child.poll() is None:
            child.send_signal(signal.SIGINT)
    deadline = time.monotonic() + timeout_s
    for child in children:
        try:
            child.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()


def _exited(processes):
    return any(process.poll() is not None for process in processes)


def output_lines(outputs):
    """Where the run's bag and .rrd are, with their sizes."""
    lines = []
    for name, what in (('bag', 'bag (rosbag2, MCAP)'), ('facade.rrd', 'Rerun recording')):
        path = os.path.join(outputs, name)
        if os.path.exists(path):
            files = [os.path.join(root, f) for root, _, names in os.walk(path) for f in names] \
                if os.path.isdir(path) else [path]
            size = sum(os.path.getsize(f) for f in files)
            lines.append(f'  {what}: {path} ({size / 1e6:.1f} MB)')
    if lines:
        latest = os.path.join(os.path.dirname(outputs), 'latest')
        lines.insert(0, f'outputs (also under {latest}):')
    return lines


def run(options, args):
    facade = load_facade(options.facade or DEFAULT_FACADE)
    plan = build_plan(options, facade)
    rclpy.init(args=args)
    outputs = run_directory(options.out, plan) if options.record or options.rerun else None
    executor = make_executor()
    nodes, children, observers = [], [], []
    interrupted = True
    started = time.monotonic()
    monitor = None
    try:
        coordinator = CoordinatorNode(parameter_overrides=coordinator_parameters(plan))
        nodes.append(coordinator)
        env = dict(os.environ, PYTHONUNBUFFERED='1')
        if options.record:
            observers.append(subprocess.Popen(
                recorder_command(os.path.join(outputs, 'bag')), env=env))
        if options.rerun:
            observers.append(subprocess.Popen(
                bridge_command(plan, os.path.join(outputs, 'facade.rrd'), options.rerun),
                env=env))
        if options.panel_processes:
            children = [subprocess.Popen(panel_group_command(plan, k, options.panel_processes),
                                         env=env)
                        for k in range(options.panel_processes)]
        else:
            nodes += start_panels(facade.panel_ids, executor,
                                  parameter_overrides=panel_parameters(plan))
        sun = SunPositionNode(parameter_overrides=sun_parameters(plan, facade))
        sun.paused = True
        monitor = Monitor(sun, coordinator, facade, options.progress_period)
        monitor.observers = len(observers)
        nodes += [sun, monitor]
        for node in (coordinator, sun, monitor):
            executor.add_node(node)
        print(f'facade: {facade.name}, {len(facade)} panels '
              f'({"in this process" if not children else f"in {len(children)} processes"}), '
              f'{plan.start_iso} .. {plan.end_iso} at {plan.speedup:g}x; Ctrl-C stops',
              flush=True)
        waited = time.monotonic()
        spin_until(executor, lambda: monitor.ready() or
                   time.monotonic() - waited > START_WAIT_S or _exited(children + observers))
        if not monitor.ready():
            print(f'facade: not every panel and observer was up after '
                  f'{time.monotonic() - waited:.0f} s; starting the day anyway', flush=True)
        elif observers:
            settled = time.monotonic()
            spin_until(executor, lambda: time.monotonic() - settled > MATCH_SETTLE_S)
        monitor.start_day()
        spin_until(executor, lambda: monitor.done)
        interrupted = not monitor.done
        if observers:
            spin_until(executor, lambda: time.monotonic() - monitor.finished_at > 2.0)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if rclpy.ok():
            raise  # a real error; after a signal's shutdown, callbacks fail on a dead context
    finally:
        wall_s = time.monotonic() - (monitor.started if monitor is not None else started)
        _stop_children(children)
        _stop_children(observers, timeout_s=120.0)
        if monitor is not None:
            lines = summary_lines(monitor, plan, wall_s, interrupted, time.monotonic() - started)
            print('\n'.join(lines), flush=True)
        if outputs is not None:
            print('\n'.join(output_lines(outputs)), flush=True)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0 if not interrupted else 130


def main(args=None):
    argv = remove_ros_args(args=sys.argv if args is None else args)[1:]
    options = parse_arguments(argv)
    try:
        return run(options, args)
    except (ValueError, FacadeError, ParameterException) as error:
        print(f'facade: {error}', file=sys.stderr)
        return 2


if __name__ == '__main__':
    sys.exit(main())
