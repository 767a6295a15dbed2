"""Bring up a whole facade: sun, coordinator and every panel, through a simulated day.

``ros2 run flectofold_ros facade`` (or ``./run``): the embedded 6 x 6 demonstrator in
Stuttgart through the June solstice at 360 x. The sun node is the clock; the coordinator and
the panel nodes run on ``use_sim_time``. Panels run in this process on one events executor and
one vectorised loop, or split over ``--panel-processes`` child processes (``panel_group``).
A progress line while it runs, a summary at the end; Ctrl-C stops everything cleanly.
"""

import argparse
import datetime
import math
import os
import resource
import signal
import subprocess
import sys
import time

from rclpy.clock import Clock, ClockType
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros import contract
from flectofold_ros.bringup.monitor import Monitor
from flectofold_ros.bringup.plan import local_time, MAX_LAG_S, plan_day
from flectofold_ros.nodes.coordinator import CoordinatorNode
from flectofold_ros.nodes.panel import MAX_CALL_S, start_panels
from flectofold_ros.nodes.sun_position import SunPositionNode
from flectofold_ros.runner import Program, run_nodes

#: Wall seconds the clock waits at the start for every panel and observer to be up.
START_WAIT_S = 60.0
#: After the graph shows every subscription, the publishers in other processes still have to
#: match them: the clock starts this much later [s of wall time].
MATCH_SETTLE_S = 1.0
#: Wall seconds the end of the day waits for panel loops that are behind to catch up.
CATCH_UP_WAIT_S = 60.0
#: Wall seconds the observers get to take the last messages after the day.
DRAIN_S = 2.0
#: Wall seconds panel processes and observers get to stop before they are killed.
PANELS_STOP_S, OBSERVERS_STOP_S = 10.0, 120.0
#: Exit codes of a day that was interrupted, and of one whose processes failed to start.
INTERRUPTED, FAILED = 130, 1


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
    options = parser.parse_args(argv)
    if not (math.isfinite(options.progress_period) and options.progress_period > 0):
        parser.error(f'--progress-period must be a positive number of seconds, got '
                     f'{options.progress_period:g}')
    return options


def option_name(setting):
    """Spell a setting of the plan as the command line does: ``--panel-processes``."""
    return '--' + setting.replace('_', '-')


def run_directory(out, plan):
    """Create ``out/<day>_<start>-<end>_<wall time>/`` and point ``out/latest`` at it."""
    start = datetime.datetime.fromisoformat(plan.start_iso)
    end = datetime.datetime.fromisoformat(plan.end_iso)
    name = f'{start:%Y-%m-%d_%H%M}-{end:%H%M}_{datetime.datetime.now():%Y%m%d-%H%M%S}'
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


def parameters(values):
    """Return rclpy ``Parameter`` objects of a plan's ``{name: value}``."""
    return [Parameter(name, value=value) for name, value in values.items()]


