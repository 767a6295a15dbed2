"""The sun falls silent under a real coordinator and panel process, then comes back.

Documented (``coordinator_node.md``): a sun vector older than ``sun_timeout_s`` is not used;
the coordinator holds its last commands, its heartbeat keeps the panels' watchdogs fed, and
``/diagnostics`` says WARN ``sun vector stale``. The panels keep tracking what they tracked.
"""

from pathlib import Path

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from ros_graph import domain_for, Graph, on_facade_setpoints
from rosgraph_msgs.msg import Clock

from flectofold_model.facade.description import build_facade
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract

SUN_PATH = Path(__file__).parents[2] / 'data' / 'sun_path_stuttgart_2026-06-21.csv'
CONTROL = 'period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0'
SUN_TIMEOUT_S = 120.0
pytestmark = pytest.mark.graph


def stamp(epoch_s):
    seconds = int(epoch_s)
    return Time(sec=seconds, nanosec=int(round((epoch_s - seconds) * 1e9)))


class Day:
    """The test's clock and sun; what the coordinator and the panels say."""

    def __init__(self, graph, panel_ids):
        self.graph, self.now_s = graph, None
        self.clock = publisher(graph.node, contract.CLOCK)
        self.sun = publisher(graph.node, contract.SUN)
        self.setpoints = {p: [] for p in panel_ids}
        self.status = {p: [] for p in panel_ids}
        self.coordinator = []
        on_facade_setpoints(graph.node, lambda p, closure: self.setpoints[p].append(
            (self.now_s, closure)))
        for p in panel_ids:
            subscription(graph.node, contract.STATUS.of(p),
                         lambda m, p=p: self.status[p].append((self.now_s, m.data)))
        subscription(graph.node, contract.DIAGNOSTICS, self._on_diagnostics)

    def _on_diagnostics(self, message):
        # Its own stamp: the coordinator's ROS clock when it judged the sun (it may arrive here
        # many test clock steps later on a loaded machine).
        at_s = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        self.coordinator += [(at_s, ord(s.level), s.message) for s in message.status
                             if s.name.startswith('/facade/coordinator')]

    def run(self, until_s, sun=None):
        """Step the clock by 1 s to ``until_s``; publish ``sun(epoch)`` on every minute."""
        while self.now_s < until_s:
            self.now_s += 1.0
            self.clock.publish(Clock(clock=stamp(self.now_s)))
            if sun is not None and self.now_s % 60.0 == 0.0:
                message = Vector3Stamped()
                message.header.stamp = stamp(self.now_s)
                message.header.frame_id = contract.SITE_FRAME
                x, y, z = sun(self.now_s)
                message.vector.x, message.vector.y, message.vector.z = x, y, z
                self.sun.publish(message)
            self.graph.spin_for(0.02)


@pytest.fixture()
def small_facade(small_facade_text, tmp_path):
    path = tmp_path / 'small.yaml'
    path.write_text(small_facade_text(CONTROL))
    return path, build_facade(path.read_text())


def test_a_silent_sun_holds_the_commands_and_is_reported_then_recovers(small_facade):
    path, facade = small_facade
    data = np.loadtxt(SUN_PATH, delimiter=',', skiprows=2)
    epochs, vectors = data[:, 0], data[:, 1:]

    def sun(epoch_s):
        return [float(np.interp(epoch_s, epochs, vectors[:, k])) for k in range(3)]

    graph = Graph(domain_for(54))
    try:
        panels = graph.start('panel_group', '--panels', ','.join(facade.panel_ids),
                             '--facade', str(path), '--ros-args', '-p', 'use_sim_time:=true',
                             '-p', 'setpoint_timeout_s:=60.0')
        coordinator = graph.start('coordinator_node', '--ros-args', '-p', 'use_sim_time:=true',
                                  '-p', f'facade_file:={path}', '-p', 'setpoint_period_s:=10.0',
                                  '-p', f'sun_timeout_s:={SUN_TIMEOUT_S}')
        day = Day(graph, facade.panel_ids)
        day.now_s = float(np.ceil(epochs[0] / 60.0) * 60.0) - 30.0
        setpoint = contract.FACADE_SETPOINTS.name
        assert graph.spin_until(lambda: graph.node.count_publishers(setpoint) and
                                all(day.status.values()), 60.0), 'graph not up'
        day.run(day.now_s + 240.0, sun)  # four minutes of sun
        assert all(values for values in day.setpoints.values()), 'no setpoints'
        silent_from_s = day.now_s
        held = {p: values[-1][1] for p, values in day.setpoints.items()}
        day.run(silent_from_s + 360.0)  # six minutes without a sun vector
        during = {p: [value for t, value in values if t > silent_from_s + SUN_TIMEOUT_S]
                  for p, values in day.setpoints.items()}
        for p, values in during.items():
            assert len(values) >= 10 and set(values) == {held[p]}, (p, values)  # heartbeat
            assert day.status[p][-1][1] == 'tracking', day.status[p]
        stale = [m for t, level, m in day.coordinator
                 if t > silent_from_s + SUN_TIMEOUT_S + 2.0]
        assert stale and all('sun vector stale' in m for m in stale), stale
        assert all(level == 1 for t, level, _ in day.coordinator
                   if t > silent_from_s + SUN_TIMEOUT_S + 2.0)
        back_s = day.now_s
        day.run(back_s + 180.0, sun)
        after = [(level, m) for t, level, m in day.coordinator if t > back_s + 62.0]
        assert after and all(level == 0 for level, _ in after), after
        assert panels.poll() is None and coordinator.poll() is None
    finally:
        graph.close()
