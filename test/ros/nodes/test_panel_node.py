"""A panel node as its own process over DDS: setpoints, feedback, bad input, watchdog."""

import math
from pathlib import Path
import time

from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
import pytest
from ros_graph import domain_for, Graph
from std_msgs.msg import Float64
from std_srvs.srv import Trigger

from flectofold_model.actuation import actuated_like, ActuationModel, CushionMap
from flectofold_model.facade.description import load_facade
from flectofold_ros.runtime.interfaces import client, publisher, subscription
from flectofold_ros.wire import contract, panel_states

PANEL = 'r02c03'
NS = contract.panel_namespace(PANEL)
pytestmark = pytest.mark.graph


class PanelProbe:
    """Publishes setpoints to one panel and keeps everything it says."""

    def __init__(self, graph):
        node = graph.node
        self.graph = graph
        self.setpoint = publisher(node, contract.SETPOINT.of(PANEL))
        self.pressure, self.joints, self.closure, self.status, self.diagnostics = \
            [], [], [], [], []
        self.pressure_times, self.state_times, self.table = [], [], None
        # A sensor-data (best effort) subscriber is compatible with the reliable stream.
        subscription(node, contract.PRESSURE.of(PANEL), self._on_pressure, contract.SENSOR_DATA)
        subscription(node, contract.JOINT_STATES.of(PANEL), self.joints.append)
        subscription(node, contract.CLOSURE.of(PANEL), lambda m: self.closure.append(m.data))
        subscription(node, contract.STATUS.of(PANEL), lambda m: self.status.append(m.data))
        subscription(node, contract.DIAGNOSTICS, self._on_diagnostics)
        subscription(node, contract.PANEL_STATES, self._on_panel_states)
        self.reset = client(node, contract.reset_faults_service(PANEL), contract.RESET_FAULTS_TYPE)

    def _on_panel_states(self, message):
        self.state_times.append(time.monotonic())
        self.table = panel_states.unpack(message)

    def _on_pressure(self, message):
        self.pressure.append(message)
        self.pressure_times.append(time.monotonic())

    def _on_diagnostics(self, message):
        self.diagnostics += [s for s in message.status if s.hardware_id == PANEL]

    def send(self, value):
        self.setpoint.publish(Float64(data=value))

    def hold(self, value, condition, timeout_s):
        """Keep sending ``value`` at 5 Hz until ``condition()``."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.send(value)
            if self.graph.spin_until(condition, 0.2):
                return True
        return False


@pytest.fixture(scope='module')
def model():
    facade = load_facade()
    actuation = ActuationModel([actuated_like(facade.panels[facade.panel_ids.index(PANEL)])])
    return actuation, CushionMap(actuation)


@pytest.fixture(scope='module')
def panel():
    graph = Graph(domain_for(0))
    process = graph.start('panel_node', '--ros-args', '-r', f'__ns:={NS}',
                          '-p', 'setpoint_timeout_s:=3.0')
    probe = PanelProbe(graph)
    assert graph.spin_until(lambda: probe.status and probe.pressure, 30.0), \
        graph.stop(process)[1]
    yield graph, process, probe
    code, output = graph.stop(process)
    graph.close()
    assert code == 0, output


def test_a_setpoint_from_another_process_moves_pressure_and_fold_angle(panel, model):
    graph, process, probe = panel
    actuation, cushion_map = model
    target = 0.4
    assert probe.hold(target, lambda: probe.closure and abs(probe.closure[-1] - target) < 0.01
                      and probe.status[-1] == 'tracking', 40.0), probe.closure[-5:]
    graph.spin_for(1.0)
    expected_pa = 101325.0 + cushion_map.pressure_for_closure(np.array([target]))[0]
    assert probe.pressure[-1].fluid_pressure == pytest.approx(expected_pa, abs=120.0)
    assert probe.pressure[-1].header.frame_id == PANEL
    # The topics of one state arrive independently and the state moves inside the hold band
    # from one to the next: a joint_states a few states old belongs to one of the newest
    # closures, whose state has surely arrived whole.
    joints = probe.joints[-3]
    assert list(joints.name) == [f'{PANEL}_flap_left', f'{PANEL}_flap_right']
    angles = [actuation.fold.state_from_closure(c).apex_fold_angle_rad[0]
              for c in probe.closure[-6:]]
    assert any(np.allclose(joints.position, [a, a], rtol=2e-3) for a in angles), \
        (joints.position, angles)
    assert angles[-1] > actuation.fold.open_fold_angle_rad[0] + 0.1


def test_bad_setpoints_are_rejected_and_the_loop_keeps_its_timing(panel):
    graph, process, probe = panel
    holding = probe.closure[-1]
    probe.state_times.clear()
    probe.diagnostics.clear()
    bad = [math.nan, math.inf, -math.inf, 1.5, -0.2]
    sent, last_valid = 0, 0.0
    for _ in range(400):  # 2,000 bad setpoints over at least 4 s (a count, not a duration)
        if time.monotonic() - last_valid > 0.5:  # a live commander between the bad ones
            probe.send(0.4)
            last_valid = time.monotonic()
        for value in bad:
            probe.send(value)
        sent += len(bad)
        graph.spin_for(0.01)
    graph.spin_for(0.5)
    assert graph.spin_until(lambda: len(probe.state_times) > 26, 30.0), probe.state_times
    intervals = np.diff(probe.state_times)  # panel_states: every state, moving or not
    assert np.median(intervals) == pytest.approx(0.1, abs=0.02)  # publish_rate_hz 10
    assert intervals.max() < 2.0  # no stall (a loaded machine delays a few by 100s of ms)
    assert abs(probe.closure[-1] - holding) < 0.02
    warnings = [s for s in probe.diagnostics if s.level == DiagnosticStatus.WARN]
    assert warnings and 'rejected' in warnings[0].message

    def rejected():  # diagnostics come once a second: the last may predate the flood's end
        return int({kv.key: kv.value for kv in probe.diagnostics[-1].values}
                   ['setpoints_rejected'])
    assert graph.spin_until(lambda: rejected() >= sent * 0.9, 30.0), (rejected(), sent)
    assert probe.diagnostics[-1].name == f'{NS}/panel: pressure loop'


def test_no_setpoint_for_the_timeout_vents_the_panel_open(panel):
    graph, process, probe = panel
    assert graph.spin_until(lambda: probe.status[-1] == 'setpoint_timeout', 30.0)
    # The loop tracks closure 0: it vents, and the flaps spring open (the closure, from the
    # filtered pressure of a vented cushion, settles within the sensor noise of 0).
    assert graph.spin_until(lambda: probe.table['setpoint'][0] == 0.0 and
                            probe.table['closure'][0] < 0.03, 30.0), probe.table
    assert probe.hold(0.2, lambda: probe.status[-1] == 'tracking', 30.0)


def test_reset_faults_service_answers(panel):
    graph, process, probe = panel
    assert probe.reset.wait_for_service(timeout_sec=30.0)
    future = probe.reset.call_async(Trigger.Request())
    assert graph.spin_until(future.done, 30.0)
    assert future.result().success and future.result().message == 'no fault'


@pytest.mark.parametrize('arguments, message', [
    (['-p', 'control_period_s:=5.0'], 'control_period_s'),
    (['-p', 'safe_behaviour:=explode'], 'safe_behaviour'),
    (['-p', 'control.time_constant_s:=0.1'], 'at least twice'),
    (['-p', 'control_period_s:=1'], 'control_period_s'),
])
def test_bad_parameters_are_refused_with_a_reason(arguments, message):
    graph = Graph(domain_for(1))
    try:
        process = graph.start('panel_node', '--ros-args', '-r', f'__ns:={NS}', *arguments)
        code, output = process.wait(timeout=30.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2, output
    assert message in output and 'Traceback' not in output


@pytest.mark.parametrize('arguments, message', [
    ([], 'not of the form rNNcNN'),
    (['-r', '__ns:=/facade/r09c09'], 'unknown panel id'),
])
def test_a_panel_needs_a_known_id(arguments, message):
    graph = Graph(domain_for(1))
    try:
        process = graph.start('panel_node', '--ros-args', *arguments)
        code, output = process.wait(timeout=30.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2 and message in output, output


def test_a_refused_runtime_change_leaves_every_parameter_as_it_was():
    from rclpy.parameter import Parameter

    from flectofold_ros.nodes.panel_node import start_panels
    graph = Graph(domain_for(4))
    try:
        program = start_panels([PANEL], context=graph.context)
        node, guard = program.nodes[0], program.process.guards
        results = node.set_parameters_atomically([Parameter('setpoint_timeout_s', value=5.0),
                                                  Parameter('safe_behaviour', value='explode')])
        assert not results.successful and 'explode' in results.reason
        assert guard.timeout_s == 10.0
        assert node.get_parameter('setpoint_timeout_s').value == 10.0
        assert node.set_parameters_atomically([Parameter('setpoint_timeout_s', value=5.0),
                                               Parameter('safe_behaviour', value='hold')]
                                              ).successful
        assert guard.timeout_s == 5.0 and guard.safe_behaviour.value == 'hold'
        program.process.close()
        node.destroy_node()
    finally:
        graph.close()


def test_the_example_parameter_file_starts_a_panel():
    config = Path(__file__).resolve().parents[3] / 'config' / 'panel.yaml'
    graph = Graph(domain_for(5))
    try:
        process = graph.start('panel_node', '--ros-args', '-r', f'__ns:={NS}',
                              '--params-file', str(config))
        probe = PanelProbe(graph)
        assert graph.spin_until(lambda: probe.status and probe.diagnostics, 30.0), \
            graph.stop(process)[1]
        values = {kv.key: kv.value for kv in probe.diagnostics[-1].values}
        assert probe.status[-1] == 'waiting_for_setpoint' and values['fault'] == 'none'
        code, output = graph.stop(process)
    finally:
        graph.close()
    assert code == 0, output


HARDWARE_FILE = '/**:\n  ros__parameters:\n    hardware: real\n'


@pytest.mark.parametrize('executable, arguments', [
    ('panel_node', ['-r', f'__ns:={NS}', '-p', 'hardware:=real']),
    ('panel_group', ['-p', 'hardware:=real']),
    ('panel_group', ['--params-file', 'HARDWARE_FILE']),
    ('panel_group', ['-p', 'hardware:=Simulated']),
])
def test_a_cushion_driver_that_does_not_exist_is_refused_at_start(executable, arguments,
                                                                  tmp_path):
    params = tmp_path / 'hardware.yaml'
    params.write_text(HARDWARE_FILE)
    arguments = [str(params) if a == 'HARDWARE_FILE' else a for a in arguments]
    before = ['--panels', PANEL] if executable == 'panel_group' else []
    graph = Graph(domain_for(19))
    try:
        process = graph.start(executable, *before, '--ros-args', *arguments)
        code, output = process.wait(timeout=30.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2, output
    lines = output.strip().splitlines()
    assert len(lines) == 1 and 'Traceback' not in output, output
    assert lines[0].startswith(f'{executable}: parameter hardware=') and \
        lines[0].endswith('must be one of simulated, modbus'), output


@pytest.mark.parametrize('group_name', [None, 'panel_group_test'])
def test_the_cushion_driver_cannot_be_changed_at_run_time(group_name):
    from rclpy.parameter import Parameter

    from flectofold_ros.nodes.panel_node import start_panels
    graph = Graph(domain_for(19))
    try:
        program = start_panels([PANEL], group_name, context=graph.context)
        settings = program.nodes[0]
        for value in ('real', 'simulated'):
            result = settings.set_parameters([Parameter('hardware', value=value)])[0]
            assert not result.successful and 'hardware' in result.reason, result
        assert settings.get_parameter('hardware').value == 'simulated'
        program.process.close()
        for node in program.nodes:
            node.destroy_node()
    finally:
        graph.close()


@pytest.mark.parametrize('arguments, message', [
    (['--panels', ''], "--panels names no panel: ''"),
    (['--panels', ' , '], "--panels names no panel: ' , '"),
    (['--panels', 'r00c00;rm'], "--panels: 'r00c00;rm' is no panel id (r<row>c<column>, two "
                                'digits each)'),
    (['--panels', 'r00c00', '--name', '../x'], '--name must be a ROS node name (a letter or _, '
                                               "then letters, digits or _), got '../x'"),
])
def test_bad_panel_group_options_are_refused_with_a_reason(arguments, message):
    # Before, each of these ended in a traceback (exit 1).
    graph = Graph(domain_for(19))
    try:
        process = graph.start('panel_group', *arguments)
        code, output = process.wait(timeout=60.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2 and 'Traceback' not in output, output
    assert output.strip().splitlines()[-1] == f'panel_group: error: {message}', output


def test_a_panel_id_and_a_namespace_that_disagree_are_refused():
    # Before, the node ran with the id: r00c00's setpoints went nowhere.
    graph = Graph(domain_for(19))
    try:
        process = graph.start('panel_node', '--ros-args', '-r', '__ns:=/facade/r00c00', '-p',
                              'panel_id:=r00c01')
        code, output = process.wait(timeout=60.0), process.stdout.read()
    finally:
        graph.close()
    assert code == 2 and 'Traceback' not in output, output
    assert output.strip() == ("panel_node: panel_id 'r00c01' and namespace '/facade/r00c00' "
                              'disagree: the node would sit in one and serve the topics of the '
                              'other; give one of them'), output
