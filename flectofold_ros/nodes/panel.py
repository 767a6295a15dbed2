"""Flectofold panels on the graph: closure setpoints in; pressure, fold angles, state out.

A panel process (``panel_node``: one panel; ``panel_group``: many) runs every panel's pressure
loop in one :class:`flectofold_model.control.PanelLoops`, so the numerics run vectorised, and
drives the ROS side from one timer (:class:`PanelProcess`): each tick it runs the loops up to
the clock, then publishes. Each panel keeps its own node (:class:`PanelNode`) with its topics
and service; what costs with the panel count is done once per process: the timer, the clock,
``/diagnostics`` (one array of every panel's status), the facade-level state topics
(``/facade/joint_states``, ``/facade/panel_states``), the fault injection of simulated panels
(``/facade/inject_fault``, ``msg_docs/fault_injection.md``) and the parameters (on the
process's settings node). A panel's own state topics go out at the full rate while its loop
moves it, and at a heartbeat at rest. Topics, parameters, QoS and when each is published:
``msg_docs/panel_node.md`` and ``msg_docs/facade_state.md``.
"""

import array
import math
import os
from pathlib import Path
import sys
import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import FluidPressure, JointState, PointCloud2, PointField
from std_msgs.msg import Float64, String

from flectofold_model.control import (compile_kernels, ControllerParameters, facade_loops, Fault,
                                      PublishDecimator, SafeAction, SafeBehaviour, SetpointGuard,
                                      SetpointState)
from flectofold_model.control.hardware import SimulatedCushions
from flectofold_model.control.panel_loops import LoopSample, panel_indices
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.kinds import panel_kind
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.domain_watch import (log_with_senders, log_with_service_clients,
                                                 Presence, report_domain, SourceGuard,
                                                 StartCheck)
from flectofold_ros.runtime.interfaces import publisher, service, subscription
from flectofold_ros.runtime.parameters import choice, declare_all, double, integer, string
from flectofold_ros.runtime.runner import Program, run_nodes
from flectofold_ros.wire import contract, facade_setpoints, panel_states, presence
from flectofold_ros.wire.fault_injection import FaultInjector, FaultRequestError, parse_request

#: The cushion drivers there are (``hardware``), each built in :func:`build_loops`:
#: ``simulated`` (the plant model) and ``modbus`` (a Modbus TCP valve terminal,
#: ``msg_docs/modbus.md``).
DRIVERS = ('simulated', 'modbus')
#: name -> Spec. The loop settings (read-only) must agree between the panel nodes of one
#: process, since they share one vectorised loop.
PARAMETERS = {
    'panel_id': string('', 'Panel id rNNcNN; empty: the last token of the namespace'),
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'hardware': choice('simulated', 'Cushion driver', DRIVERS),
    'modbus.map_file': string('', "hardware modbus: the valve terminal's register map YAML "
                              '(msg_docs/modbus.md)'),
    'modbus.host': string('127.0.0.1', "hardware modbus: the terminal's host name or address"),
    'modbus.port': integer(502, "hardware modbus: the terminal's Modbus TCP port", 1, 65535),
    'modbus.timeout_s': double(
        0.05, 'hardware modbus: longest wait for a reply [s]; a late one is comms_lost',
        0.001, 1.0),
    'control_period_s': double(0.1, 'Pressure loop period [s]', 0.01, 1.0),
    'control.time_constant_s': double(
        0.4, 'Closed-loop time constant [s], at least twice control_period_s', 0.02, 10.0),
    'control.hold_band_pa': double(
        60.0, 'At rest the valves stay shut within this of the target [Pa]; 3 sensor sigmas',
        0.0, 1000.0),
    'simulation.quiet_period_s': double(
        2.0, 'Simulated cushions: longest loop period while every panel of the process rests '
        '[s]', 0.01, 60.0),
    'max_gauge_pressure_pa': double(12e3, 'Hard cushion pressure limit [Pa gauge]', 2e3, 14e3),
    'publish_rate_hz': double(10.0, 'Rate of pressure, joint_states and closure [Hz]',
                              0.001, 100.0),
    'heartbeat_period_s': double(
        1.0, "At rest, the period of each panel's own state topics [s of ROS time]",
        0.01, 3600.0),
    'diagnostics_period_s': double(1.0, 'Period of /diagnostics, wall clock [s]', 0.1, 60.0),
    'setpoint_timeout_s': double(
        10.0, 'No valid setpoint for this long (ROS time) starts the safe behaviour [s]',
        0.1, 86400.0, read_only=False),
    'safe_behaviour': choice('vent', 'After a setpoint timeout: vent (open) or hold',
                             ['vent', 'hold'], read_only=False),
    'fault_action': choice('vent', 'On a latched circuit fault: vent or hold (a fill valve '
                           'stuck open always vents)', ['vent', 'hold'], read_only=False),
}
LOOP_SETTINGS = ('facade_file', 'hardware', 'control_period_s', 'control.time_constant_s',
                 'control.hold_band_pa', 'simulation.quiet_period_s', 'max_gauge_pressure_pa',
                 'modbus.map_file', 'modbus.host', 'modbus.port', 'modbus.timeout_s')
