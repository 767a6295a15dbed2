"""The sun position node in-process: simulated /clock, sun vectors, the end, bad parameters."""

import os
from pathlib import Path
import subprocess
import sys
import time

from builtin_interfaces.msg import Time
import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.exceptions import ParameterException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from ros_graph import domain_for
from rosgraph_msgs.msg import Clock

from flectofold_model.environment.sun import epoch_from_iso, Site, sun_vector_enu
from flectofold_ros.nodes.sun_position import SunPositionNode
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph
#: rcl's log topic (not the package's): latched, so that a late probe hears the start-up.
ROSOUT = contract.Topic('/rosout', 'rcl_interfaces/msg/Log', contract.Qos(depth=100, latched=True))
# A domain of its own, so that parallel test runs on this host do not hear each other.
DOMAIN_ID = domain_for(41)  # this worker's own range (was 60-99: other workers' tests)
NS = 10**9
NOON = '2026-06-21T12:00:00+02:00'
SHORT_DAY = {'mode': 'simulated', 'start_time': NOON,
             'end_time': '2026-06-21T12:10:00+02:00', 'speedup': 600.0}
START_NS = int(epoch_from_iso(NOON)) * NS
END_NS = START_NS + 600 * NS
SITE = Site(48.7784, 9.18, 245.0)


def epoch_ns(stamp):
    return stamp.sec * NS + stamp.nanosec


class Probe:
    """A listener of /clock, /facade/sun and /rosout with an executor, in its own context."""

    def __init__(self, context):
        self.context = context
        self.node = Node('probe', context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.clock = []  # (steady receive time [s], /clock [ns])
        self.sun = []
        self.logs = []
        subscription(self.node, contract.CLOCK,
                     lambda m: self.clock.append((time.monotonic(), epoch_ns(m.clock))))
        subscription(self.node, contract.SUN, self.sun.append)
        subscription(self.node, ROSOUT, self.logs.append)

    def start(self, **parameters):
        """Create the node, wait until its topics reach this probe, then spin it."""
        node = SunPositionNode(context=self.context, parameter_overrides=[
            Parameter(name, value=value) for name, value in parameters.items()])
        topics = {contract.CLOCK.name, contract.SUN.name} if node.mode == 'simulated' \
            else {contract.SUN.name}
        publishers = [p for p in node.publishers if p.topic_name in topics]
        assert len(publishers) == len(topics)
        assert self.wait(lambda: all(p.get_subscription_count() for p in publishers), 30.0)
        self.executor.add_node(node)
        return node

    def wait(self, condition, timeout_s):
        deadline = time.monotonic() + timeout_s
        while not condition() and time.monotonic() < deadline:
            time.sleep(0.01)
        return condition()

    def spin_for(self, duration_s):
        deadline = time.monotonic() + duration_s
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    def spin_until(self, condition, timeout_s):
        deadline = time.monotonic() + timeout_s
        while not condition() and time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)
        return condition()


@pytest.fixture
def context():
    context = Context()
    rclpy.init(context=context, domain_id=DOMAIN_ID)
    yield context
    rclpy.try_shutdown(context=context)


@pytest.fixture
def probe(context):
    probe = Probe(context)
    yield probe
    # Destroy the nodes before the executor's shutdown forgets them: a node left alive keeps
    # its name's /rosout publisher, and the next node of that name logs into it.
    for node in probe.executor.get_nodes():
        node.destroy_node()
    probe.executor.shutdown()


def end_clock_arrivals(probe):
    """Steady receive times [s] of the /clock messages at the end of the short day."""
    return [received for received, clock_ns in probe.clock if clock_ns == END_NS]


@pytest.fixture
def short_day(probe):
    """Run a 10-minute simulated day at 600x until it finished and repeated its end twice."""
    node = probe.start(frame_id='stuttgart_enu', **SHORT_DAY)
    assert node.sim_epoch_s == START_NS / NS
    assert probe.spin_until(lambda: node.finished, 30.0)
    # the end's own /clock, then two repeats of it
    assert probe.spin_until(lambda: len(end_clock_arrivals(probe)) >= 3, 30.0), probe.clock[-5:]
    return node


