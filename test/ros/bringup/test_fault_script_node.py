"""A fault script played on the ROS clock into a real panel_group process over DDS."""

import datetime
import time

from builtin_interfaces.msg import Time
import pytest
from ros_graph import domain_for, Graph
from rosgraph_msgs.msg import Clock

from flectofold_ros.bringup.fault_script import load_fault_script
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
FACADE = [f'r{row:02d}c{column:02d}' for row in range(6) for column in range(6)]
OFFSET_H = 2.0
ZONE = datetime.timezone(datetime.timedelta(hours=OFFSET_H))
START_S = datetime.datetime(2026, 6, 21, 12, 0, tzinfo=ZONE).timestamp()
END_S = START_S + 3 * 3600.0


def test_the_script_node_injects_each_fault_when_the_ros_clock_reaches_it(tmp_path):
    """Each fault goes in when the ROS clock reaches its time, not before.

    Two panels in a real panel_group at rest; the script loses one's supply at +10 s and
    sticks the other's sensor at 12:00:20. As the bringup does, the clock holds at the day's
    start until the panels are heard, then runs at 2x. When a fault came is the stamp of the
    first state that shows it: the panels' simulated time of detection.
    """
    from flectofold_ros.bringup.fault_script_node import FaultScriptNode
    path = tmp_path / 'faults.yaml'
    path.write_text('- {at: 10, panels: [r00c00], fault: supply_loss}\n'
                    "- {at: '12:00:20', panels: [r00c01], fault: sensor_stuck}\n")
    script = load_fault_script(path, FACADE, START_S, END_S, OFFSET_H)
    graph = Graph(domain_for(18))
    process = graph.start('panel_group', '--panels', 'r00c00,r00c01', '--ros-args',
                          '-p', 'use_sim_time:=true', '-p', 'setpoint_timeout_s:=86400.0',
                          group=True)
    node = None
    try:
        clock = publisher(graph.node, contract.CLOCK)
        started = None  # wall time the day started at

        def now_s():
            return START_S + (0.0 if started is None else 2.0 * (time.monotonic() - started))

        def tick():
            now = now_s()
            clock.publish(Clock(clock=Time(sec=int(now), nanosec=int(now % 1 * 1e9))))
        graph.node.create_timer(0.02, tick)
        heard, named, detected = set(), {}, {}

        def on_fault(message, panel):
            heard.add(panel)
            if message.data != 'none':
                named.setdefault(panel, message.data)

        def on_states(message):
            table = panel_states.unpack(message)
            offset_s = panel_states.stamp_ns(message.header) * 1e-9 - START_S
            for panel, word in zip(panel_states.panel_ids(table),
                                   panel_states.fault_words(table)):
                if word != contract.NO_FAULT:
                    detected.setdefault(panel, (word, offset_s))
        for panel in ('r00c00', 'r00c01'):
            subscription(graph.node, contract.FAULT.of(panel),
                         lambda m, p=panel: on_fault(m, p))
        subscription(graph.node, contract.PANEL_STATES, on_states)
        node = FaultScriptNode(script, START_S, context=graph.context)
        graph.executor.add_node(node)
        assert graph.spin_until(lambda: len(heard) == 2, 60.0), process.poll()
        graph.spin_for(1.0)
        assert node.sent == 0  # the clock holds at the start
        started = time.monotonic()
        assert graph.spin_until(lambda: len(named) == 2 and len(detected) == 2, 60.0), \
            (named, detected, process.poll())
        assert node.done and node.sent == 2
        assert named == {'r00c00': 'supply_lost', 'r00c01': 'sensor_stuck'}, named
        # at the scripted times: not before (detection takes some 0.2 and 0.5 s), and the
        # first before the second's time, with room for a late delivery of the request
        # on a busy machine (3 s of wall time at 2x)
        supply, stuck = detected['r00c00'], detected['r00c01']
        assert supply[0] == 'supply_lost' and 10.0 <= supply[1] < 16.0, supply
        assert stuck[0] == 'sensor_stuck' and 20.0 <= stuck[1] < 30.0, stuck
    finally:
        if node is not None:
            graph.executor.remove_node(node)
            node.destroy_node()
        graph.stop(process)
        graph.close()
