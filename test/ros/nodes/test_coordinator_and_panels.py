"""Coordinator and panels as separate processes over DDS, driven by a recorded sun path."""

from pathlib import Path
import signal

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from ros_graph import domain_for, Graph, on_facade_setpoints, START_S
from rosgraph_msgs.msg import Clock

from flectofold_model.facade.description import build_facade
from flectofold_model.scheduling.facade_schedule import FacadeSchedule
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract

SUN_PATH = Path(__file__).parents[2] / 'data' / 'sun_path_stuttgart_2026-06-21.csv'
CONTROL = 'period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0'
pytestmark = pytest.mark.graph
LEAD_S = 5.0  # each sun vector is published this long before its minute
FOLLOW_S = 2.0  # the clock waits for panels whose last state is older than this
FOLLOW_TIMEOUT_S = 10.0  # ... for at most this long of wall time per tick


def seconds(time):
    return time.sec + time.nanosec * 1e-9


def stamp(epoch_s):
    seconds = int(epoch_s)
    return Time(sec=seconds, nanosec=int(round((epoch_s - seconds) * 1e9)))


class SimulatedDay:
    """Publishes /clock and the recorded sun; records what the panels and coordinator say."""

    def __init__(self, graph, panel_ids):
        node = graph.node
        self.graph = graph
        self.clock = publisher(node, contract.CLOCK)
        self.sun = publisher(node, contract.SUN)
        self.setpoints = {p: [] for p in panel_ids}
        self.closure = {p: [] for p in panel_ids}
        self.status = {p: [] for p in panel_ids}
        self.state_s = dict.fromkeys(panel_ids)
        for p in panel_ids:
            subscription(node, contract.PRESSURE.of(p),
                         lambda m, p=p: self.state_s.update({p: seconds(m.header.stamp)}))
            subscription(node, contract.CLOSURE.of(p),
                         lambda m, p=p: self.closure[p].append(m.data))
            subscription(node, contract.STATUS.of(p),
                         lambda m, p=p: self.status[p].append(m.data))
        on_facade_setpoints(node, lambda p, closure: self.setpoints[p].append(closure))
        self.now_s = None

    def tick(self, epoch_s, wall_s=0.01):
        """Advance the clock, then let the panels catch up with it.

        A loaded machine runs them slower than the clock: a test of control must not become
        a test of CPU speed.
        """
        self.now_s = epoch_s
        self.clock.publish(Clock(clock=stamp(epoch_s)))
        self.graph.spin_for(wall_s)
        self.graph.spin_until(self._panels_follow, FOLLOW_TIMEOUT_S)

    def _panels_follow(self):
        times = self.state_s.values()
        return None in times or min(times) >= self.now_s - FOLLOW_S

    def publish_sun(self, epoch_s, vector):
        message = Vector3Stamped()
        message.header.stamp, message.header.frame_id = stamp(epoch_s), contract.SITE_FRAME
        message.vector.x, message.vector.y, message.vector.z = (float(c) for c in vector)
        self.sun.publish(message)

    def run(self, until_s, step_s, wall_s=0.01, condition=lambda: False):
        while self.now_s < until_s and not condition():
            self.tick(self.now_s + step_s, wall_s)
        return condition()


@pytest.fixture(scope='module')
def recorded_sun():
    data = np.loadtxt(SUN_PATH, delimiter=',', skiprows=2)
    return data[:, 0], data[:, 1:]


@pytest.fixture(scope='module')
def small_facade(small_facade_text, tmp_path_factory):
    path = tmp_path_factory.mktemp('facade') / 'small.yaml'
    path.write_text(small_facade_text(CONTROL))
    return path, build_facade(path.read_text())


