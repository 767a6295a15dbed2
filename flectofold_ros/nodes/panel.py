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

import math
import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Float64, String

from flectofold_model.control import (Fault, SafeAction, SafeBehaviour, SetpointGuards,
                                      SimulatedCushions)
from flectofold_model.control.decimation import loop_start_s
from flectofold_ros.nodes.panel_outputs import PanelOutputs
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.domain_watch import (log_with_senders, log_with_service_clients,
                                                 report_domain, SourceGuard)
from flectofold_ros.runtime.interfaces import publisher, service, subscription
from flectofold_ros.runtime.parameters import declare_all
from flectofold_ros.wire import contract, facade_setpoints
from flectofold_ros.wire.fault_injection import FaultInjector, FaultRequestError, parse_request
from flectofold_ros.wire.panel_parameters import PARAMETERS
from flectofold_ros.wire.panel_report import ProcessReport

#: Panel statuses in one ``/diagnostics`` message at most: a process of more panels reports
#: them in slices spread over the period (``msg_docs/panel_node.md``).
STATUSES_PER_MESSAGE = 50
#: The status code of each of the guards' states (``SetpointGuards.STATES``' order).
_STATE_STATUS = np.array([contract.STATUSES.index(state.value)
                          for state in SetpointGuards.STATES])


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
        self.settings, self.panels, self.loops, self.kind = settings, panels, loops, kind
        value = self._value
        count = len(panels)
        self.guards = SetpointGuards(count, value('setpoint_timeout_s'),
                                     SafeBehaviour(value('safe_behaviour')))
        loops.set_safe_action(SafeAction(value('fault_action')))
        self.control_period_s = value('control_period_s')
        state_period_s = 1.0 / value('publish_rate_hz')
        loops.request_sample_period(0, state_period_s)
        self.report = ProcessReport(count, self.control_period_s)
        self._setpoints = np.zeros(count)
        # Half a loop period of slack: a state rounding puts a hair early still counts.
        self.outputs = PanelOutputs(settings, panels, positions_enu, kind, state_period_s,
                                    value('heartbeat_period_s'), 0.5 * self.control_period_s,
                                    self.report)
        self._diagnostics = publisher(settings, contract.DIAGNOSTICS)
        for index, panel in enumerate(panels):
            panel.attach(self, index)
        ids = [panel.panel_id for panel in panels]
        self._index_of = {panel_id: index for index, panel_id in enumerate(ids)}
        self._facade_ids = list(facade_ids) if facade_ids is not None else ids
        self._facade_id_set = frozenset(self._facade_ids)
        self.injector = FaultInjector(loops.driver.plant, ids) \
            if isinstance(loops.driver, SimulatedCushions) else None
        subscription(settings, contract.INJECT_FAULT, self._on_inject_fault)
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
                              self._report, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._publish_latched(np.full(count, _STATE_STATUS[0]))  # waiting for a setpoint

    def _value(self, name):
        return self.settings.get_parameter(name).value

    def _now_s(self):
        return self.settings.get_clock().now().nanoseconds * 1e-9

    def _apply_parameters(self, parameters):
        # Ranges and choices were checked before (declare_all's on_set): apply to every panel.
        for parameter in parameters:
            if parameter.name == 'setpoint_timeout_s':
                self.guards.timeout_s = parameter.value
            elif parameter.name == 'safe_behaviour':
                self.guards.safe_behaviour = SafeBehaviour(parameter.value)
            elif parameter.name == 'fault_action':
                self.loops.set_safe_action(SafeAction(parameter.value))

    # -- what comes in: setpoints, fault requests, resets ----------------------------------

    def offer(self, index, value, logger):
        """Take a setpoint that arrived for panel ``index``, or log why not."""
        reason = self.guards.offer(index, value, self._now_s())
        if reason is not None:
            self.report.rejected_since_report[index] += 1
            logger.warning(f'rejected setpoint: {reason}; holding '
                           f'{self.guards.last_valid[index]:g}', throttle_duration_sec=1.0)
        # else the next tick hands it to the loop (with every panel's, after the watchdog)

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
            self.report.refuse_setpoints(str(error))
            self.settings.get_logger().warning(
                f'refused {contract.FACADE_SETPOINTS.name}: {error}', throttle_duration_sec=1.0)
            return
        for name, closure in pairs:
            index = self._index_of.get(name)
            if index is not None:  # else another process's panel
                self.offer(index, closure, self.panels[index].get_logger())

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
            self.report.refuse_fault_request(str(error))
            self.settings.get_logger().warning(f'refused fault request: {error}',
                                               throttle_duration_sec=1.0)
            return
        if indices.size:  # else the panels are another process's
            self.report.fault_requests_applied += 1
            log_with_senders(self.settings, contract.INJECT_FAULT.name,
                             f'fault request: {request.describe()} ({indices.size} panel(s) '
                             f'here),')

    def _injected(self, index):
        return self.injector.injected(index) if self.injector is not None else 'none'

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
        self.report.tick(now)
        self._setpoints, states = self.guards.command(now)
        self.loops.set_setpoints(self._setpoints)
        if self.loops.time_s is None and self.loops.driver.simulated:
            until_next_ns = self._tick_timer.time_until_next_call()
            self.loops.advance_to(loop_start_s(
                now, None if until_next_ns is None else until_next_ns * 1e-9,
                self.control_period_s))
        advance = self.loops.advance_to(now)
        # after the loop ran up to now: a timed fault lasts at least as long as asked
        for panel_id, kind in self.injector.expire(now) if self.injector else ():
            self.settings.get_logger().warning(f'injected {kind} on {panel_id} ended')
        if advance.skipped_s > 0.0:
            self.settings.get_logger().warning(
                f'the clock jumped: {advance.skipped_s:.0f} s were not simulated (the plant '
                f'held; {self.loops.skipped_s:.0f} s in all)', throttle_duration_sec=5.0)
        self._publish_latched(_STATE_STATUS[states])
        if not self.report.states_published and not advance.periods:
            self.outputs.first_state(self.loops, now, self._setpoints)
        self.outputs.samples(self.loops, self._setpoints)
        self.report.tick_cpu_s += time.process_time() - started

    def _publish_latched(self, status):
        self.outputs.latched(self.loops.controller.fault_codes, status,
                             self._value('fault_action'))

    # -- diagnostics ------------------------------------------------------------------------

    def _report(self):
        # One slice of the panels per call, the process's own status with the first: every
        # status still comes once per diagnostics period.
        now = self._now_s()
        panels = self._report_slices[self._next_slice]
        states = self.guards.states(now) if now > 0.0 else None
        feedback = self.loops.current_feedback()
        statuses = [self._panel_status(index, states, feedback) for index in panels]
        if self._next_slice == 0:
            statuses.append(self._process_status())
        self._diagnostics.publish(diagnostics.diagnostic_array(self.settings, statuses))
        self.report.reported(panels)
        self._next_slice = (self._next_slice + 1) % len(self._report_slices)

    def _panel_status(self, index, states, feedback):
        node = self.panels[index]
        level, message, figures = self.report.panel(
            index, self.loops, self.guards, states, self._setpoints, feedback,
            self._injected(index))
        return diagnostics.status(node, level, 'pressure loop', node.panel_id, message, figures)

    def _process_status(self):
        level, message, figures = self.report.process(self.loops, len(self.panels))
        level, message = report_domain(self.presence, self.sources, level, message, figures)
        level, message = self.report.refusals(level, message)
        return diagnostics.status(self.settings, level, 'panel process',
                                  self.settings.get_name(), message, figures)

    def close(self):
        """Shut the valves: the panels keep their air (a held position) until vented."""
        self.loops.close()