class Bringup(Program):
    """The facade's day as one program: children started, nodes here, phases, the summary.

    Phases: ``starting`` (the clock held at the start until the graph is ready), ``day``
    (the clock runs, held while a panel loop trails it by more than MAX_LAG_S), ``ending``
    (the day is over; panels behind catch up), ``draining`` (the observers take the last
    messages), ``done``.
    """

    def __init__(self, options, facade, plan):
        super().__init__()
        self.facade, self.plan = facade, plan
        self.children, self.observers = [], []
        self.panels = None
        """The panel program when the panels run in this process."""
        self.outputs = (run_directory(options.out, plan)
                        if options.record or options.rerun else None)
        self.started = self.day_started = time.monotonic()
        self.day_ended = None
        """When the clock reached the day's end (the wrap-up after it is not the day's)."""
        self._panel_cpu_s = []
        """CPU seconds of the panel processes at the day's start and end."""
        self.phase, self._phase_since = 'starting', self.started
        self.holds, self.held_s, self._held_since = 0, 0.0, None
        self.failed = False
        try:
            self._start(options)
        except BaseException:
            self._stop_children()
            raise

    def _start(self, options):
        plan = self.plan
        env = dict(os.environ, PYTHONUNBUFFERED='1')
        if options.record:
            self.observers.append(subprocess.Popen(
                plan.recorder_command(os.path.join(self.outputs, 'bag')), env=env))
        if options.rerun:
            self.observers.append(subprocess.Popen(
                plan.bridge_command(os.path.join(self.outputs, 'facade.rrd'), options.rerun),
                env=env))
        self.children = [subprocess.Popen(plan.panel_group_command(k), env=env)
                         for k in range(plan.panel_processes)]
        self.coordinator = CoordinatorNode(
            parameter_overrides=parameters(plan.coordinator_parameters()))
        self.nodes.append(self.coordinator)
        if not plan.panel_processes:
            self.panels = start_panels(self.facade.panel_ids, 'panel_group_0',
                                       parameter_overrides=parameters(plan.panel_parameters()))
            self.nodes += self.panels.nodes
        self.sun = SunPositionNode(parameter_overrides=parameters(plan.sun_parameters()))
        self.sun.hold()
        self.monitor = Monitor(self.facade)
        self.nodes += [self.sun, self.monitor]
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.monitor.create_timer(options.progress_period, self._print_progress, clock=steady)
        self.monitor.create_timer(0.25, self._advance, clock=steady)
        where = f'in {len(self.children)} processes' if self.children else 'in this process'
        print(f'facade: {self.facade.name}, {len(self.facade)} panels ({where}), '
              f'{plan.start_iso} .. {plan.end_iso} at {plan.speedup:g}x; Ctrl-C stops',
              flush=True)

    # -- phases -----------------------------------------------------------------------------

    def done(self):
        return self.phase == 'done'

    def _enter(self, phase):
        self.phase, self._phase_since = phase, time.monotonic()

    def _advance(self):
        waited = time.monotonic() - self._phase_since
        if self.phase == 'starting':
            self._while_starting(waited)
        elif self.phase == 'settling' and waited > MATCH_SETTLE_S:
            self._start_day()
        elif self.phase == 'day':
            self._hold_clock_for_laggards()
            if self.monitor.clock_s is not None and \
                    self.monitor.clock_s >= self.plan.end_epoch_s:
                self.day_ended = time.monotonic()
                self._panel_cpu_s.append(_processes_cpu_s(self.children))
                self._enter('ending')
        elif self.phase == 'ending':
            self._hold_clock_for_laggards()
            caught_up = self.monitor.caught_up(self.plan.end_epoch_s, self.plan.state_period_s)
            if (caught_up and waited > 1.5) or waited > CATCH_UP_WAIT_S:
                self._enter('draining' if self.observers else 'done')
        elif self.phase == 'draining' and waited > DRAIN_S:
            self._enter('done')

    def _while_starting(self, waited):
        ended = [process for process in self.children + self.observers
                 if process.poll() is not None]
        if ended:
            print(f'facade: {", ".join(_describe(process) for process in ended)} ended while '
                  f'starting; stopping', flush=True)
            self.failed = True
            self._enter('done')
            return
        ready = self.monitor.ready(len(self.observers))
        if ready and self.observers:
            self._enter('settling')
        elif ready:
            self._start_day()
        elif waited > START_WAIT_S:
            print(f'facade: not every panel and observer was up after {waited:.0f} s; '
                  f'starting the day anyway', flush=True)
            self._start_day()

    def _start_day(self):
        self.sun.release()
        self.day_started = time.monotonic()
        self._panel_cpu_s = [_processes_cpu_s(self.children)]
        self._enter('day')

    def _hold_clock_for_laggards(self):
        """Hold simulated time while a panel loop is more than MAX_LAG_S behind it."""
        lagging = self.monitor.lag_s(self.plan.start_epoch_s) > MAX_LAG_S
        if lagging and not self.sun.held:
            self.holds += 1
            self._held_since = time.monotonic()
            self.sun.hold()
        elif not lagging and self.sun.held:
            self.held_s += time.monotonic() - self._held_since
            self.sun.release()

    def _print_progress(self):
        elapsed = time.monotonic() - (self.started if self.phase in ('starting', 'settling')
                                      else self.day_started)
        line = (self.monitor.starting_line(len(self.observers))
                if self.phase in ('starting', 'settling')
                else self.monitor.progress_line(self.plan.start_epoch_s))
        print(f'[{elapsed:6.1f} s] {line}', flush=True)

    # -- the end ----------------------------------------------------------------------------

    def close(self, interrupted):
        wall_s = (self.day_ended or time.monotonic()) - self.day_started
        self._stop_children()
        if self.panels is not None:
            self.panels.close(interrupted)
        print('\n'.join(self.summary_lines(wall_s, interrupted,
                                           time.monotonic() - self.started)), flush=True)
        if self.outputs is not None:
            print('\n'.join(output_lines(self.outputs)), flush=True)
        if self.failed:
            return FAILED
        return INTERRUPTED if interrupted else 0

    def _stop_children(self):
        _stop(self.children, PANELS_STOP_S)
        _stop(self.observers, OBSERVERS_STOP_S)

    def summary_lines(self, wall_s, interrupted, process_wall_s):
        """Return the end-of-run summary: the day's figures, then CPU and memory.

        ``wall_s`` is the day's wall time (the speed-up); ``process_wall_s`` the whole run's,
        start-up included, over which the CPU time was spent.
        """
        facade, plan, monitor = self.facade, self.plan, self.monitor
        now_s = monitor.clock_s if monitor.clock_s is not None else plan.start_epoch_s
        sim_s = now_s - plan.start_epoch_s
        usage = resource.getrusage(resource.RUSAGE_SELF)
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu_s = usage.ru_utime + usage.ru_stime + children.ru_utime + children.ru_stime
        lines = [f'{facade.name}: {"interrupted" if interrupted else "day finished"} at '
                 f'{local_time(now_s, facade.utc_offset_h)} (local)',
                 f'  simulated {sim_s / 3600:.2f} h in {wall_s:.1f} s wall: '
                 f'{sim_s / max(wall_s, 1e-9):.0f}x real time (asked {plan.speedup:g}x)',
                 f'  panels reporting: {monitor.reporting()}/{len(facade)}; clock held '
                 f'{self.holds} times, {self.held_s:.1f} s wall, for panel loops more than '
                 f'{MAX_LAG_S:g} s behind']
        figures = self.coordinator.figures()
        if figures['decisions']:
            lines.append(f'  coordinator: {figures["decisions"]} decisions, moves per panel '
                         f'{figures["moves_mean"]:.1f} (max {figures["moves_max"]}), peak '
                         f'parallel fills {figures["peak_filling"]}, air budget '
                         f'{figures["air_used_nl"]:.0f} NL')
        if monitor.reporting():
            air = monitor.counter_total(contract.DIAGNOSTIC_FREE_AIR_NL)
            rejected = monitor.counter_total(contract.DIAGNOSTIC_SETPOINTS_REJECTED)
            timeouts = sum(status == contract.STATUS_TIMED_OUT
                           for status in monitor.statuses())
            lines += [f'  panels: air drawn {air:.0f} NL ({air / len(facade):.1f} NL per '
                      f'panel), final |closure - setpoint| max {monitor.tracking_error():.3f}',
                      f'  faults: {", ".join(monitor.faults()) or "none"}; setpoints rejected '
                      f'{rejected:.0f}; panels in setpoint timeout {timeouts}',
                      f'  simulation: at most {monitor.largest_behind_s():.1f} s behind the '
                      f'clock (a loop call works at most {MAX_CALL_S:g} s)']
        if self.children and len(self._panel_cpu_s) == 2 and None not in self._panel_cpu_s \
                and wall_s > 0.0:
            spent = self._panel_cpu_s[1] - self._panel_cpu_s[0]
            lines.append(f"  panel processes: {spent:.1f} CPU s in the day's {wall_s:.1f} s "
                         f'({spent / wall_s:.2f} cores together)')
        lines.append(f'  CPU {cpu_s:.1f} s in {process_wall_s:.0f} s '
                     f'({cpu_s / max(process_wall_s, 1e-9):.2f} cores); peak RSS '
                     f'{usage.ru_maxrss / 1024:.0f} MB this process'
                     + (f', {children.ru_maxrss / 1024:.0f} MB largest child'
                        if children.ru_maxrss else ''))
        return lines