#: Longest one loop call works [s, wall clock]: a process that cannot keep up with its clock
#: still publishes and answers signals between calls.
MAX_CALL_S = 0.25
#: A loop further behind its clock than this says it is overloaded [s].
OVERLOADED_S = 1.0
#: A tick publishes at most this many of the states its loop kept since the last one (the
#: newest): a loop catching up hours keeps thousands, which would starve the process.
MAX_STATES_PER_TICK = 20
#: Panel statuses in one ``/diagnostics`` message at most: a process of more panels reports
#: them in slices spread over the period (building a status costs about 45 us, so a report of
#: 1,000 panels in one go held the tick up by 46 ms once a second).
STATUSES_PER_MESSAGE = 50
#: The Fast DDS profile a panel process uses unless the user gives one (see the file).
FASTDDS_PROFILE = Path(__file__).resolve().parent.parent / 'fastdds_panel_process.xml'
PROFILE_VARIABLES = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
USAGE = 'panel_node --ros-args -r __ns:=/facade/<id> [-p name:=value ...]'
_STATUS_CODE = {word: code for code, word in enumerate(contract.STATUSES)}
_FAULT_STATUS = _STATUS_CODE[contract.STATUS_FAULT]


class PanelNode(Node):
    """Node ``panel`` in namespace ``/facade/<id>``: one panel's topics and service.

    ``settings``: the node declares the process's parameters and serves them (``panel_node``,
    one panel); otherwise (``panel_group``) it has no parameters of its own, no parameter
    services and no clock of its own, which is what lets a thousand of them start in seconds:
    the group's settings node holds those for all.
    """

    def __init__(self, panel_id=None, settings=True, **kwargs):
        if panel_id:
            kwargs.setdefault('namespace', contract.panel_namespace(panel_id))
        if not settings:
            kwargs['start_parameter_services'] = False
            kwargs['parameter_overrides'] = [Parameter('use_sim_time', value=False)]
        super().__init__(contract.PANEL_NODE, **kwargs)
        if settings:
            declare_all(self, PARAMETERS)
        self.panel_id = self._resolve_id(panel_id, settings)
        self.process, self.index = None, None

    def _resolve_id(self, panel_id, settings):
        given = panel_id or (self.get_parameter('panel_id').value if settings else '')
        from_namespace = self.get_namespace().rstrip('/').rsplit('/', 1)[-1]
        if given and self.get_namespace() != '/' and from_namespace != given:
            raise ValueError(
                f'panel_id {given!r} and namespace {self.get_namespace()!r} disagree: the node '
                f'would sit in one and serve the topics of the other; give one of them')
        panel_id = given or from_namespace
        if not contract.PANEL_ID.fullmatch(panel_id or ''):
            raise ValueError(
                f'panel id {panel_id!r} is not of the form rNNcNN: run the node in namespace '
                f'/facade/<id> (--ros-args -r __ns:=/facade/r00c00) or set panel_id')
        return panel_id

    def attach(self, process, index):
        """Become panel ``index`` of ``process`` (a :class:`PanelProcess`): topics, service."""
        self.process, self.index = process, index
        panel = self.panel_id
        self._pressure = publisher(self, contract.PRESSURE.of(panel))
        self._joints = publisher(self, contract.JOINT_STATES.of(panel))
        self._closure = publisher(self, contract.CLOSURE.of(panel))
        self._fault = publisher(self, contract.FAULT.of(panel))
        self._status = publisher(self, contract.STATUS.of(panel))
        subscription(self, contract.SETPOINT.of(panel), self._on_setpoint)
        service(self, contract.reset_faults_service(panel), self._on_reset_faults,
                contract.RESET_FAULTS_TYPE)
        # One message of each kind, refilled for every state: building them costs more than
        # sending them.
        self._pressure_message = FluidPressure(
            variance=process.loops.driver.circuit.sensor_noise_pa ** 2)
        self._pressure_message.header.frame_id = panel
        self._joints_message = JointState(name=contract.flap_joint_names(panel, process.kind))
        self._flap_count = len(self._joints_message.name)
        self._closure_message = Float64()

    def _on_setpoint(self, message):
        self.process.offer(self.index, message.data, self.get_logger())

    def _on_reset_faults(self, request, response):
        response.success, response.message = True, self.process.reset_faults(self.index)
        return response

    def publish_state(self, stamp, closure, fold_angle_rad, measured_pa):
        """Publish ``pressure`` (when there is a reading), ``joint_states`` and ``closure``."""
        if math.isfinite(measured_pa):
            pressure = self._pressure_message
            pressure.fluid_pressure, pressure.header.stamp = measured_pa, stamp
            self._pressure.publish(pressure)
        joints = self._joints_message
        joints.header.stamp, joints.position = stamp, [fold_angle_rad] * self._flap_count
        self._joints.publish(joints)
        closure_message = self._closure_message
        closure_message.data = closure
        self._closure.publish(closure_message)

    def publish_fault(self, word):
        """Publish the latched ``fault``."""
        self._fault.publish(String(data=word))

    def publish_status(self, word):
        """Publish the latched ``status``."""
        self._status.publish(String(data=word))


