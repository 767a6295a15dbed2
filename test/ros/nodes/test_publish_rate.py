"""A panel publishes its state at the publish_rate_hz it is given, measured as a user would."""

import time

import numpy as np
import pytest
from ros_graph import domain_for, Graph

from flectofold_ros import contract
from flectofold_ros.interfaces import subscription

pytestmark = pytest.mark.graph
#: Panel -> asked publish rate [Hz]; the loop runs at its default 10 Hz.
RATES = {'r00c00': 1.0, 'r00c01': 2.0, 'r00c02': 5.0, 'r00c03': 10.0}
WINDOW_S = 6.0


@pytest.fixture(scope='module')
def published():
    """Run four panel nodes in real time; return each one's (arrival, stamp) pairs."""
    graph = Graph(domain_for(20))
    heard = {panel_id: [] for panel_id in RATES}
    try:
        processes = [graph.start('panel_node', '--ros-args', '-r',
                                 f'__ns:={contract.panel_namespace(panel_id)}',
                                 '-p', f'publish_rate_hz:={rate!r}')
                     for panel_id, rate in RATES.items()]
        for panel_id, pairs in heard.items():
            subscription(graph.node, contract.JOINT_STATES.of(panel_id), lambda m, pairs=pairs:
                         pairs.append((time.monotonic(),
                                       m.header.stamp.sec + m.header.stamp.nanosec * 1e-9)))
        assert graph.spin_until(lambda: all(len(p) >= 2 for p in heard.values()), 60.0), \
            [graph.stop(p)[1] for p in processes]
        graph.spin_for(WINDOW_S + 2.0)
        for process in processes:
            code, output = graph.stop(process)
            assert code == 0, output
    finally:
        graph.close()
    return heard


@pytest.mark.parametrize('panel_id', sorted(RATES))
def test_the_stamps_come_at_the_asked_rate(published, panel_id):
    stamps = np.array([stamp for _, stamp in published[panel_id]])
    period = 1.0 / RATES[panel_id]
    np.testing.assert_allclose(np.diff(stamps), period, atol=1e-3)


@pytest.mark.parametrize('panel_id', sorted(RATES))
def test_as_many_messages_arrive_as_the_rate_asks(published, panel_id):
    arrivals = np.array([arrival for arrival, _ in published[panel_id]])
    window = arrivals[arrivals >= arrivals[-1] - WINDOW_S]
    expected = RATES[panel_id] * WINDOW_S
    assert abs(len(window) - expected) <= 1 + 0.05 * expected, (len(window), expected)
