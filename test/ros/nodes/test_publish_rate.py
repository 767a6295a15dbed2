"""When a panel process publishes what, measured as a user would (msg_docs/panel_node.md).

Every state instant (``publish_rate_hz``) goes out on the facade-level topics; a panel's own
state topics go out at that rate while its loop moves it and at ``heartbeat_period_s`` at rest.
"""

import time

import numpy as np
import pytest
from ros_graph import domain_for, Graph
from std_msgs.msg import Float64

from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
#: Process -> (panels, asked publish rate [Hz], heartbeat [s]); the loop runs at 10 Hz.
PROCESSES = {'slow': (['r00c00', 'r00c01'], 2.0, 1.0),
             'fast': (['r01c00', 'r01c01', 'r01c02'], 10.0, 0.5)}
REST_S = 6.0
MOVING = 'r01c01'


def _stamp_s(message):
    return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9


@pytest.fixture(scope='module')
def heard():
    """Two panel groups in real time: at rest, then one panel moved; everything they said.

    The windows are of the processes' clock (the wall clock: their stamps), not of arrival: a
    loaded machine delays messages, not the instants they carry.
    """
    graph = Graph(domain_for(20))
    panel_topic = {}   # panel -> [(arrival, stamp)] of its own joint_states
    clouds = {name: [] for name in PROCESSES}   # process -> [(arrival, stamp, table)]
    joints = []
    owner = {p: name for name, (panels, _, _) in PROCESSES.items() for p in panels}
    try:
        processes = [graph.start('panel_group', '--panels', ','.join(panels), '--ros-args',
                                 '-p', f'publish_rate_hz:={rate!r}',
                                 '-p', f'heartbeat_period_s:={heartbeat!r}',
                                 '-p', 'setpoint_timeout_s:=60.0')
                     for panels, rate, heartbeat in PROCESSES.values()]
        for panel_id in owner:
            pairs = panel_topic.setdefault(panel_id, [])
            subscription(graph.node, contract.JOINT_STATES.of(panel_id),
                         lambda m, pairs=pairs: pairs.append((time.monotonic(), _stamp_s(m))))

        def on_cloud(message):
            table = panel_states.unpack(message)
            name = owner[panel_states.panel_ids(table)[0]]
            clouds[name].append((time.monotonic(), _stamp_s(message), table.copy()))
        subscription(graph.node, contract.PANEL_STATES, on_cloud, contract.OBSERVER)
        subscription(graph.node, contract.FACADE_JOINT_STATES, joints.append,
                     contract.OBSERVER)
        command = publisher(graph.node, contract.SETPOINT.of(MOVING))
        assert graph.spin_until(lambda: all(len(c) >= 2 for c in clouds.values()), 60.0), \
            [graph.stop(p)[1] for p in processes]
        graph.spin_for(2.0)  # the first states of every panel go out at once: let them pass
        rest_started = time.time()
        graph.spin_for(REST_S)
        moving_started = time.time()
        deadline = moving_started + 6.0
        while time.time() < deadline:
            command.publish(Float64(data=0.9))
            graph.spin_for(0.5)
        # every state stamped in the windows has been sent: wait for those that are late
        assert graph.spin_until(lambda: all(c[-1][1] >= deadline for c in clouds.values()),
                                30.0)
        for process in processes:
            code, output = graph.stop(process)
            assert code == 0, output
    finally:
        graph.close()
    return {'panel': panel_topic, 'clouds': clouds, 'joints': joints,
            'rest': (rest_started, moving_started), 'moving': (moving_started, deadline)}


def _within(pairs, window):
    """Return the ``(arrival, stamp)`` pairs stamped inside ``window``."""
    start, end = window
    return [(arrival, stamp) for arrival, stamp in pairs if start <= stamp < end]


@pytest.mark.parametrize('name', sorted(PROCESSES))
def test_panel_states_carry_every_state_at_the_asked_rate(heard, name):
    panels, rate, _ = PROCESSES[name]
    clouds = heard['clouds'][name]
    stamps = np.array([stamp for _, stamp, _ in clouds[1:]])  # the first: as soon as it runs
    np.testing.assert_allclose(np.diff(stamps), 1.0 / rate, atol=1e-3)
    rest = [c for c in clouds if heard['rest'][0] <= c[1] < heard['rest'][1]]
    assert abs(len(rest) - rate * REST_S) <= 1 + 0.02 * rate * REST_S
    assert all(panel_states.panel_ids(table) == panels for _, _, table in clouds)


def test_facade_joint_states_name_every_flap_of_a_process(heard):
    names = {tuple(m.name) for m in heard['joints']}
    assert names == {tuple(contract.flap_joint_names(p)[k] for p in panels for k in (0, 1))
                     for panels, _, _ in PROCESSES.values()}
    assert all(len(m.position) == len(m.name) for m in heard['joints'])


@pytest.mark.parametrize('panel_id', ['r00c00', 'r00c01', 'r01c00', 'r01c02'])
def test_at_rest_a_panel_publishes_its_own_state_at_the_heartbeat(heard, panel_id):
    name = next(n for n, (panels, _, _) in PROCESSES.items() if panel_id in panels)
    _, rate, heartbeat = PROCESSES[name]
    pairs = _within(heard['panel'][panel_id], heard['rest'])
    stamps = np.array([stamp for _, stamp in pairs])
    # A tick late by a few hundred ms (a loaded machine) sends the heartbeat with its newest
    # state: that gap is longer, and the window holds one fewer. Never sooner than the
    # heartbeat, and never twice as long; mostly exactly the heartbeat.
    assert -2 <= len(pairs) - REST_S / heartbeat <= 1, (len(pairs), REST_S / heartbeat)
    gaps = np.diff(stamps)
    assert np.all(gaps >= heartbeat - 1e-3) and np.all(gaps < 2.0 * heartbeat - 1e-3), gaps
    assert np.median(gaps) == pytest.approx(heartbeat, abs=1e-3), gaps


def test_a_moving_panel_publishes_every_state_and_the_others_keep_the_heartbeat(heard):
    _, rate, heartbeat = PROCESSES['fast']
    moving = _within(heard['panel'][MOVING], heard['moving'])
    stamps = np.array([stamp for _, stamp in moving])
    assert len(moving) > 0.6 * rate * 6.0, len(moving)  # it moves for most of the 6 s
    assert np.median(np.diff(stamps)) == pytest.approx(1.0 / rate, abs=1e-3)
    still = _within(heard['panel']['r01c00'], heard['moving'])
    assert len(still) <= 6.0 / heartbeat + 1
    cloud = [table for _, stamp, table in heard['clouds']['fast']
             if stamp >= heard['moving'][0]]
    index = ['r01c00', 'r01c01', 'r01c02'].index(MOVING)
    assert cloud[-1]['closure'][index] > 0.3 and cloud[-1]['setpoint'][index] == \
        pytest.approx(0.9)
    assert any(table['active'][index] for table in cloud)
    assert not any(table['active'][0] for table in cloud)
