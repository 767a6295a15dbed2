"""Bring up a whole facade: sun, coordinator and every panel, through a simulated day.

``ros2 run flectofold_ros facade`` (or ``./run``): the embedded 6 x 6 demonstrator in
Stuttgart through the June solstice at 360 x. The sun node is the clock; the coordinator and
the panel nodes run on ``use_sim_time``. Panels run in this process on one events executor and
one vectorised loop, or split over ``--panel-processes`` child processes (``panel_group``).
A progress line while it runs, a summary at the end; Ctrl-C stops everything cleanly. The
child processes are supervised (:mod:`.supervision`): a dead one is restarted with back-off.
"""

import argparse
import datetime
import math
import os
import resource
import shutil
import sys
import tempfile
import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from flectofold_model.environment import read_weather, site_distance_deg, uncovered
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.bringup.fault_script import load_fault_script
from flectofold_ros.bringup.fault_script_node import FaultScriptNode
from flectofold_ros.bringup.monitor import Monitor
from flectofold_ros.bringup.plan import local_time, MAX_LAG_S, plan_day
from flectofold_ros.bringup.supervision import hangs, RestartPolicy, Supervisor
from flectofold_ros.commands.structure_cache import prepare_structural_map
from flectofold_ros.hardware.drivers import MAX_CALL_S
from flectofold_ros.nodes.coordinator import CoordinatorNode
from flectofold_ros.nodes.panel_group import group_slice
from flectofold_ros.nodes.panel_node import start_panels
from flectofold_ros.nodes.sun_position import SunPositionNode
from flectofold_ros.nodes.weather import WEATHER_SITE_TOLERANCE_DEG, WeatherNode
from flectofold_ros.recording import check_bag
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.domain_watch import Presence, StartCheck
from flectofold_ros.runtime.interfaces import publisher
from flectofold_ros.runtime.runner import NO_ROOM, Program, run_nodes, stop_requested
from flectofold_ros.sitenet.certificates import SiteError
from flectofold_ros.sitenet.fastdds_profile import (check_profile, listening_port,
                                                    process_profile, site_environment,
                                                    SITE_REMOVED)
from flectofold_ros.wire import contract, presence

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
#: Wall seconds the clock waits for a restarted panel process's panels to report again (twice
#: the start's wait: a restart competes with the running processes for the CPU).
RESTART_WAIT_S = 2.0 * START_WAIT_S
#: Wall seconds without /diagnostics (sent every second) after which a panel process that
#: reported before counts as hung and is killed, to be restarted; one that never reported
#: counts as hung START_WAIT_S after its start.
HUNG_S = 15.0
#: Exit codes of a day that was interrupted, of one whose processes failed to start, of one
#: that lost a supervised process for good, and of one stopped because another facade or a
#: second clock came on its ROS domain.
INTERRUPTED, FAILED, LOST, CONFLICT = 130, 1, 3, 5


#: What the end-of-run summary's figures mean (``--help`` and the summary's last lines).
FIGURES_HELP = (
    'the summary at the end:\n'
    '  NL                  normal litres: free air at the ISO 8778 reference atmosphere\n'
    '                      (20 degC, 100 kPa), as compressor capacities are rated\n'
    '  clock held          times (and wall seconds) the simulated clock was stopped so that\n'
    '                      lagging panel loops or restarting panel processes catch up\n'
    "  air budget          the coordinator's estimate of the air its closing moves need\n"
    '                      (its compressed-air token bucket, scheduling.md)\n'
    "  air drawn           the free air the panels' fill valves took from the supply\n"
    '  |closure - setpoint| the tracking error at the end, closure 0 open .. 1 closed\n'
    '  behind the clock    how far the slowest panel simulation lagged simulated time [s]\n'
    '  cores               CPU seconds per wall second (1.00 = one core busy)')


