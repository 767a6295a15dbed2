"""One Flectofold panel on the graph: closure setpoint in; pressure, fold angles, state out.

The node is the panel's ROS face. Its pressure loop and the fold model live in
:class:`flectofold_model.control.PanelLoops`, which every panel node of a process shares
(``panel_group``, ``facade``) so that the numerics run vectorised; each node works through
its own :class:`~flectofold_model.control.LoopRow`. Topics, parameters and QoS:
``msg_docs/panel_node.md``.
"""

import math
import sys

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Float64, String

from flectofold_model.control import (compile_kernels, ControllerParameters, facade_loops, Fault,
                                      PublishDecimator, SafeAction, SafeBehaviour, SetpointGuard,
                                      SetpointState)
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros import contract, diagnostics
from flectofold_ros.interfaces import publisher, service, subscription
from flectofold_ros.parameters import choice, declare_all, double, string
from flectofold_ros.runner import Program, run_nodes

#: name -> Spec. The loop settings (read-only) must agree between the panel nodes of one
#: process, since they share one vectorised loop.
PARAMETERS = {
    'panel_id': string('', 'Panel id rNNcNN; empty: the last token of the namespace'),
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'hardware': choice('simulated', 'Cushion driver', ['simulated']),
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
                 'control.hold_band_pa', 'simulation.quiet_period_s', 'max_gauge_pressure_pa')
#: Longest one loop call works [s, wall clock]: a process that cannot keep up with its clock
#: still publishes and answers signals between calls.
MAX_CALL_S = 0.25
#: A loop further behind its clock than this says it is overloaded [s].
OVERLOADED_S = 1.0
#: A tick publishes at most this many of the states its loop kept since the last one (the
#: newest): a loop catching up hours keeps thousands, which would starve the process.
MAX_STATES_PER_TICK = 20
USAGE = 'panel_node --ros-args -r __ns:=/facade/<id> [-p name:=value ...]'