@pytest.fixture(scope='module')
def day(small_facade, recorded_sun):
    path, facade = small_facade
    graph = Graph(domain_for(2))
    try:
        panels = graph.start('panel_group', '--panels', ','.join(facade.panel_ids),
                             '--facade', str(path), '--ros-args', '-p', 'use_sim_time:=true',
                             '-p', 'setpoint_timeout_s:=60.0')
        coordinator = graph.start('coordinator_node', '--ros-args', '-p', 'use_sim_time:=true',
                                  '-p', f'facade_file:={path}', '-p', 'setpoint_period_s:=10.0')
        simulated = SimulatedDay(graph, facade.panel_ids)
        epochs, vectors = recorded_sun
        start = epochs[0] - 2 * LEAD_S
        simulated.tick(start)
        assert graph.spin_until(lambda: all(simulated.status.values()), START_S), \
            [graph.stop(p)[1] for p in (panels, coordinator)]
        assert graph.spin_until(lambda: coordinator.poll() is not None
                                or graph.node.count_publishers(contract.FACADE_SETPOINTS.name),
                                START_S), [graph.stop(p)[1] for p in (panels, coordinator)]
        assert coordinator.poll() is None, graph.stop(coordinator)[1]
        for epoch, vector in zip(epochs, vectors):
            simulated.run(epoch - LEAD_S, 1.0)
            simulated.publish_sun(epoch, vector)
            graph.spin_for(0.05)
            simulated.run(epoch, 1.0)
        commanded = {p: values[-1] for p, values in simulated.setpoints.items()}
        # Run the clock on until the panels have reached the last commands (or 10 min have passed).
        simulated.run(epochs[-1] + 600.0, 1.0, wall_s=0.05, condition=lambda: all(
            simulated.closure[p] and abs(simulated.closure[p][-1] - commanded[p]) < 0.02
            for p in facade.panel_ids))
        yield graph, simulated, panels, coordinator, commanded
    finally:
        graph.close()


def offline_schedule(facade, epochs, vectors):
    """Decide as the coordinator does, with the pure model: first sun, then each minute."""
    schedule = FacadeSchedule(facade, start_s=epochs[0] - LEAD_S)
    schedule.step(epochs[0] - LEAD_S, vectors[0])
    for epoch, vector in zip(epochs, vectors):
        result = schedule.step(epoch, vector)
    return result.closure


def test_the_coordinator_commands_what_the_model_schedules(day, small_facade, recorded_sun):
    graph, simulated, panels, coordinator, commanded = day
    expected = offline_schedule(small_facade[1], *recorded_sun)
    got = np.array([commanded[p] for p in small_facade[1].panel_ids])
    np.testing.assert_allclose(got, expected, atol=1e-9)
    moves = [len(set(np.round(values, 6))) for values in simulated.setpoints.values()]
    # The sun path really drives the schedule: a panel leaves the default closure. (The target
    # rule stepped a panel through 0.1 closures, 5 setpoints here; the predictive controller,
    # the default, prices each move and makes one full stroke, 1 -> 0, in these 35 minutes.)
    assert max(moves) >= 2, moves


def test_the_panels_follow_the_coordinator(day, small_facade):
    graph, simulated, panels, coordinator, commanded = day
    for panel_id in small_facade[1].panel_ids:
        assert simulated.status[panel_id][-1] == 'tracking'
        assert simulated.closure[panel_id][-1] == pytest.approx(commanded[panel_id], abs=0.03)


def test_killing_the_coordinator_vents_the_panels(day, small_facade):
    graph, simulated, panels, coordinator, commanded = day
    assert max(commanded.values()) > 0.1
    code, _ = graph.stop(coordinator, sig=signal.SIGKILL)
    assert code == -signal.SIGKILL
    ids = small_facade[1].panel_ids
    vented = lambda: all(simulated.status[p][-1] == 'setpoint_timeout'  # noqa: E731
                         and simulated.closure[p][-1] < 0.02 for p in ids)
    assert simulated.run(simulated.now_s + 900.0, 1.0, wall_s=0.03, condition=vented), \
        {p: (simulated.status[p][-1], simulated.closure[p][-1]) for p in ids}
    code, output = graph.stop(panels)
    assert code == 0, output
