"""One Flectofold panel on the graph: closure setpoint in; pressure, fold angles, state out.

The node is the panel's ROS face. Its pressure loop and the fold model live in
:class:`flectofold_model.panel_loop.PanelLoops`, which may be shared by every panel node of a
process (``panel_group``, ``facade``) so that the numerics run vectorised; each node owns one
row of it. Topics, parameters and QoS: ``msg_docs/panel_node.md``.
"""

import math
import re
import sys

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.time import Time
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Float64, String
from std_srvs.srv import Trigger

from flectofold_model.facade import DEFAULT_FACADE, FacadeError, load_facade
from flectofold_model.panel_loop import facade_loops
from flectofold_model.pressure_control import ControllerParameters, Fault, SafeAction
from flectofold_model.setpoint_guard import SafeBehaviour, SetpointGuard, SetpointState
from flectofold_ros.parameters import declare_all, double, string
from flectofold_ros.spinning import make_executor, print_usage_if_asked, spin_until

PANEL_ID = re.compile(r'r\d{2}c\d{2}')
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _choices(description, read_only=True, choices=()):
    return string(description, read_only, f'one of: {", ".join(choices)}')


#: name -> (default, descriptor). The loop settings (read-only) must agree between the panel
#: nodes of one process, since they share one vectorised loop.
PARAMETERS = {
    'panel_id': ('', string('Panel id rNNcNN; empty: the last token of the namespace')),
    'facade_file': ('', string('Facade description YAML; empty: the embedded demonstrator')),
    'hardware': ('simulated', _choices('Cushion driver', choices=['simulated'])),
    'control_period_s': (0.1, double('Pressure loop period [s]', 0.01, 1.0)),
    'control.time_constant_s': (0.4, double(
        'Closed-loop time constant [s], at least twice control_period_s', 0.02, 10.0)),
    'control.hold_band_pa': (60.0, double(
        'At rest the valves stay shut within this of the target [Pa]; 3 sensor sigmas',
        0.0, 1000.0)),
    'simulation.quiet_period_s': (2.0, double(
        'Simulated cushions: longest loop period while every panel of the process rests [s]',
        0.01, 60.0)),
    'max_gauge_pressure_pa': (12e3, double('Hard cushion pressure limit [Pa gauge]',
                                           2e3, 14e3)),
    'publish_rate_hz': (10.0, double('Rate of pressure, joint_states and closure [Hz]',
                                     0.001, 100.0)),
    'diagnostics_period_s': (1.0, double('Period of /diagnostics, wall clock [s]', 0.1, 60.0)),
    'setpoint_timeout_s': (10.0, double(
        'No valid setpoint for this long (ROS time) starts the safe behaviour [s]',
        0.1, 86400.0, read_only=False)),
    'safe_behaviour': ('vent', _choices('After a setpoint timeout: vent (open) or hold',
                                        read_only=False, choices=['vent', 'hold'])),
    'fault_action': ('vent', _choices('On a latched circuit fault: vent or hold (a fill '
                                      'valve stuck open always vents)', read_only=False,
                                      choices=['vent', 'hold'])),
}
LOOP_SETTINGS = ('facade_file', 'hardware', 'control_period_s', 'control.time_constant_s',
                 'control.hold_band_pa', 'simulation.quiet_period_s', 'max_gauge_pressure_pa')