class PanelNode(Node):
    """Node ``panel`` in namespace ``/facade/<id>``; call :meth:`attach` before spinning."""

    def __init__(self, panel_id=None, **kwargs):
        if panel_id:
            kwargs.setdefault('namespace', contract.panel_namespace(panel_id))
        super().__init__(contract.PANEL_NODE, **kwargs)
        declare_all(self, PARAMETERS)
        self.panel_id = self._resolve_id(panel_id)
        self.row = None
        self.guard = SetpointGuard(self._value('setpoint_timeout_s'),
                                   SafeBehaviour(self._value('safe_behaviour')))
        self.add_post_set_parameters_callback(self._apply_parameters)

    # -- configuration ----------------------------------------------------------------------

    def _value(self, name):
        return self.get_parameter(name).value

    def _resolve_id(self, panel_id):
        given = panel_id or self._value('panel_id')
        from_namespace = self.get_namespace().rstrip('/').rsplit('/', 1)[-1]
        panel_id = given or from_namespace
        if not contract.PANEL_ID.fullmatch(panel_id or ''):
            raise ValueError(
                f'panel id {panel_id!r} is not of the form rNNcNN: run the node in namespace '
                f'/facade/<id> (--ros-args -r __ns:=/facade/r00c00) or set panel_id')
        return panel_id

    def loop_settings(self):
        """Return the read-only settings that panels sharing one loop must agree on."""
        return {name: self._value(name) for name in LOOP_SETTINGS}

    def attach(self, row):
        """Drive ``row`` (a :class:`~flectofold_model.control.LoopRow`); start topics, timers."""
        self.row = row
        row.set_safe_action(SafeAction(self._value('fault_action')))
        self._noise_variance = row.sensor_noise_pa ** 2
        panel = self.panel_id
        self._pressure = publisher(self, contract.PRESSURE.of(panel))
        self._joints = publisher(self, contract.JOINT_STATES.of(panel))
        self._closure = publisher(self, contract.CLOSURE.of(panel))
        self._fault = publisher(self, contract.FAULT.of(panel))
        self._status = publisher(self, contract.STATUS.of(panel))
        self._diagnostics = publisher(self, contract.DIAGNOSTICS)
        subscription(self, contract.SETPOINT.of(panel), self._on_setpoint)
        service(self, contract.reset_faults_service(panel), self._on_reset_faults,
                contract.RESET_FAULTS_TYPE)
        self._joint_names = contract.flap_joint_names(panel)
        period_s = 1.0 / self._value('publish_rate_hz')
        row.request_sample_period(period_s)
        # Half a loop period of slack: a state rounding puts a hair early still counts.
        self._decimator = PublishDecimator(period_s, 0.5 * self._value('control_period_s'))
        self._last_sequence = 0
        self._published = {'fault': None, 'status': None}
        self._rejected_since_report = 0
        self._states_skipped = 0
        self.create_timer(self._value('control_period_s'), self._tick)
        self.create_timer(self._value('diagnostics_period_s'), self._report,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._publish_latched(SetpointState.WAITING)

    def _apply_parameters(self, parameters):
        # Ranges and choices were checked before (declare_all's on_set): apply.
        for parameter in parameters:
            if parameter.name == 'setpoint_timeout_s':
                self.guard.timeout_s = parameter.value
            elif parameter.name == 'safe_behaviour':
                self.guard.safe_behaviour = SafeBehaviour(parameter.value)
            elif parameter.name == 'fault_action' and self.row is not None:
                self.row.set_safe_action(SafeAction(parameter.value))

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
        self.row.set_setpoint(self.guard.last_valid)

    def _tick(self):
        now = self._now_s()
        if now <= 0.0:
            return  # use_sim_time before the first /clock
        closure, state = self.guard.command(now)
        self.row.set_setpoint(closure)
        advance = self.row.loops.advance_to(now)
        if advance.skipped_s > 0.0:
            self.get_logger().warning(f'the clock jumped: {advance.skipped_s:.0f} s were not '
                                      f'simulated (the plant held; {self.row.skipped_s:.0f} s in '
                                      f'all)', throttle_duration_sec=5.0)
        self._publish_latched(state)
        self._publish_samples()

    def _publish_samples(self):
        # The shared loop keeps its state at each publish instant, also while it catches up
        # a clock jump in one call: publish those, each with its own stamp; of more than
        # MAX_STATES_PER_TICK (a loop racing to catch up), the newest, counting the rest.
        samples = self.row.samples_since(self._last_sequence, MAX_STATES_PER_TICK)
        if samples:
            self._states_skipped += samples[0].sequence - self._last_sequence - 1
        for sample in samples:
            self._last_sequence = sample.sequence
            if self._decimator.due(sample.time_s):
                self._publish_state(sample)

    def _publish_state(self, sample):
        stamp = Time(nanoseconds=round(sample.time_s * 1e9)).to_msg()
        if math.isfinite(sample.measured_pa):
            pressure = FluidPressure(fluid_pressure=sample.measured_pa,
                                     variance=self._noise_variance)
            pressure.header.stamp, pressure.header.frame_id = stamp, self.panel_id
            self._pressure.publish(pressure)
        angle = sample.fold_angle_rad
        joints = JointState(name=self._joint_names, position=[angle, angle])
        joints.header.stamp = stamp
        self._joints.publish(joints)
        self._closure.publish(Float64(data=sample.closure))

    def _publish_latched(self, state):
        fault = self.row.fault
        status = contract.STATUS_FAULT if fault is not Fault.NONE else state.value
        for key, value, publisher_ in (('fault', fault.value, self._fault),
                                       ('status', status, self._status)):
            if self._published[key] != value:
                self._published[key] = value
                publisher_.publish(String(data=value))
                if key == 'fault' and value != contract.NO_FAULT:
                    self.get_logger().error(f'circuit fault {value}: '
                                            f'{self._value("fault_action")}')

    def _on_reset_faults(self, request, response):
        fault = self.row.fault
        self.row.reset_faults()
        response.success = True
        response.message = f'cleared {fault.value}' if fault is not Fault.NONE else 'no fault'
        return response

    # -- diagnostics ------------------------------------------------------------------------

    def _report(self):
        self._diagnostics.publish(diagnostics.diagnostic_array(self, [self.diagnostic_status()]))
        self._rejected_since_report = 0

    def diagnostic_status(self):
        """Return the panel's REP-107 status: level, message and figures."""
        row, guard = self.row, self.guard
        fault = row.fault
        state = guard.state(self._now_s()) if self._now_s() > 0.0 else SetpointState.WAITING
        level, message = diagnostics.OK, state.value
        if state is SetpointState.TIMED_OUT:
            level, message = diagnostics.WARN, (
                f'no setpoint for {guard.timeout_s:g} s: {guard.safe_behaviour.value}')
        elif self._rejected_since_report:
            level, message = diagnostics.WARN, (
                f'rejected {self._rejected_since_report} setpoint(s): {guard.last_rejection}')
        elif row.limited_by_supply:
            level, message = diagnostics.WARN, 'supply too weak for the setpoint'
        if row.behind_s > OVERLOADED_S and level == diagnostics.OK:
            level, message = diagnostics.WARN, (
                f'overloaded: the simulation is {row.behind_s:.1f} s behind the clock')
        if fault is not Fault.NONE:
            level, message = diagnostics.ERROR, f'circuit fault: {fault.value}'
        figures = {
            'setpoint': guard.last_valid, 'tracked_closure': row.setpoint,
            'closure': row.closure, 'fold_angle_rad': row.fold_angle_rad,
            'pressure_gauge_pa': row.gauge_pa, 'target_gauge_pa': row.target_gauge_pa,
            'fault': fault.value, 'setpoint_state': state.value,
            contract.DIAGNOSTIC_SETPOINTS_REJECTED: guard.rejected,
            'last_rejection': guard.last_rejection,
            contract.DIAGNOSTIC_FREE_AIR_NL: row.free_air_used_nl,
            'sim_time_skipped_s': self.row.skipped_s,
            contract.DIAGNOSTIC_STATES_SKIPPED: self._states_skipped,
            'loop_time_s': row.time_s if row.time_s is not None else math.nan,
            contract.DIAGNOSTIC_BEHIND_S: row.behind_s,
        }
        return diagnostics.status(self, level, 'pressure loop', self.panel_id, message,
                                  figures)

    def destroy_node(self):
        if self.row is not None:
            self.row.loops.close()
        return super().destroy_node()


def build_loops(node, panel_ids, seed=0):
    """Build the shared :class:`~flectofold_model.control.PanelLoops` from ``node``'s settings."""
    settings = node.loop_settings()
    facade = load_facade(settings['facade_file'] or DEFAULT_FACADE)
    parameters = ControllerParameters(
        max_gauge_pa=settings['max_gauge_pressure_pa'],
        time_constant_s=settings['control.time_constant_s'],
        integral_time_s=4.0 * settings['control.time_constant_s'],
        hold_band_pa=settings['control.hold_band_pa'])
    loops = facade_loops(facade, panel_ids, settings['control_period_s'], parameters,
                         seed=seed, quiet_period_s=settings['simulation.quiet_period_s'],
                         max_call_s=MAX_CALL_S)
    compile_kernels()  # here, before the panels report ready, not in their first tick
    return loops


def start_panels(panel_ids, seed=0, **node_kwargs):
    """Create one :class:`PanelNode` per id on one shared loop; return the nodes.

    ``panel_ids`` None: one node whose id comes from its namespace or ``panel_id``.
    """
    nodes = []
    try:
        for panel_id in panel_ids or [None]:
            nodes.append(PanelNode(panel_id, **node_kwargs))
        settings = nodes[0].loop_settings()
        for node in nodes[1:]:
            if node.loop_settings() != settings:
                raise ValueError(f'{node.panel_id}: loop settings {node.loop_settings()} differ '
                                 f'from {nodes[0].panel_id}: {settings}')
        loops = build_loops(nodes[0], [node.panel_id for node in nodes], seed=seed)
    except BaseException:
        for node in nodes:
            node.destroy_node()
        raise
    for index, node in enumerate(nodes):
        node.attach(loops.row(index))
    ids = [node.panel_id for node in nodes]
    nodes[0].get_logger().info(f'{len(nodes)} panel(s) ready: {", ".join(ids)}')
    return nodes


def run_panels(name, args, panel_ids=lambda: None, usage=None, **node_kwargs):
    """Run panel nodes until a stop signal: the body of ``panel_node`` and ``panel_group``.

    ``panel_ids()`` gives the ids (None: one node, its id from its namespace).
    """
    return run_nodes(name, args, lambda: Program(start_panels(panel_ids(), **node_kwargs)),
                     usage, PARAMETERS)


def main(args=None):
    """``ros2 run flectofold_ros panel_node --ros-args -r __ns:=/facade/r00c00``."""
    return run_panels('panel_node', args, usage=USAGE)


if __name__ == '__main__':
    sys.exit(main())