def _stop(processes, timeout_s):
    """SIGINT every process that still runs (a terminal may have sent it already), then wait."""
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
    deadline = time.monotonic() + timeout_s
    for process in processes:
        try:
            process.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _processes_cpu_s(processes):
    """CPU seconds (user + system) the processes have used so far; None where /proc is not."""
    total = 0.0
    for process in processes:
        try:
            with open(f'/proc/{process.pid}/stat') as stat:
                fields = stat.read().rsplit(')', 1)[1].split()
        except OSError:
            return None
        total += (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')
    return total


def _describe(process):
    """Name a child process by its executable and how it ended: ``panel_group (exit 2)``."""
    command = process.args
    name = command[command.index('flectofold_ros') + 1] if 'flectofold_ros' in command \
        else command[0]
    return f'{name} (exit {process.returncode})'


def main(args=None):
    argv = remove_ros_args(args=sys.argv if args is None else args)[1:]
    options = parse_arguments(argv)

    def start():
        facade = load_facade(options.facade or DEFAULT_FACADE)
        plan = plan_day(facade, options.facade, options.date, options.start, options.end,
                        options.speedup, options.panel_processes, name=option_name)
        return Bringup(options, facade, plan)

    return run_nodes('facade', args, start, interrupted_code=INTERRUPTED)


if __name__ == '__main__':
    sys.exit(main())