class PanelNode(Node):
    """Node ``panel`` in namespace ``/facade/<id>``; call :meth:`attach` before spinning."""

    def __init__(self, panel_id=None, **kwargs):
        kwargs.setdefault('namespace', f'/facade/{panel_id}' if panel_id else None)
        if kwargs['namespace'] is None:
            del kwargs['namespace']
        super().__init__('panel', **kwargs)
        declare_all(self, PARAMETERS)
        self.panel_id = self._resolve_id(panel_id)
        self.loops = None
        self.guard = SetpointGuard(self._value('setpoint_timeout_s'),
                                   SafeBehaviour(self._choice('safe_behaviour')))
        self.add_on_set_parameters_callback(self._on_set_parameters)

    # -- configuration ----------------------------------------------------------------------

    def _value(self, name):
        return self.get_parameter(name).value

    def _choice(self, name):
        value = self._value(name)
        choices = PARAMETERS[name][1].additional_constraints.split(': ')[1].split(', ')
        if value not in choices:
            raise ValueError(f'parameter {name}={value!r} must be one of {choices}')
        return value

    def _resolve_id(self, panel_id):
        given = panel_id or self._value('panel_id')
        from_namespace = self.get_namespace().rstrip('/').rsplit('/', 1)[-1]
        panel_id = given or from_namespace
        if not PANEL_ID.fullmatch(panel_id or ''):
            raise ValueError(
                f'panel id {panel_id!r} is not of the form rNNcNN: run the node in namespace '
                f'/facade/<id> (--ros-args -r __ns:=/facade/r00c00) or set panel_id')
        return panel_id

    def loop_settings(self):
        """Return the read-only settings that panels sharing one loop must agree on."""
        return {name: self._value(name) for name in LOOP_SETTINGS}

    def build_loops(self, panel_ids, seed=0):
        """Build the shared :class:`PanelLoops` of ``panel_ids`` from this node's settings."""
        settings = self.loop_settings()
        facade = load_facade(settings['facade_file'] or DEFAULT_FACADE)
        parameters = ControllerParameters(
            max_gauge_pa=settings['max_gauge_pressure_pa'],
            time_constant_s=settings['control.time_constant_s'],
            integral_time_s=4.0 * settings['control.time_constant_s'],
            hold_band_pa=settings['control.hold_band_pa'])
        return facade_loops(facade, panel_ids, settings['control_period_s'], parameters,
                            seed=seed, quiet_period_s=settings['simulation.quiet_period_s'])

    def attach(self, loops, index):
        """Drive row ``index`` of ``loops`` and start the topics, timers and service."""
        self.loops, self.index = loops, index
        self._apply_fault_action()
        self._noise_variance = loops.driver.circuit.sensor_noise_pa ** 2
        self._pressure = self.create_publisher(FluidPressure, 'pressure', 10)
        self._joints = self.create_publisher(JointState, 'joint_states', 10)
        self._closure = self.create_publisher(Float64, 'closure', 10)
        self._fault = self.create_publisher(String, 'fault', LATCHED)
        self._status = self.create_publisher(String, 'status', LATCHED)
        self._diagnostics = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.create_subscription(Float64, 'setpoint', self._on_setpoint, 10)
        self.create_service(Trigger, 'reset_faults', self._on_reset_faults)
        self._joint_names = [f'{self.panel_id}_flap_left', f'{self.panel_id}_flap_right']
        self._publish_period_s = 1.0 / self._value('publish_rate_hz')
        self._next_publish_s = -math.inf
        self._last_sequence, self._last_sample_s = 0, -math.inf
        loops.sample_period_s = min(loops.sample_period_s or math.inf, self._publish_period_s)
        self._published = {'fault': None, 'status': None}
        self._rejected_since_report = 0
        self._skipped_s = 0.0
        self.create_timer(self._value('control_period_s'), self._tick)
        self.create_timer(self._value('diagnostics_period_s'), self._report,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._publish_latched(SetpointState.WAITING)
        self.get_logger().debug(f'panel {self.panel_id} ready, row {index} of {len(loops)}')

    def _on_set_parameters(self, parameters):
        # Check every change before applying any: a refused call must leave nothing half set.
        changes = {p.name: p.value for p in parameters}
        try:
            behaviour = SafeBehaviour(changes.get('safe_behaviour', self.guard.safe_behaviour))
            action = SafeAction(changes.get('fault_action', self._value('fault_action')))
            self.guard.timeout_s = changes.get('setpoint_timeout_s', self.guard.timeout_s)
        except ValueError as error:
            return SetParametersResult(successful=False, reason=str(error))
        self.guard.safe_behaviour = behaviour
        if self.loops is not None:
            self.loops.set_safe_action(action, [self.index])
        return SetParametersResult(successful=True)

    def _apply_fault_action(self):
        self.loops.set_safe_action(SafeAction(self._choice('fault_action')), [self.index])

    # -- the loop ---------------------------------------------------------------------------

    def _now_s(self):
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_setpoint(self, message):
        reason = self.guard.offer(message.data, self._now_s())
        if reason is not None:
            self._rejected_since_report += 1
            self.get_logger().warning(f'rejected setpoint: {reason}; holding '
                                      f'{self.guard.last_valid:g}', throttle_duration_sec=1.0)
            return
        self.loops.setpoint[self.index] = self.guard.last_valid

    def _tick(self):
        now = self._now_s()
        if now <= 0.0:
            return  # use_sim_time before the first /clock
        closure, state = self.guard.command(now)
        self.loops.setpoint[self.index] = closure
        advance = self.loops.advance_to(now)
        if advance.skipped_s > 0.0:
            self._skipped_s += advance.skipped_s
            self.get_logger().warning(f'the clock jumped: {advance.skipped_s:.0f} s were not '
                                      f'simulated (the plant held)')
        self._publish_latched(state)
        self._publish_samples()

    def _publish_samples(self):
        # The shared loop keeps its state at each publish instant, also while it catches up
        # a clock jump in one call: publish those, each with its own stamp.
        for sample in self.loops.samples:
            if sample.sequence <= self._last_sequence:
                continue
            if sample.time_s < self._last_sample_s:
                self._next_publish_s = -math.inf  # the loop restarted (the clock went back)
            self._last_sequence, self._last_sample_s = sample.sequence, sample.time_s
            # Half a control period of slack: timer jitter must not stretch the period.
            if sample.time_s >= self._next_publish_s - 0.5 * self.loops.period_s:
                self._next_publish_s += self._publish_period_s
                if self._next_publish_s <= sample.time_s:
                    self._next_publish_s = sample.time_s + self._publish_period_s
                self._publish_state(sample)

    def _publish_state(self, sample):
        stamp = Time(nanoseconds=round(sample.time_s * 1e9)).to_msg()
        i = self.index
        measured = float(sample.measured_pa[i])
        if math.isfinite(measured):
            pressure = FluidPressure(fluid_pressure=measured, variance=self._noise_variance)
            pressure.header.stamp, pressure.header.frame_id = stamp, self.panel_id
            self._pressure.publish(pressure)
        angle = float(sample.fold_angle_rad[i])
        joints = JointState(name=self._joint_names, position=[angle, angle])
        joints.header.stamp = stamp
        self._joints.publish(joints)
        self._closure.publish(Float64(data=float(sample.closure[i])))

    def _publish_latched(self, state):
        fault = self.loops.fault[self.index]
        status = 'fault' if fault is not Fault.NONE else state.value
        for key, value, publisher in (('fault', fault.value, self._fault),
                                      ('status', status, self._status)):
            if self._published[key] != value:
                self._published[key] = value
                publisher.publish(String(data=value))
                if key == 'fault' and value != Fault.NONE.value:
                    self.get_logger().error(f'circuit fault {value}: '
                                            f'{self._value("fault_action")}')

    def _on_reset_faults(self, request, response):
        fault = self.loops.fault[self.index]
        self.loops.reset_faults([self.index])
        response.success = True
        response.message = f'cleared {fault.value}' if fault is not Fault.NONE else 'no fault'
        return response

    # -- diagnostics ------------------------------------------------------------------------

    def _report(self):
        array = DiagnosticArray()
        array.header.stamp = self.get_clock().now().to_msg()
        array.status.append(self.diagnostic_status())
        self._diagnostics.publish(array)
        self._rejected_since_report = 0

    def diagnostic_status(self):
        """Return the panel's REP-107 status: level, message and figures."""
        i, loops, guard = self.index, self.loops, self.guard
        fault = loops.fault[i]
        state = guard.state(self._now_s()) if self._now_s() > 0.0 else SetpointState.WAITING
        level, message = DiagnosticStatus.OK, state.value
        if state is SetpointState.TIMED_OUT:
            level, message = DiagnosticStatus.WARN, (
                f'no setpoint for {guard.timeout_s:g} s: {guard.safe_behaviour.value}')
        elif self._rejected_since_report:
            level, message = DiagnosticStatus.WARN, (
                f'rejected {self._rejected_since_report} setpoint(s): {guard.last_rejection}')
        elif loops.controller.limited_by_supply[i]:
            level, message = DiagnosticStatus.WARN, 'supply too weak for the setpoint'
        if fault is not Fault.NONE:
            level, message = DiagnosticStatus.ERROR, f'circuit fault: {fault.value}'
        values = {
            'setpoint': guard.last_valid, 'tracked_closure': float(loops.setpoint[i]),
            'closure': float(loops.closure[i]),
            'fold_angle_rad': float(loops.fold_angle_rad[i]),
            'pressure_gauge_pa': float(loops.gauge_pa[i]),
            'target_gauge_pa': float(loops.controller.target_gauge_pa[i]),
            'fault': fault.value, 'setpoint_state': state.value,
            'setpoints_rejected': guard.rejected, 'last_rejection': guard.last_rejection,
            'free_air_used_nl': float(loops.free_air_used_nl[i]),
            'sim_time_skipped_s': self._skipped_s,
            'loop_time_s': loops.time_s if loops.time_s is not None else math.nan,
        }
        return DiagnosticStatus(
            level=level, name=f'{self.get_fully_qualified_name()}: pressure loop',
            message=message, hardware_id=self.panel_id,
            values=[KeyValue(key=k, value=_text(v)) for k, v in values.items()])

    def destroy_node(self):
        if self.loops is not None:
            self.loops.close()
        return super().destroy_node()


def _text(value):
    return f'{value:.12g}' if isinstance(value, float) else str(value)


def start_panels(panel_ids, executor, seed=0, **node_kwargs):
    """Create one :class:`PanelNode` per id on one shared loop and add them to ``executor``."""
    nodes = []
    try:
        for panel_id in panel_ids:
            nodes.append(PanelNode(panel_id, **node_kwargs))
        settings = nodes[0].loop_settings()
        for node in nodes[1:]:
            if node.loop_settings() != settings:
                raise ValueError(f'{node.panel_id}: loop settings {node.loop_settings()} differ '
                                 f'from {nodes[0].panel_id}: {settings}')
        loops = nodes[0].build_loops([node.panel_id for node in nodes], seed=seed)
    except Exception:
        for node in nodes:
            node.destroy_node()
        raise
    for index, node in enumerate(nodes):
        node.attach(loops, index)
        executor.add_node(node)
    return nodes


def spin_panels(args, panel_ids=None, **node_kwargs):
    """Run panel nodes on the events executor until Ctrl-C; the console scripts' body."""
    rclpy.init(args=args)
    executor = make_executor()
    nodes = []
    try:
        if panel_ids is None:
            node = PanelNode()
            node.attach(node.build_loops([node.panel_id]), 0)
            executor.add_node(node)
            nodes = [node]
            node.get_logger().info(f'panel {node.panel_id} ready')
        else:
            nodes = start_panels(panel_ids, executor, **node_kwargs)
            nodes[0].get_logger().info(f'{len(nodes)} panels ready: {", ".join(panel_ids)}')
        spin_until(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ValueError, FacadeError, ParameterException) as error:
        print(f'panel: {error}', file=sys.stderr)
        return 2
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(args=None):
    """``ros2 run flectofold_ros panel_node --ros-args -r __ns:=/facade/r00c00``."""
    if print_usage_if_asked(args, 'panel_node --ros-args -r __ns:=/facade/<id> [-p ...]',
                            PARAMETERS):
        return 0
    return spin_panels(args)


if __name__ == '__main__':
    sys.exit(main())
