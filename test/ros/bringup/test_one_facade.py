"""One facade per ROS domain, and inputs with one source (``presence.py``, ``domain_watch.py``).

Each test runs a real ``facade`` day (2 x 2 panels in two panel processes) and does to it
what a second operator or a stray process on the same domain would: start a second facade,
coordinator or panel process; publish a second ``/clock``. Setpoints beside the coordinator and
fault requests: ``test_one_facade_setpoints.py``.
"""

import signal
import socket
import time

from bringup_day import finish, start_day
import pytest
from ros_graph import domain_for, Graph
from rosgraph_msgs.msg import Clock

from flectofold_ros.runtime.interfaces import publisher
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph


def test_a_second_facade_coordinator_or_panel_process_is_refused_naming_the_first(
        small_facade_file):
    graph = Graph(domain_for(71))
    try:
        # a day long enough (210 s of wall time) for three refusals on a loaded machine, each
        # of which listens 6 s or more; stopped with Ctrl-C once they are done
        first, output = start_day(graph, small_facade_file, '18:00', '--panel-processes', '2')
        codes, texts = [], []
        for command in (['facade', '--facade', str(small_facade_file), '--start', '11:00',
                         '--end', '11:10', '--panel-processes', '2'],
                        ['coordinator_node', '--ros-args', '-p',
                         f'facade_file:={small_facade_file}'],
                        ['panel_group', '--panels', 'r00c01', '--name', 'intruder', '--facade',
                         str(small_facade_file)]):  # one after the other, as an operator would
            assert first.poll() is None, output.text  # the first still holds the domain
            intruder = graph.start(*command)
            codes.append(finish(graph, intruder, 120))
            texts.append(graph.stop(intruder)[1])
        assert first.poll() is None, output.text
        first.send_signal(signal.SIGINT)
        finish(graph, first, 60)
        output.rest(graph)
    finally:
        graph.close()
    first_is = f"of 'small' (host {socket.gethostname()}, pid {first.pid})"
    assert first.returncode == 130, output.text  # the Ctrl-C, not a conflict (5)
    assert codes == [2, 2, 2], texts
    assert f'facade: another facade on this ROS domain (ROS_DOMAIN_ID {graph.domain_id}): ' \
           f'facade bringup {first_is} already holds /clock, /facade/coordinator' \
        in texts[0], texts[0]
    assert f'coordinator_node: another facade on this ROS domain (ROS_DOMAIN_ID ' \
           f'{graph.domain_id}): ' \
           f'facade bringup {first_is} already holds /facade/coordinator' in texts[1], texts[1]
    assert f'panel_group: another facade on this ROS domain (ROS_DOMAIN_ID {graph.domain_id}' \
           "): panel process of '" in texts[2], texts[2]
    assert 'already holds panel(s) r00c01' in texts[2], texts[2]
    assert all('Traceback' not in text for text in texts)
    # the first ran on, untouched: none of the refused ones announced itself to it
    assert 'CONFLICT' not in output.text and 'panels reporting: 4/4' in output.text
    assert 'Traceback' not in output.text


def test_a_second_clock_stops_the_day_with_an_error_and_exit_code_5(small_facade_file):
    graph = Graph(domain_for(72), name='stray_clock')
    try:
        bringup, output = start_day(graph, small_facade_file, '14:00', '--panel-processes', '2')
        stray = publisher(graph.node, contract.CLOCK)
        deadline = time.monotonic() + 60
        while bringup.poll() is None and time.monotonic() < deadline:
            stray.publish(Clock(clock=graph.node.get_clock().now().to_msg()))  # wall time
            graph.spin_for(0.1)
        assert finish(graph, bringup, 60) == 5
        output.rest(graph)
    finally:
        graph.close()
    text = output.text
    assert 'facade: ERROR: a second /clock (' in text, text
    assert '/stray_clock (announced no flectofold process: host unknown)' in text
    assert 'CONFLICT: the day was stopped at 11:' in text, text
    assert 'day finished' not in text  # the stray's far later time did not end the day
    assert 'Traceback' not in text