def test_simulated_clock_runs_speedup_times_the_wall_clock(probe):
    node = probe.start(mode='simulated', start_time=NOON, speedup=600.0)
    assert probe.spin_until(lambda: len(probe.clock) >= 100, 30.0)  # 2 s of the 50 Hz clock
    received_s = np.array([received for received, _ in probe.clock])
    clock_ns = np.array([ns for _, ns in probe.clock])  # exact: no float64 of 1.8e18 ns
    assert clock_ns[0] == START_NS
    assert np.all(np.diff(clock_ns) > 0)
    # 50 Hz: a tick is 1/50 s of the steady clock, 12 s of simulated time at 600x (the median:
    # the odd late tick of a busy machine is longer, the one after it shorter)
    assert np.median(np.diff(clock_ns)) / NS == pytest.approx(600.0 / 50.0, rel=0.1)
    rate = np.polyfit(received_s - received_s[0], (clock_ns - START_NS) / NS, 1)[0]
    assert rate == pytest.approx(600.0, rel=0.15)
    assert not node.finished
    # in ns as the node rounds its simulated time for /clock (seconds lose the last ulp)
    assert clock_ns[-1] <= round(node.sim_epoch_s * NS) < clock_ns[-1] + 300 * NS


def test_sun_messages_are_the_spa_sun_vectors_at_their_stamps(short_day, probe):
    stamps_ns = np.array([epoch_ns(m.header.stamp) for m in probe.sun])
    vectors = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in probe.sun])
    assert {m.header.frame_id for m in probe.sun} == {'stuttgart_enu'}
    # Every publish_period_s = 60 s of simulated time, on the grid from the start to the end.
    assert stamps_ns[0] == START_NS and stamps_ns[-1] == END_NS
    assert np.all(np.diff(stamps_ns) > 0)
    assert np.all((stamps_ns - START_NS) % (60 * NS) == 0)
    assert len(stamps_ns) >= 8
    np.testing.assert_allclose(np.linalg.norm(vectors, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(vectors, sun_vector_enu(stamps_ns / NS, SITE), rtol=0, atol=1e-9)
    # Stuttgart before its solar noon (about 13:25 CEST) at midsummer: high and south-east.
    assert np.all(vectors[:, 2] > 0.8) and np.all(vectors[:, 0] > 0) and np.all(vectors[:, 1] < 0)


def test_clock_stops_exactly_at_the_end(short_day, probe):
    node = short_day
    clock_ns = np.array([ns for _, ns in probe.clock])
    assert np.all(np.diff(clock_ns) >= 0)
    assert clock_ns.max() == END_NS and clock_ns[-1] == END_NS
    assert node.finished and node.sim_epoch_s == END_NS / NS
    assert epoch_ns(probe.sun[-1].header.stamp) == END_NS
    # Then the final /clock again for late joiners (nothing else: the clock ends at END_NS),
    # at 1 Hz, not the 50 Hz of the day: after the end's own message and the tick due before
    # the new period took effect, the repeats come a period apart.
    ends = end_clock_arrivals(probe)
    assert len(ends) >= 3 and np.all(np.diff(ends[1:]) > 0.5), np.diff(ends)
    messages = [log.msg for log in probe.logs if log.name == contract.SUN_POSITION_NODE]
    assert any('mode simulated' in msg and '600x' in msg for msg in messages), messages
    assert any('simulated day finished' in msg for msg in messages), messages


def test_wall_mode_with_sim_time_follows_an_external_clock(probe):
    clock = publisher(probe.node, contract.CLOCK)
    node = probe.start(mode='wall', use_sim_time=True, publish_period_s=60.0)
    # The probe's own /clock subscription is one match, the node's time source the other.
    assert probe.wait(lambda: clock.get_subscription_count() >= 2, 30.0)
    published = [START_NS + k * 60 * NS for k in range(4)]
    for clock_ns in published:
        clock.publish(Clock(clock=Time(sec=clock_ns // NS, nanosec=clock_ns % NS)))
        assert probe.spin_until(
            lambda: probe.sun and epoch_ns(probe.sun[-1].header.stamp) == clock_ns, 30.0), \
            (clock_ns, [epoch_ns(m.header.stamp) for m in probe.sun])
    stamps_ns = [epoch_ns(m.header.stamp) for m in probe.sun]
    assert stamps_ns == published
    vectors = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in probe.sun])
    np.testing.assert_allclose(vectors, sun_vector_enu(np.array(stamps_ns) / NS, SITE),
                               rtol=0, atol=1e-9)
    assert probe.sun[0].header.frame_id == contract.SITE_FRAME
    assert not node.finished and node.sim_epoch_s is None


@pytest.mark.parametrize('parameters, error, named', [
    ({'latitude_deg': 95.0}, ParameterException, 'latitude_deg'),
    ({'speedup': 20000.0}, ParameterException, 'speedup'),
    ({'speedup': 360}, ParameterException, 'speedup'),  # an int where a float is declared
    ({'mode': 'sideways'}, ValueError, 'mode'),
    ({'end_time': '2026-06-21T03:00:00+02:00'}, ValueError, 'end_time'),
    ({'start_time': '2026-06-21T04:00:00'}, ValueError, 'start_time'),
    ({'start_time': 'dawn'}, ValueError, 'start_time'),
    ({'end_time': '2040-01-01T00:00:00Z'}, ValueError, 'end_time'),
    ({'mode': 'simulated', 'use_sim_time': True}, ValueError, 'use_sim_time'),
])
def test_bad_parameters_are_refused_naming_them(context, parameters, error, named):
    overrides = [Parameter(name, value=value) for name, value in parameters.items()]
    with pytest.raises(error, match=named):
        SunPositionNode(context=context, parameter_overrides=overrides)


def test_runtime_parameter_changes(probe):
    node = probe.start(mode='simulated', start_time=NOON, speedup=3600.0)
    refused = node.set_parameters([Parameter('use_sim_time', value=True)])[0]
    assert not refused.successful and 'use_sim_time' in refused.reason
    assert not node.set_parameters([Parameter('latitude_deg', value=10.0)])[0].successful
    assert not node.set_parameters([Parameter('publish_period_s', value=0.001)])[0].successful
    changed = node.set_parameters([Parameter('frame_id', value='roof_enu'),
                                   Parameter('publish_period_s', value=600.0)])
    assert all(result.successful for result in changed)
    assert probe.spin_until(lambda: len(probe.sun) >= 3, 30.0)  # 1200 s of simulated time
    stamps_ns = np.array([epoch_ns(m.header.stamp) for m in probe.sun])
    assert stamps_ns[0] == START_NS and len(stamps_ns) >= 3
    assert np.all(np.diff(stamps_ns) == 600 * NS)
    assert {m.header.frame_id for m in probe.sun} == {'roof_enu'}


@pytest.mark.parametrize('argument, named', [
    ('latitude_deg:=95.0', 'latitude_deg'), ('mode:=sideways', 'mode')])
def test_executable_refuses_bad_parameters_without_a_traceback(argument, named):
    executable = Path(sys.executable).parent / 'sun_position_node'
    assert executable.exists(), 'run: .venv/bin/python -m pip install --no-deps -e .'
    result = subprocess.run([str(executable), '--ros-args', '-p', argument],
                            capture_output=True, text=True, timeout=30,
                            env={**os.environ, 'ROS_DOMAIN_ID': str(DOMAIN_ID)})
    output = result.stdout + result.stderr
    assert result.returncode == 2, output
    assert named in output and 'Traceback' not in output, output


def _panel_states_message(panel_ids):
    from sensor_msgs.msg import PointCloud2, PointField
    from flectofold_ros.wire import panel_states
    table = panel_states.new_table(len(panel_ids))
    table['row'], table['column'] = panel_states.id_numbers(panel_ids)
    return panel_states.fill_message(PointCloud2(), table, Time(sec=1), PointField)


def _clock_moved(probe):
    return any(clock_ns > START_NS for _, clock_ns in probe.clock)


def test_the_start_is_held_until_the_panels_report_and_the_sun_has_listeners(probe):
    """As under ros2 launch: the day starts when the graph is up (the probe listens to sun)."""
    node = probe.start(**SHORT_DAY, **{'start.wait_for_panels': 2,
                                       'start.wait_for_sun_listeners': 1})
    states = publisher(probe.node, contract.PANEL_STATES)
    assert probe.wait(lambda: states.get_subscription_count() >= 1, 30.0)  # the node's gate
    probe.spin_for(1.5)
    assert probe.clock and not _clock_moved(probe) and node.waiting_for_graph
    states.publish(_panel_states_message(['r00c00']))
    states.publish(_panel_states_message(['r00c00']))  # the same panel again counts once
    probe.spin_for(1.5)
    assert not _clock_moved(probe)
    states.publish(_panel_states_message(['r00c01']))
    assert probe.spin_until(lambda: _clock_moved(probe), 30.0)
    assert not node.waiting_for_graph
    assert probe.spin_until(lambda: any('the graph was ready' in log.msg for log in probe.logs),
                            30.0)


def test_a_graph_that_never_gets_ready_starts_the_day_after_the_timeout_with_a_warning(probe):
    created = time.monotonic()
    probe.start(**SHORT_DAY, **{'start.wait_for_panels': 3, 'start.timeout_s': 1.0})
    assert probe.spin_until(lambda: _clock_moved(probe), 30.0)
    # held for the timeout (on the steady clock, from the node's creation), then started
    assert min(received for received, clock_ns in probe.clock if clock_ns > START_NS) \
        >= created + 1.0
    assert probe.spin_until(lambda: any('without a ready graph' in log.msg and
                                        '0/3 panels' in log.msg for log in probe.logs), 30.0)