class PanelProcess:
    """The panels of one process: one loop, one timer, the facade-level topics, diagnostics.

    ``settings`` is the node whose parameters the process runs with (and whose clock it
    reads); ``panels`` the :class:`PanelNode` objects, in the order of ``loops``' rows;
    ``positions_enu`` their origins in the site's frame (N, 3) [m]; ``facade_ids`` every
    panel id of the facade (a fault request naming another is refused; default: the
    process's).
    """

    def __init__(self, settings, panels, loops, positions_enu, facade_ids=None, kind='quad'):
        self.settings, self.panels, self.loops = settings, panels, loops
        value = self._value
        count = len(panels)
        self.guards = [SetpointGuard(value('setpoint_timeout_s'),
                                     SafeBehaviour(value('safe_behaviour')))
                       for _ in range(count)]
        loops.set_safe_action(SafeAction(value('fault_action')))
        self.control_period_s = value('control_period_s')
        self.heartbeat_s = value('heartbeat_period_s')
        state_period_s = 1.0 / value('publish_rate_hz')
        loops.request_sample_period(0, state_period_s)
        # Half a loop period of slack: a state rounding puts a hair early still counts.
        self._slack_s = 0.5 * self.control_period_s
        self._decimator = PublishDecimator(state_period_s, self._slack_s)
        self._last_sequence = 0
        self._setpoints = np.zeros(count)
        self._status = np.zeros(count, dtype=np.uint8)
        self._published_fault = np.full(count, -1)
        self._published_status = np.full(count, -1)
        self._published_s = np.full(count, -math.inf)
        self._published_reading = np.zeros(count, dtype=bool)
        self._was_active = np.zeros(count, dtype=bool)
        self._rejected_since_report = np.zeros(count, dtype=np.int64)
        self.states_skipped = 0
        self.states_published = 0
        self._tick_intervals_s, self._last_tick_s = [], None
        self._tick_cpu_s = 0.0
        self._table = panel_states.new_table(count)
        self._table['x'], self._table['y'], self._table['z'] = positions_enu.T
        self._table['row'], self._table['column'] = panel_states.id_numbers(
            [panel.panel_id for panel in panels])
        self._cloud = PointCloud2()
        self.kind = kind
        self._joint_states = JointState(name=[name for panel in panels
                                              for name in contract.flap_joint_names(
                                                  panel.panel_id, kind)])
        self._flaps_per_panel = len(contract.FLAPS[kind])
        self._cloud_publisher = publisher(settings, contract.PANEL_STATES)
        self._joints_publisher = publisher(settings, contract.FACADE_JOINT_STATES)
        self._diagnostics = publisher(settings, contract.DIAGNOSTICS)
        for index, panel in enumerate(panels):
            panel.attach(self, index)
        self._start_fault_injection(facade_ids)
        self._index_of = {panel.panel_id: index for index, panel in enumerate(panels)}
        self.setpoint_messages_refused, self.last_setpoints_refusal = 0, ''
        self._setpoint_refusals_since_report = 0
        self.presence = None
        """The process's :class:`~flectofold_ros.runtime.domain_watch.Presence` (set by
        start_panels)."""
        watched = [contract.FACADE_SETPOINTS.name]
        if settings.get_parameter('use_sim_time').value:
            watched.append(contract.CLOCK.name)
        self.sources = SourceGuard(settings, watched, who=self._who)
        subscription(settings, contract.FACADE_SETPOINTS, self._on_facade_setpoints)
        settings.add_post_set_parameters_callback(self._apply_parameters)
        self._tick_timer = settings.create_timer(self.control_period_s, self._tick)
        self._report_slices = [range(start, min(start + STATUSES_PER_MESSAGE, count))
                               for start in range(0, count, STATUSES_PER_MESSAGE)]
        self._next_slice = 0
        settings.create_timer(value('diagnostics_period_s') / len(self._report_slices),
                              self._report,
                              clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._publish_latched(np.full(count, _STATUS_CODE[SetpointState.WAITING.value]))

    def _value(self, name):
        return self.settings.get_parameter(name).value

    def _now_s(self):
        return self.settings.get_clock().now().nanoseconds * 1e-9

    def _apply_parameters(self, parameters):
        # Ranges and choices were checked before (declare_all's on_set): apply to every panel.
        for parameter in parameters:
            for guard in self.guards:
                if parameter.name == 'setpoint_timeout_s':
                    guard.timeout_s = parameter.value
                elif parameter.name == 'safe_behaviour':
                    guard.safe_behaviour = SafeBehaviour(parameter.value)
            if parameter.name == 'fault_action':
                self.loops.set_safe_action(SafeAction(parameter.value))

    # -- fault injection (simulated cushions only) -----------------------------------------

    def _start_fault_injection(self, facade_ids):
        ids = [panel.panel_id for panel in self.panels]
        self._facade_ids = list(facade_ids) if facade_ids is not None else ids
        self._facade_id_set = frozenset(self._facade_ids)
        driver = self.loops.driver
        self.injector = FaultInjector(driver.plant, ids) \
            if isinstance(driver, SimulatedCushions) else None
        self.fault_requests_applied, self.fault_requests_refused = 0, 0
        self._fault_refusals_since_report, self.last_fault_refusal = 0, ''
        subscription(self.settings, contract.INJECT_FAULT, self._on_inject_fault)

    def _on_inject_fault(self, message):
        try:
            if self.injector is None:
                raise FaultRequestError(
                    f'hardware {self._value("hardware")!r} takes no injected faults: only '
                    f'simulated cushions do')
            request = parse_request(message.name, message.hardware_id,
                                    ((kv.key, kv.value) for kv in message.values),
                                    self._facade_ids)
            indices = self.injector.apply(request, self._now_s())
        except FaultRequestError as error:
            self.fault_requests_refused += 1
            self._fault_refusals_since_report += 1
            self.last_fault_refusal = str(error)
            self.settings.get_logger().warning(f'refused fault request: {error}',
                                               throttle_duration_sec=1.0)
            return
        if indices.size:  # else the panels are another process's
            self.fault_requests_applied += 1
            log_with_senders(self.settings, contract.INJECT_FAULT.name,
                             f'fault request: {request.describe()} ({indices.size} panel(s) '
                             f'here),')

    def _end_timed_faults(self, now_s):
        for panel_id, kind in self.injector.expire(now_s) if self.injector else ():
            self.settings.get_logger().warning(f'injected {kind} on {panel_id} ended')

    def _injected(self, index):
        return self.injector.injected(index) if self.injector is not None else 'none'

    # -- what the panels' nodes hand over ---------------------------------------------------

    def offer(self, index, value, logger):
        """Take a setpoint that arrived for panel ``index``, or log why not."""
        guard = self.guards[index]
        reason = guard.offer(value, self._now_s())
        if reason is not None:
            self._rejected_since_report[index] += 1
            logger.warning(f'rejected setpoint: {reason}; holding {guard.last_valid:g}',
                           throttle_duration_sec=1.0)
            return
        # the next tick hands it to the loop (with every panel's, after the watchdog)

    def _who(self, node_name):
        return self.presence.who(node_name) if self.presence is not None else node_name

    def _on_facade_setpoints(self, message):
        if self.sources.doubled(contract.FACADE_SETPOINTS.name):
            # policy hold: whose message this is cannot be told; the watchdog vents the panels
            self.sources.refuse(contract.FACADE_SETPOINTS.name)
            return
        try:
            pairs = facade_setpoints.entries(message.name, message.position)
            unknown = [name for name, _ in pairs if name not in self._facade_id_set]
            if unknown:
                raise facade_setpoints.SetpointsMessageError(
                    f'{", ".join(unknown[:5])} not of this facade')
        except facade_setpoints.SetpointsMessageError as error:
            self.setpoint_messages_refused += 1
            self._setpoint_refusals_since_report += 1
            self.last_setpoints_refusal = str(error)
            self.settings.get_logger().warning(
                f'refused {contract.FACADE_SETPOINTS.name}: {error}', throttle_duration_sec=1.0)
            return
        for name, closure in pairs:
            index = self._index_of.get(name)
            if index is not None:  # else another process's panel
                self.offer(index, closure, self.panels[index].get_logger())

    def reset_faults(self, index):
        """Clear panel ``index``'s latched fault, logged with its sender; return what it was."""
        fault = self.loops.controller.fault_at(index)
        self.loops.reset_faults([index])
        panel = self.panels[index]
        log_with_service_clients(panel, contract.reset_faults_service(panel.panel_id),
                                 f'reset_faults ({fault.value})')
        return f'cleared {fault.value}' if fault is not Fault.NONE else 'no fault'

    # -- the tick ---------------------------------------------------------------------------

    def _tick(self):
        started = time.process_time()
        now = self._now_s()
        if now <= 0.0:
            return  # use_sim_time before the first /clock
        if self._last_tick_s is not None and now > self._last_tick_s:
            self._tick_intervals_s.append(now - self._last_tick_s)
        self._last_tick_s = now
        for index, guard in enumerate(self.guards):
            closure, state = guard.command(now)
            self._setpoints[index] = closure
            self._status[index] = _STATUS_CODE[state.value]
        self.loops.set_setpoints(self._setpoints)
        if self.loops.time_s is None and self.loops.driver.simulated:
            until_next_ns = self._tick_timer.time_until_next_call()
            self.loops.advance_to(loop_start_s(
                now, None if until_next_ns is None else until_next_ns * 1e-9,
                self.control_period_s))
        advance = self.loops.advance_to(now)
        # after the loop ran up to now: a timed fault lasts at least as long as asked
        self._end_timed_faults(now)
        if advance.skipped_s > 0.0:
            self.settings.get_logger().warning(
                f'the clock jumped: {advance.skipped_s:.0f} s were not simulated (the plant '
                f'held; {self.loops.skipped_s:.0f} s in all)', throttle_duration_sec=5.0)
        self._publish_latched(self._status)
        if not self.states_published and not advance.periods:
            self._publish_first_state(now)
        self._publish_samples()
        self._tick_cpu_s += time.process_time() - started

    def _publish_latched(self, status):
        """Publish each panel's ``fault`` and ``status`` where it changed."""
        fault = self.loops.controller.fault_codes
        status = np.where(fault != 0, _FAULT_STATUS, status)
        self._table['fault'], self._table['status'] = fault, status
        for index in np.flatnonzero(fault != self._published_fault).tolist():
            word = contract.FAULTS[fault[index]]
            self.panels[index].publish_fault(word)
            if word != contract.NO_FAULT:
                self.panels[index].get_logger().error(
                    f'circuit fault {word}: {self._value("fault_action")}')
        for index in np.flatnonzero(status != self._published_status).tolist():
            self.panels[index].publish_status(contract.STATUSES[status[index]])
        self._published_fault[:], self._published_status[:] = fault, status

    def _publish_samples(self):
        # The loop keeps its state at each publish instant, also while it catches up a clock
        # jump in one call: the facade-level topics carry each, with its own stamp (of more
        # than MAX_STATES_PER_TICK, a loop racing to catch up, the newest, counting the rest);
        # the panels' own topics the newest only, so that a late tick does not publish a
        # thousand panels' states several times over and fall later still.
        samples = self.loops.samples_since(self._last_sequence, MAX_STATES_PER_TICK)
        if samples:
            self.states_skipped += samples[0].sequence - self._last_sequence - 1
        due = []
        for sample in samples:
            self._last_sequence = sample.sequence
            if self._decimator.due(sample.time_s):
                self._publish_facade_state(_stamp(sample.time_s), sample)
                due.append(sample)
        if due:
            self._publish_panel_states(due[-1], np.logical_or.reduce([s.active for s in due]))

    def _publish_first_state(self, now_s):
        # As soon as the process knows the time, also while a bringup holds its clock at the
        # start of the day (then the loop runs no period and keeps no state): the panels are up.
        closure, fold_angle = self.loops.current_feedback()
        sample = LoopSample(0, now_s, closure, fold_angle, self.loops.measured_pa,
                            self.loops.controller.active)
        self._publish_facade_state(_stamp(now_s), sample)
        self._publish_panel_states(sample, sample.active)

    def _publish_panel_states(self, sample, active):
        stamp = _stamp(sample.time_s)
        for index in np.flatnonzero(self._panels_due(sample, active)).tolist():
            self.panels[index].publish_state(stamp, float(sample.closure[index]),
                                             float(sample.fold_angle_rad[index]),
                                             float(sample.measured_pa[index]))

    def _panels_due(self, sample, active):
        """Which panels publish their own state topics for ``sample``.

        While the loop moves a panel (``active``: in any state since the last tick), and for
        the first state after, every state; at rest, a heartbeat; and whenever its sensor
        starts or stops giving a reading.
        """
        reading = np.isfinite(sample.measured_pa)
        due = active | self._was_active | (reading != self._published_reading) | \
            (sample.time_s - self._published_s >= self.heartbeat_s - self._slack_s)
        first = ~np.isfinite(self._published_s)
        self._was_active = active
        self._published_s[due] = sample.time_s
        self._published_reading[due] = reading[due]
        if np.any(first):
            # spread the panels' heartbeats over one heartbeat period, not all at once
            count = len(self.panels)
            phase = self.heartbeat_s * np.arange(count) / count
            self._published_s[first] = sample.time_s - phase[first]
        return due

    def _publish_facade_state(self, stamp, sample):
        table = self._table
        table['closure'], table['fold_angle_rad'] = sample.closure, sample.fold_angle_rad
        table['pressure_pa'], table['setpoint'] = sample.measured_pa, self._setpoints
        table['active'] = sample.active
        self._cloud_publisher.publish(panel_states.fill_message(self._cloud, table, stamp,
                                                                PointField))
        joints = self._joint_states
        joints.header.stamp = stamp
        joints.position = array.array('d', np.repeat(sample.fold_angle_rad,
                                                     self._flaps_per_panel).tobytes())
        self._joints_publisher.publish(joints)
        self.states_published += 1

    # -- diagnostics ------------------------------------------------------------------------

    def _report(self):
        # One slice of the panels per call, the process's own status with the first: every
        # status still comes once per diagnostics period.
        now = self._now_s()
        panels = self._report_slices[self._next_slice]
        statuses = [self.panel_status(index, now) for index in panels]
        if self._next_slice == 0:
            statuses.append(self.process_status())
        self._diagnostics.publish(diagnostics.diagnostic_array(self.settings, statuses))
        self._rejected_since_report[panels.start:panels.stop] = 0
        self._next_slice = (self._next_slice + 1) % len(self._report_slices)

    def panel_status(self, index, now_s):
        """Return panel ``index``'s REP-107 status: level, message and figures."""
        loops, guard, node = self.loops, self.guards[index], self.panels[index]
        controller = loops.controller
        fault = controller.fault_at(index)
        state = guard.state(now_s) if now_s > 0.0 else SetpointState.WAITING
        level, message = diagnostics.OK, state.value
        if state is SetpointState.TIMED_OUT:
            level, message = diagnostics.WARN, (
                f'no setpoint for {guard.timeout_s:g} s: {guard.safe_behaviour.value}')
        elif self._rejected_since_report[index]:
            level, message = diagnostics.WARN, (
                f'rejected {self._rejected_since_report[index]} setpoint(s): '
                f'{guard.last_rejection}')
        elif controller.limited_by_supply[index]:
            level, message = diagnostics.WARN, 'supply too weak for the setpoint'
        if loops.behind_s > OVERLOADED_S and level == diagnostics.OK:
            level, message = diagnostics.WARN, (
                f'overloaded: the simulation is {loops.behind_s:.1f} s behind the clock')
        injected = self._injected(index)
        if injected != 'none' and level == diagnostics.OK:
            level, message = diagnostics.WARN, f'simulated fault injected: {injected}'
        if fault is not Fault.NONE:
            level, message = diagnostics.ERROR, f'circuit fault: {fault.value}'
        closure, fold_angle = loops.current_feedback()
        figures = {
            'setpoint': guard.last_valid, 'tracked_closure': float(self._setpoints[index]),
            'closure': float(closure[index]), 'fold_angle_rad': float(fold_angle[index]),
            'pressure_gauge_pa': float(controller.filtered_gauge_pa[index]),
            'target_gauge_pa': float(controller.target_gauge_pa[index]),
            'fault': fault.value, 'setpoint_state': state.value,
            contract.DIAGNOSTIC_SETPOINTS_REJECTED: guard.rejected,
            'last_rejection': guard.last_rejection,
            contract.DIAGNOSTIC_FREE_AIR_NL: float(loops.free_air_used_nl[index]),
            contract.DIAGNOSTIC_INJECTED_FAULTS: injected,
        }
        return diagnostics.status(node, level, 'pressure loop', node.panel_id, message, figures)

    def process_status(self):
        """Return the process's REP-107 status: its panels, its tick and what it published."""
        intervals = np.array(self._tick_intervals_s)
        self._tick_intervals_s = []
        jitter = np.abs(intervals - self.control_period_s)
        p50, p99 = (np.percentile(jitter, [50, 99]) if len(jitter) else (math.nan, math.nan))
        figures = {
            'panels': len(self.panels), 'ticks': len(intervals),
            contract.DIAGNOSTIC_TICK_JITTER_P50_S: float(p50),
            contract.DIAGNOSTIC_TICK_JITTER_P99_S: float(p99),
            'tick_cpu_s': self._tick_cpu_s,
            'states_published': self.states_published,
            contract.DIAGNOSTIC_STATES_SKIPPED: self.states_skipped,
            'sim_time_skipped_s': self.loops.skipped_s,
            'loop_time_s': self.loops.time_s if self.loops.time_s is not None else math.nan,
            contract.DIAGNOSTIC_BEHIND_S: self.loops.behind_s,
            contract.DIAGNOSTIC_FAULT_REQUESTS_APPLIED: self.fault_requests_applied,
            contract.DIAGNOSTIC_FAULT_REQUESTS_REFUSED: self.fault_requests_refused,
            contract.DIAGNOSTIC_LAST_FAULT_REFUSAL: self.last_fault_refusal,
            contract.DIAGNOSTIC_SETPOINT_MESSAGES_REFUSED: self.setpoint_messages_refused,
            contract.DIAGNOSTIC_LAST_SETPOINTS_REFUSAL: self.last_setpoints_refusal,
        }
        level, message = diagnostics.OK, f'{len(self.panels)} panels'
        statistics = getattr(self.loops.driver, 'statistics', None)
        if statistics is not None:  # a fieldbus driver: its link and timing
            figures.update(statistics(self.control_period_s))
            if self.loops.driver.comms_lost:
                level, message = diagnostics.ERROR, (
                    f'{message}; comms lost: {figures["modbus_last_error"]}')
        level, message = report_domain(self.presence, self.sources, level, message, figures)
        for count, what, reason in (
                (self._fault_refusals_since_report, 'fault request(s)', self.last_fault_refusal),
                (self._setpoint_refusals_since_report, 'setpoints message(s)',
                 self.last_setpoints_refusal)):
            if count:  # WARN in the report after refusals
                level, message = max(level, diagnostics.WARN), (
                    f'{message}; refused {count} {what}: {reason}')
        self._fault_refusals_since_report = self._setpoint_refusals_since_report = 0
        return diagnostics.status(self.settings, level, 'panel process',
                                  self.settings.get_name(), message, figures)

    def close(self):
        """Shut the valves: the panels keep their air (a held position) until vented."""
        self.loops.close()


def loop_start_s(now_s, until_next_tick_s, period_s):
    """Return where a simulated loop's periods start, at a process's first tick ``now_s``.

    Half a period before the instant the tick was *due* (the next is due ``until_next_tick_s``
    from now, None if unknown: then now), so that every later tick, due a whole number of
    periods after it, falls midway between two period ends: a tick a little early or late
    still finds exactly one new state. Started at the tick itself, a tick a hair early found
    none and the next two (1 in 100 intervals of ``/facade/panel_states`` 0 or 200 ms instead
    of 100); started half a period before a first tick that ran about half a period late (a
    busy start), the period ends fell on the due instants and that process published at 0
    and 200 ms intervals all its life (1,000 panels in two processes: p99 100 ms). A real
    driver's loop runs one period per tick whatever its phase.
    """
    due_s = now_s
    if until_next_tick_s is not None and 0.0 <= until_next_tick_s <= period_s:
        due_s = now_s + until_next_tick_s - period_s
    return due_s - 0.5 * period_s


def _stamp(time_s):
    return Time(nanoseconds=round(time_s * 1e9)).to_msg()


def build_loops(node, panel_ids, seed=0):
    """Build the shared loops from ``node``'s settings.

    Return them, the panels' origins in the site's frame (N, 3) [m], the facade's ids and its
    panel kind.
    """
    settings = {name: node.get_parameter(name).value for name in LOOP_SETTINGS}
    if settings['hardware'] not in DRIVERS:  # declare_all refused it already
        raise ValueError(f'hardware {settings["hardware"]!r}: no such cushion driver')
    facade = load_facade(settings['facade_file'] or DEFAULT_FACADE)
    parameters = ControllerParameters(
        max_gauge_pa=settings['max_gauge_pressure_pa'],
        time_constant_s=settings['control.time_constant_s'],
        integral_time_s=4.0 * settings['control.time_constant_s'],
        hold_band_pa=settings['control.hold_band_pa'])
    if settings['hardware'] == 'modbus':
        loops = _modbus_loops(node, settings, facade, panel_ids, parameters)
    else:
        loops = facade_loops(facade, panel_ids, settings['control_period_s'], parameters,
                             seed=seed, quiet_period_s=settings['simulation.quiet_period_s'],
                             max_call_s=MAX_CALL_S, trace=False)
    compile_kernels()  # here, before the panels report ready, not in their first tick
    origins = facade.origin_m[panel_indices(facade, panel_ids)] @ facade.facade_to_enu.T
    return loops, origins, facade.panel_ids, panel_kind(facade.panels[0])


def _modbus_loops(node, settings, facade, panel_ids, parameters):
    """Loops on a Modbus TCP valve terminal, one map channel per panel, in ``panel_ids`` order.

    Real valves run on the wall clock: ``use_sim_time`` is refused.
    """
    from flectofold_ros.hardware.modbus_driver import ModbusCushions
    from flectofold_ros.hardware.register_map import load_register_map
    if node.get_parameter('use_sim_time').value:
        raise ValueError('hardware modbus drives real valves on the wall clock: '
                         'use_sim_time must be false')
    if not settings['modbus.map_file']:
        raise ValueError('hardware modbus needs modbus.map_file, the register map '
                         '(msg_docs/modbus.md)')
    register_map = load_register_map(settings['modbus.map_file'])
    if register_map.count != len(panel_ids):
        raise ValueError(f'{register_map.source} has {register_map.count} channel(s) for '
                         f'{len(panel_ids)} panel(s) ({_id_span(panel_ids)})')
    driver = ModbusCushions(register_map, settings['modbus.host'], settings['modbus.port'],
                            timeout_s=settings['modbus.timeout_s'])
    return facade_loops(facade, panel_ids, settings['control_period_s'], parameters,
                        driver=driver, trace=False)


class PanelProgram(Program):
    """A panel process as a program: on close, the valves shut.

    As an executable (``panel_node``, ``panel_group``) it ends its process right after, without
    tearing down its DDS entities one by one (:attr:`Program.teardown`): 500 panel nodes took
    31 s to destroy; the process's end frees them, and its peers drop its participant when
    its lease runs out (``fastdds_panel_process.xml``: 3 s).
    """

    def __init__(self, nodes, process, teardown=True):
        self.teardown = teardown
        super().__init__(nodes)
        self.process = process

    def close(self, interrupted):
        self.process.close()


def start_panels(panel_ids=None, group_name=None, seed=0, teardown=True, **node_kwargs):
    """Create the panel nodes of one process on one shared loop; return the :class:`Program`.

    ``group_name`` None: one :class:`PanelNode` (its id from ``panel_ids[0]``, its namespace
    or ``panel_id``) that also holds the parameters. Otherwise a settings node
    ``/facade/<group_name>`` holds them for one light node per id of ``panel_ids``.
    """
    nodes = []
    try:
        if group_name is None:
            nodes.append(PanelNode((panel_ids or [None])[0], **node_kwargs))
            settings, panels = nodes[0], nodes
        else:
            nodes.append(Node(group_name, namespace=contract.FACADE_NODE_NAMESPACE,
                              **node_kwargs))
            declare_all(nodes[0], PARAMETERS)
            context = {'context': node_kwargs['context']} if 'context' in node_kwargs else {}
            for panel_id in panel_ids:
                nodes.append(PanelNode(panel_id, settings=False, **context))
            settings, panels = nodes[0], nodes[1:]
        ids = [panel.panel_id for panel in panels]
        if len(set(ids)) != len(ids):
            raise ValueError(f'a panel is named twice in {", ".join(ids)}')
        # listening while the loops are built
        check = StartCheck(f'{settings.get_name()}_start_check', settings.context)
        loops, origins, facade_ids, kind = build_loops(settings, ids, seed=seed)
        own = presence.this_process(
            presence.PANELS, settings.get_parameter('facade_file').value or 'demonstrator',
            [settings.get_fully_qualified_name()], ids)
        check.refuse(own)
        process = PanelProcess(settings, panels, loops, origins, facade_ids, kind)
        process.presence = Presence(settings, own)
        process.presence.announce()
    except BaseException:
        for node in nodes:
            node.destroy_node()
        raise
    settings.get_logger().info(f'{len(panels)} panel(s) ready: {_id_span(ids)}')
    return PanelProgram(nodes, process, teardown)


def _id_span(ids):
    return ', '.join(ids) if len(ids) <= 6 else f'{ids[0]} ... {ids[-1]}'


def use_panel_process_profile(environ=os.environ):
    """Give Fast DDS the panel process's profile, unless the user chose a profile or an RMW.

    Called before rclpy starts; see ``fastdds_panel_process.xml``.
    """
    if any(environ.get(name) for name in PROFILE_VARIABLES):
        return
    if environ.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp') != 'rmw_fastrtps_cpp':
        return
    environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(FASTDDS_PROFILE)


def run_panels(name, args, panel_ids=lambda: None, group_name=None, usage=None,
               **node_kwargs):
    """Run a panel process until a stop signal: the body of ``panel_node`` and ``panel_group``.

    ``panel_ids()`` gives the ids (None: one node, its id from its namespace).
    """
    use_panel_process_profile()
    return run_nodes(name, args,
                     lambda: start_panels(panel_ids(), group_name, teardown=False,
                                          **node_kwargs),
                     usage, PARAMETERS)


def main(args=None):
    """``ros2 run flectofold_ros panel_node --ros-args -r __ns:=/facade/r00c00``."""
    return run_panels('panel_node', args, usage=USAGE)


if __name__ == '__main__':
    sys.exit(main())
