"""Inputs with one source (``presence.py``): setpoints beside the coordinator, fault requests.

A real ``facade`` day (2 x 2 panels in two panel processes) with ``/facade/setpoints``
published beside the coordinator, faults reset and one requested, as a stray process on the
same domain would. Apart from ``test_one_facade.py`` so that ``--dist loadfile`` runs the two
files' days side by side.
"""

import socket

from bringup_day import finish, start_day
import pytest
from ros_graph import domain_for, Graph
from sensor_msgs.msg import JointState

from flectofold_ros.runtime.interfaces import client, message_class, publisher, subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph


def test_setpoints_beside_the_coordinators_are_refused_and_senders_of_resets_are_logged(
        small_facade_file):
    """Also: each accepted fault request and reset is logged with who can have sent it."""
    graph = Graph(domain_for(73), name='stranger')
    tracked, errors = [], []

    def on_diagnostics(message):
        for status in message.status:
            values = {kv.key: kv.value for kv in status.values}
            if 'setpoint' in values:
                tracked.append(float(values['setpoint']))
            if status.name.endswith(': panel process') and ord(status.level) == 2:
                errors.append(status.message)

    subscription(graph.node, contract.DIAGNOSTICS, on_diagnostics)
    try:
        bringup, output = start_day(graph, small_facade_file, '13:30', '--panel-processes', '2')
        stranger = publisher(graph.node, contract.FACADE_SETPOINTS)
        ids = ['r00c00', 'r00c01', 'r01c00', 'r01c01']
        graph.spin_until(lambda: errors, 30)
        for _ in range(20):
            stranger.publish(JointState(name=ids, position=[0.123] * 4))
            graph.spin_for(0.2)
        assert output.wait_for(graph, 'publishers on /facade/setpoints, which has one', 30), \
            output.text
        graph.node.destroy_publisher(stranger)
        assert output.wait_for(graph, 'one publisher on /facade/setpoints again', 30), \
            output.text
        inject = publisher(graph.node, contract.INJECT_FAULT)
        graph.spin_until(lambda: graph.node.count_subscribers(contract.INJECT_FAULT.name) >= 2,
                         30)
        inject.publish(message_class(contract.INJECT_FAULT.msgtype)(
            name=contract.INJECT_SUPPLY_LOSS, hardware_id='r01c01'))
        assert output.wait_for(graph, 'fault request: supply_loss', 30), output.text
        reset = client(graph.node, contract.reset_faults_service('r01c01'),
                       contract.RESET_FAULTS_TYPE)
        assert reset.wait_for_service(timeout_sec=30)
        future = reset.call_async(message_class(contract.RESET_FAULTS_TYPE).Request())
        graph.spin_until(future.done, 30)
        assert output.wait_for(graph, 'day finished', 240), output.text
        finish(graph, bringup, 60)
        output.rest(graph)
    finally:
        graph.close()
    text = output.text
    assert 0.123 not in tracked  # the stranger's closure was never taken
    assert any('a second source on /facade/setpoints (2 publishers)' in message
               for message in errors), errors
    lines = [line for line in text.splitlines()
             if 'publishers on /facade/setpoints, which has one' in line]
    assert lines, text
    for line in lines:  # the panel processes' and the coordinator's own (it names itself)
        assert '/stranger (announced no flectofold process: host unknown)' in line
        assert f"/facade/coordinator (facade bringup of 'small' (host " \
               f'{socket.gethostname()}, pid {bringup.pid}))' in line, line
        assert 'policy hold' in line
    assert 'fault request: supply_loss on r01c01' in text and 'from /stranger' in text, text
    assert 'reset_faults (' in text and ') from /stranger' in text, text
    assert '_NODE_NAME_UNKNOWN_' not in text, text  # a sender seen early is named later
    assert bringup.returncode == 0, text  # the panels held safe; the day went on