def parse_arguments(argv):
    parser = argparse.ArgumentParser(prog='facade', description=__doc__.split('\n')[0],
                                     epilog=FIGURES_HELP,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
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
    parser.add_argument('--markers', action='store_true',
                        help='start facade_markers: the folded facade on /facade/markers for '
                             'RViz and Foxglove (fixed frame site_enu; config/facade.rviz, '
                             'msg_docs/markers.md)')
    parser.add_argument('--out', default='out',
                        help='directory for the bag and the .rrd (default out/); each run '
                             'gets a folder, out/latest points to the newest')
    parser.add_argument('--faults', default='', metavar='FILE',
                        help='fault script YAML: faults injected into simulated panels at '
                             'chosen times (msg_docs/fault_injection.md)')
    parser.add_argument('--weather', default='', metavar='FILE',
                        help='play this EPW or TMY3 weather file into the coordinator (DNI, '
                             'wind: storms happen); the day maps into the file by day of year '
                             '(msg_docs/weather.md)')
    parser.add_argument('--restart-limit', type=int, default=RestartPolicy.restart_limit,
                        help='restarts of a child process that keeps dying before its panels '
                             f'are given up (default {RestartPolicy.restart_limit}; 0: never '
                             'restart)')
    parser.add_argument('--site-profile', default='', metavar='XML',
                        help='run every process of the facade on this Fast DDS profile '
                             '(site_certificates makes one per host: TCP with mutual TLS on '
                             'the site network), each process on a TCP port of its own from '
                             "the profile's (msg_docs/security.md); default: none, ROS's "
                             'loopback-only discovery')
    options = parser.parse_args(argv)
    if not 0 <= options.restart_limit <= 1000:
        parser.error(f'--restart-limit must lie in [0, 1000], got {options.restart_limit}')
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
        self.supervisor = Supervisor(RestartPolicy(restart_limit=options.restart_limit))
        self._awaiting = {}
        """Restarted panel processes the clock waits for: name -> wall deadline [s]."""
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
        self.hold_causes = set()
        """Why the clock was held: 'lag', 'restart'."""
        self.failed = False
        self.conflicts, self.conflict_at_s = [], None
        """Another facade or clock heard on the domain while running; where the day stopped."""
        try:
            self._start(options)
        except BaseException:
            self._stop_children()
            raise

    def _start(self, options):
        plan = self.plan
        self.monitor = Monitor(self.facade)
        self._diagnostics = publisher(self.monitor, contract.DIAGNOSTICS)
        self._refuse_beside_another_facade()
        env = dict(os.environ, PYTHONUNBUFFERED='1')
        supervisor, outputs = self.supervisor, self.outputs
        # on a site profile, child k gets the profile of process k + 1 (site_processes)
        profiles = iter(getattr(options, 'site_profiles', [])[1:])

        def child_env():
            path = next(profiles, None)
            return env if path is None else dict(env, FASTRTPS_DEFAULT_PROFILES_FILE=path,
                                                 FASTDDS_DEFAULT_PROFILES_FILE=path)
        if options.record:
            supervisor.add('bag_recorder', lambda start: plan.recorder_command(
                os.path.join(outputs, _numbered('bag', start))), env=child_env())
        if options.rerun:
            supervisor.add('rerun_bridge', lambda start: plan.bridge_command(
                os.path.join(outputs, _numbered('facade', start) + '.rrd'), options.rerun),
                env=child_env())
        if options.markers:
            supervisor.add('facade_markers', lambda start: plan.markers_command(),
                           env=child_env())
        groups = plan.panel_processes
        for k in range(groups):
            supervisor.add(f'panel_group {k}/{groups}',
                           lambda start, k=k: plan.panel_group_command(k),
                           group_slice(self.facade.panel_ids, k, groups), child_env(),
                           settings_node=f'panel_group_{k}')
        self.coordinator = CoordinatorNode(
            parameter_overrides=parameters(plan.coordinator_parameters()))
        self.coordinator.presence = self.presence
        self.nodes.append(self.coordinator)
        if not plan.panel_processes:
            self.panels = start_panels(self.facade.panel_ids, 'panel_group_0',
                                       parameter_overrides=parameters(plan.panel_parameters()))
            self.nodes += self.panels.nodes
        self.sun = SunPositionNode(parameter_overrides=parameters(plan.sun_parameters()))
        self.sun.hold()
        self.monitor.own_clock = self.sun.sent_clock
        if options.weather:
            self.nodes.append(self._weather_node(options.weather))
        self.nodes += [self.sun, self.monitor]
        if options.faults:
            script = load_fault_script(options.faults, self.facade.panel_ids,
                                       plan.start_epoch_s, plan.end_epoch_s,
                                       self.facade.utc_offset_h)
            self.nodes.append(FaultScriptNode(script, plan.start_epoch_s,
                                              subscribers=max(1, groups)))
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.monitor.create_timer(options.progress_period, self._print_progress, clock=steady)
        self.monitor.create_timer(0.25, self._advance, clock=steady)
        where = f'in {groups} processes' if groups else 'in this process'
        print(f'facade: {self.facade.name}, {len(self.facade)} panels ({where}), '
              f'{plan.start_iso} .. {plan.end_iso} at {plan.speedup:g}x; Ctrl-C stops',
              flush=True)

    def _refuse_beside_another_facade(self):
        """Listen for another live facade on the domain; refuse to start beside it (exit 2).

        This process holds the clock and the coordinator (and the panels when it runs them);
        its children announce their own panels.
        """
        namespace = contract.FACADE_NODE_NAMESPACE
        own = presence.this_process(
            presence.BRINGUP, self.facade.name,
            [self.monitor.get_fully_qualified_name(), f'{namespace}/{contract.COORDINATOR_NODE}',
             f'{namespace}/{contract.SUN_POSITION_NODE}'],
            () if self.plan.panel_processes else self.facade.panel_ids, clock=True)
        StartCheck('facade_start_check').refuse(own)
        self.presence = Presence(self.monitor, own, on_conflict=self._conflict)
        self.presence.announce()

    def _conflict(self, line):
        """Stop the day: another facade (or a second clock) is on the domain."""
        if line in self.conflicts:
            return
        self.conflicts.append(line)
        print(f'facade: ERROR: {line}; stopping the day', flush=True)
        self._diagnostics.publish(diagnostics.diagnostic_array(self.monitor, [
            diagnostics.status(self.monitor, diagnostics.ERROR, 'domain', self.facade.name,
                               f'another facade on this ROS domain: {line}',
                               {'conflicts': len(self.conflicts)})]))
        self.conflict_at_s = self.monitor.clock_s
        self._enter('done')

    def _check_clock_source(self):
        """Stop the day on a /clock this bringup did not send: a second clock."""
        if self.monitor.foreign_clock:
            names = sorted(set(self._clock_publishers()))
            self._conflict(f'a second {contract.CLOCK.name} ({self.monitor.foreign_clock} '
                           f'message(s) this bringup did not send); its publishers: '
                           f'{"; ".join(self.presence.who(name) for name in names)}')

    def _clock_publishers(self):
        for info in self.monitor.get_publishers_info_by_topic(contract.CLOCK.name):
            yield f'{info.node_namespace.rstrip("/")}/{info.node_name}'

    def _weather_node(self, path):
        node = WeatherNode(parameter_overrides=parameters(self.plan.weather_parameters(path)))
        away_deg = site_distance_deg(self.sun.site, node.weather)
        if away_deg > WEATHER_SITE_TOLERANCE_DEG:
            print(f'facade: warning: the weather file {node.weather.source} is for a site '
                  f'{away_deg:.1f} deg away from the facade; the sun is still computed for the '
                  'facade site',
                  file=sys.stderr, flush=True)
        return node

    # -- phases -----------------------------------------------------------------------------

    def done(self):
        return self.phase == 'done'

    def _enter(self, phase):
        self.phase, self._phase_since = phase, time.monotonic()

    @property
    def observers(self):
        return [child for child in self.supervisor.children if not child.panels]

    def _panel_processes(self):
        return self.supervisor.processes(panels=True)

    def _advance(self):
        if stop_requested():  # children stopping on the same Ctrl-C are not deaths
            return
        waited = time.monotonic() - self._phase_since
        if self.phase != 'done':
            self._check_clock_source()
        if self.phase not in ('starting', 'done'):
            self._supervise()
        if self.phase == 'starting':
            self._while_starting(waited)
        elif self.phase == 'settling' and waited > MATCH_SETTLE_S:
            self._start_day()
        elif self.phase == 'day':
            self._hold_clock()
            if self.monitor.clock_s is not None and \
                    self.monitor.clock_s >= self.plan.end_epoch_s:
                self.day_ended = time.monotonic()
                self._panel_cpu_s.append(_processes_cpu_s(self._panel_processes()))
                self._enter('ending')
        elif self.phase == 'ending':
            self._hold_clock()
            caught_up = self.monitor.caught_up(self.plan.end_epoch_s, self.plan.state_period_s)
            if (caught_up and waited > 1.5) or waited > CATCH_UP_WAIT_S:
                self._enter('draining' if self.observers else 'done')
        elif self.phase == 'draining' and waited > DRAIN_S:
            self._enter('done')

    def _while_starting(self, waited):
        self.supervisor.check()
        ended = self.supervisor.ended_while_starting()
        if ended:
            print(f'facade: {", ".join(_describe(child) for child in ended)} ended while '
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
        self._panel_cpu_s = [_processes_cpu_s(self._panel_processes())]
        self._enter('day')

    # -- supervision ------------------------------------------------------------------------

    def _supervise(self):
        """Log deaths and restarts; forget a dead process's panels until they report again."""
        self._kill_hung()
        events = self.supervisor.check()
        for child, text in events:
            if child.state == 'running':  # rclpy wants one severity per call site
                self.monitor.get_logger().info(text)
            else:
                self.monitor.get_logger().warning(text)
            print(f'facade: {text}', flush=True)
            if child.deaths and child.deaths[-1].sim_time_s is None:
                child.deaths[-1].sim_time_s = self.monitor.clock_s
            if child.panels:
                self.monitor.process_heard_s.pop(child.settings_node, None)
            if child.lost:
                self.monitor.lose(child.panels)
                self._awaiting.pop(child.name, None)
            elif child.state == 'restarting':
                self.monitor.forget(child.panels)
                self._awaiting[child.name] = math.inf
            elif child.panels:
                self._awaiting[child.name] = time.monotonic() + RESTART_WAIT_S
        for child in self.supervisor.children:
            if child.name in self._awaiting and child.state == 'running' and (
                    self._back(child) or time.monotonic() > self._awaiting[child.name]):
                del self._awaiting[child.name]
        if events:
            self._publish_supervision()

    def _back(self, child):
        """Whether a restarted panel process is back: its panels or its own status reported.

        Its own status on /diagnostics comes on the wall clock, at every diagnostics period;
        its panels' states only as its loop runs, which a held clock does not let it do, and
        the first of them may go out before the monitor's subscription has matched it.
        """
        return (self.monitor.heard(child.panels) or
                child.settings_node in self.monitor.process_heard_s)

    def _kill_hung(self):
        """Kill a running panel process that hangs (:func:`supervision.hangs`)."""
        now_s = time.monotonic()
        for child in self.supervisor.children:
            if child.panels and child.state == 'running':
                why = hangs(self.monitor.silent_s(child.settings_node, child.panels),
                            self.monitor.reported(child.settings_node, child.panels),
                            now_s - child.started_at_s, HUNG_S, START_WAIT_S)
                if why:
                    self.supervisor.kill_hung(child, why)

    def _publish_supervision(self):
        """One status per supervised process on /diagnostics (OK, WARN restarting, ERROR lost)."""
        levels = {'running': diagnostics.OK, 'restarting': diagnostics.WARN,
                  'lost': diagnostics.ERROR}
        statuses = []
        for child in self.supervisor.children:
            last = child.deaths[-1].cause if child.deaths else ''
            statuses.append(diagnostics.status(
                self.monitor, levels[child.state], 'supervision', child.name, child.state,
                {'pid': child.process.pid, 'restarts': child.restarts,
                 'deaths': len(child.deaths), 'last_death': last,
                 'panels': len(child.panels)}))
        self._diagnostics.publish(diagnostics.diagnostic_array(self.monitor, statuses))

    def _hold_clock(self):
        """Hold simulated time while a panel loop lags or a panel process restarts.

        A loop lags when it is more than MAX_LAG_S behind the clock; a dead panel process
        holds the clock until its restart is back (:meth:`_back`; or RESTART_WAIT_S passed).
        """
        causes = set()
        if self.monitor.lag_s(self.plan.start_epoch_s) > MAX_LAG_S:
            causes.add('lag')
        if self._awaiting:
            causes.add('restart')
        self.hold_causes |= causes
        if causes and not self.sun.held:
            self.holds += 1
            self._held_since = time.monotonic()
            self.sun.hold()
        elif not causes and self.sun.held:
            self.held_s += time.monotonic() - self._held_since
            self.sun.release()

    def _print_progress(self):
        elapsed = time.monotonic() - (self.started if self.phase in ('starting', 'settling')
                                      else self.day_started)
        line = (self.monitor.starting_line(len(self.observers))
                if self.phase in ('starting', 'settling')
                else self.monitor.progress_line(self.plan.start_epoch_s))
        down = [child.name for child in self.supervisor.children
                if child.state == 'restarting' or child.name in self._awaiting]
        if down:
            line += f' | restarting {", ".join(down)}'
        print(f'[{elapsed:6.1f} s] {line}', flush=True)
        if self.supervisor.deaths():
            self._publish_supervision()

    # -- the end ----------------------------------------------------------------------------

    def close(self, interrupted):
        wall_s = (self.day_ended or time.monotonic()) - self.day_started
        self._stop_children()
        if self.panels is not None:
            self.panels.close(interrupted)
        print('\n'.join(self.summary_lines(wall_s, interrupted,
                                           time.monotonic() - self.started)), flush=True)
        if self.outputs is not None:
            print('\n'.join(output_lines(self.outputs) + self._recording_lines()), flush=True)
        if self.failed:
            return FAILED
        if self.conflicts:
            return CONFLICT
        if interrupted:
            return INTERRUPTED
        return LOST if any(child.lost for child in self.supervisor.children) else 0

    def _recording_lines(self):
        """Whether each bag the recorder (and its restarts) wrote is complete; what is not in it.

        A recorder that stopped because its disk has no room is not restarted onto it: the
        rest of the day is not recorded, and the line says from when.
        """
        bags = sorted(name for name in os.listdir(self.outputs)
                      if name == 'bag' or name.startswith('bag.restart'))
        lines = ['  ' + check_bag(os.path.join(self.outputs, name)).summary() for name in bags]
        for child in self.supervisor.children:
            death = child.deaths[-1] if child.lost and child.deaths else None
            if child.name == 'bag_recorder' and death and death.returncode == NO_ROOM:
                offset = self.facade.utc_offset_h
                since = ('the start' if death.sim_time_s is None else
                         local_time(death.sim_time_s, offset)[-5:])
                until = local_time(self.plan.end_epoch_s, offset)[-5:]
                lines.append(f'  NOT RECORDED: from {since} to {until} (local): the recorder '
                             f'stopped, its disk ({self.outputs}) has no room; it was not '
                             f'restarted onto it')
        return lines

    def _stop_children(self):
        self.supervisor.stop(PANELS_STOP_S, panels=True)
        self.supervisor.stop(OBSERVERS_STOP_S, panels=False)

    def _supervision_lines(self):
        """Every death and restart of a supervised process, and the panels lost."""
        deaths = self.supervisor.deaths()
        if not deaths:
            return ['  supervision: no process died']
        lost = self.supervisor.panels_lost()
        restarts = sum(death.restarted_at_s is not None for death in deaths)
        offset = self.facade.utc_offset_h

        def when(death):
            return ('the start' if death.sim_time_s is None else
                    local_time(death.sim_time_s, offset)[-5:] + ' (local)')
        return ([f'  supervision: {len(deaths)} deaths, {restarts} restarts, '
                 f'{len(lost)} panels lost for good' +
                 (f' ({", ".join(lost[:6])}{" ..." if len(lost) > 6 else ""})' if lost else '')]
                + self.supervisor.summary_lines(when))

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
        ending = ('stopped: another facade on the domain' if self.conflicts else
                  'interrupted' if interrupted else 'day finished')
        lines = [f'{facade.name}: {ending} at '
                 f'{local_time(now_s, facade.utc_offset_h)} (local)',
                 f'  simulated {sim_s / 3600:.2f} h in {wall_s:.1f} s wall: '
                 f'{sim_s / max(wall_s, 1e-9):.0f}x real time (asked {plan.speedup:g}x)',
                 f'  panels reporting: {monitor.reporting()}/{len(facade)}; clock held '
                 f'{self.holds} times, {self.held_s:.1f} s wall, for panel loops more than '
                 f'{MAX_LAG_S:g} s behind' +
                 (' or restarting panel processes' if 'restart' in self.hold_causes else '')]
        lines += self._supervision_lines()
        if self.conflicts:
            when = ('the start' if self.conflict_at_s is None else
                    local_time(self.conflict_at_s, facade.utc_offset_h)[-5:] + ' (local)')
            lines += [f'  CONFLICT: the day was stopped at {when}: another facade on this ROS '
                      f'domain: {line}' for line in self.conflicts]
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
        if self._panel_processes() and len(self._panel_cpu_s) == 2 and \
                None not in self._panel_cpu_s and wall_s > 0.0 and not self.supervisor.deaths():
            spent = self._panel_cpu_s[1] - self._panel_cpu_s[0]
            lines.append(f"  panel processes: {spent:.1f} CPU s in the day's {wall_s:.1f} s "
                         f'({spent / wall_s:.2f} cores together)')
        lines.append(f'  CPU {cpu_s:.1f} s in {process_wall_s:.0f} s '
                     f'({cpu_s / max(process_wall_s, 1e-9):.2f} cores); peak RSS '
                     f'{usage.ru_maxrss / 1024:.0f} MB this process'
                     + (f', {children.ru_maxrss / 1024:.0f} MB largest child'
                        if children.ru_maxrss else ''))
        lines.append('  (NL: normal litres of free air, ISO 8778: 20 degC, 100 kPa; '
                     '`facade --help` explains every figure)')
        return lines


def _numbered(name, start):
    """Output of start ``start`` of an observer: ``bag``, then ``bag.restart1`` ..."""
    return name if start == 0 else f'{name}.restart{start}'


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


def check_weather(path, plan):
    """Refuse (``ValueError``) a weather file that cannot be read or misses the planned day."""
    try:
        weather = read_weather(path)
    except OSError as error:
        raise ValueError(f'--weather {path}: cannot be read: {error.strerror or error}') from None
    start, end = (np.datetime64(round(t * 1e9), 'ns')
                  for t in (plan.start_epoch_s, plan.end_epoch_s))
    if reason := uncovered(weather, start, end):
        raise ValueError(f'--weather: the day {plan.start_iso} .. {plan.end_iso}: {reason}; '
                         f'choose a --date it covers or a file that covers the date')


def site_processes(options):
    """Write the site profile of each process of the run; return their paths (this one first).

    One TCP port per process (:func:`~flectofold_ros.sitenet.fastdds_profile.process_profile`):
    this process takes the profile's port P, then each child in the order they start (the
    recorder, the bridge, the markers, the panel processes) P + 1, P + 2 ... Written to a new
    temporary directory, removed when the run ends; the files name the keys, they hold none.
    """
    check_profile(options.site_profile)
    count = (1 + max(options.panel_processes, 0) + bool(options.record) + bool(options.rerun) +
             bool(options.markers))
    directory = tempfile.mkdtemp(prefix='flectofold_site_')
    paths = []
    first_panel_process = count - max(options.panel_processes, 0)
    try:
        for index in range(count):
            path = os.path.join(directory, f'process_{index}.xml')
            with open(path, 'w') as handle:
                handle.write(process_profile(options.site_profile, index, count,
                                             panel_process=index >= first_panel_process))
            paths.append(path)
    except BaseException:
        shutil.rmtree(directory, ignore_errors=True)
        raise
    port = listening_port(options.site_profile)
    print(f'facade: site profile {options.site_profile}: {count} processes on TCP ports '
          f'{port}-{port + count - 1} (list them all on the other hosts: --peer IP:P-Q)',
          flush=True)
    return paths


def _describe(child):
    """Name a child and how it ended: ``panel_group 0/2 (exit 2)``."""
    return f'{child.name} ({child.deaths[-1].cause})'


def main(args=None):
    argv = remove_ros_args(args=sys.argv if args is None else args)[1:]
    options = parse_arguments(argv)
    if options.site_profile:
        # checked, and in the environment of this process and every child, before rclpy
        # starts and before any child does
        try:
            options.site_profiles = site_processes(options)
            os.environ.update(site_environment(options.site_profiles[0], os.environ))
        except SiteError as error:
            print(f'facade: --site-profile: {error}', file=sys.stderr, flush=True)
            return 2
        for name in SITE_REMOVED:
            os.environ.pop(name, None)

    def start():
        facade = load_facade(options.facade or DEFAULT_FACADE)
        plan = plan_day(facade, options.facade, options.date, options.start, options.end,
                        options.speedup, options.panel_processes, name=option_name)
        if options.weather:  # read and checked before any child starts
            check_weather(options.weather, plan)
        # before any child starts: they only read the cache, and must start in seconds
        prepare_structural_map(facade, 'facade')
        return Bringup(options, facade, plan)

    try:
        return run_nodes('facade', args, start, interrupted_code=INTERRUPTED)
    finally:
        if getattr(options, 'site_profiles', None):  # every child has stopped by now
            shutil.rmtree(os.path.dirname(options.site_profiles[0]), ignore_errors=True)


if __name__ == '__main__':
    sys.exit(main())
