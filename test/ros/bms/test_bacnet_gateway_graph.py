"""The BACnet gateway over DDS and BACnet/IP: a coordinator, a panel process, a BMS client.

The BMS side is bacpypes3's own client ``Application`` (nobody on the team wrote it), on the
loopback at a port of its own (two applications on one ip:port would share its traffic):
it finds the device by a Who-Is sent to the gateway's address (a /32 has no broadcast),
reads the objects, subscribes to COV, writes a priority-8 override and relinquishes it, and
sees the storm latch object go active when the coordinator's storm trips. The test drives
the simulated clock, the sun, DNI and wind as ``test_storm.py`` does, and measures in wall
time: BACnet write acknowledged -> first reported closure change of the panel; a panel
state on DDS -> the COV notification of its closure.
"""

from argparse import Namespace
import asyncio
import socket
import threading
import time

from bacpypes3.apdu import ErrorRejectAbortNack
from bacpypes3.app import Application
from bacpypes3.pdu import Address
from bacpypes3.primitivedata import Null, ObjectIdentifier
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from ros_graph import domain_for, Graph, START_S
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64

from flectofold_model.facade.description import build_facade
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
SUN_PATH = __import__('pathlib').Path(__file__).parents[2] / 'data' / \
    'sun_path_stuttgart_2026-06-21.csv'
#: DNI 0 W/m2 throughout: the automatic target is default_closure, closed.
CONTROL = ('period_s: 60.0, shading_target: 0.9, default_closure: 1.0, min_dwell_s: 10.0, '
           'storm_off_delay_s: 60.0')
INSTANCE = 4194302  # the highest device instance there is (4194303 is the wildcard)
NAME = 'flectofold facade, south elevation, gateway at the 64-char limit'
STEP_S = 0.2  # clock step [s of ROS time]
FOLLOW_S = 2.0  # the clock waits for panels whose last state is older than this
SAMPLE_S = 2.0  # wind sample interval
#: Wall seconds within which a BACnet answer comes; a bound against a hang only.
ANSWER_S = 20.0
OVERRIDE_PERCENT = 20.0
MOVED = 0.005  # a reported closure this far from the one before the write: moving
NEAR = 0.05  # a panel this close to its target has reached it


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def stamp(epoch_s):
    seconds = int(epoch_s)
    return Time(sec=seconds, nanosec=int(round((epoch_s - seconds) * 1e9)))


class BmsClient:
    """bacpypes3's client Application in an asyncio loop on a thread of its own."""

    def __init__(self, gateway_port):
        self.address = Address(f'127.0.0.1:{gateway_port}')
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.app = self.call(self._make(free_udp_port()))
        self.notifications = {}  # object id -> [(monotonic s, property, value)]
        self._watches = []

    async def _make(self, port):
        return Application.from_args(Namespace(
            name='bms-client', instance=4194000, address=f'127.0.0.1/32:{port}', network=0,
            vendoridentifier=999, foreign=None, ttl=30, bbmd=None))

    def call(self, coroutine, timeout_s=ANSWER_S):
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(timeout_s)

    def read(self, objid, prop):
        return self.call(self.app.read_property(self.address, objid, prop))

    def write(self, objid, value, priority=8):
        """Write present-value; return None (acknowledged) or the error code."""
        try:
            self.call(self.app.write_property(self.address, objid, 'present-value', value,
                                              priority=priority))
        except ErrorRejectAbortNack as error:
            return str(error.errorCode)
        return None

    def watch(self, objid, process_id):
        """Subscribe to COV of ``objid``; notifications go to :attr:`notifications`."""
        sink = self.notifications.setdefault(objid, [])
        subscribed = threading.Event()

        async def run():
            async with self.app.change_of_value(self.address, ObjectIdentifier(objid),
                                                process_id, True, 3600) as subscription:
                subscribed.set()
                while True:
                    prop, value = await subscription.get_value()
                    sink.append((time.monotonic(), str(prop), value))
        self._watches.append(asyncio.run_coroutine_threadsafe(run(), self.loop))
        assert subscribed.wait(ANSWER_S), objid
        return sink

    def close(self):
        for watch in self._watches:
            watch.cancel()
        time.sleep(0.2)
        self.loop.call_soon_threadsafe(self.app.close)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(10.0)


class Day:
    """The clock, sun, DNI and wind; records panel states with their arrival times."""

    def __init__(self, graph, panel_ids):
        node = graph.node
        self.graph, self.panel_ids = graph, panel_ids
        self.clock = publisher(node, contract.CLOCK)
        self.sun = publisher(node, contract.SUN)
        self.wind = publisher(node, contract.WIND_SPEED)
        self.dni = publisher(node, contract.DNI)
        self.states = []  # (monotonic s, stamp s, closure per panel)
        self.setpoints = []  # (stamp s, {panel: closure})
        self.gateway_status = {}
        lookup = panel_states.index_lookup(panel_ids)
        subscription(node, contract.PANEL_STATES, lambda m: self._on_states(m, lookup),
                     contract.OBSERVER)
        subscription(node, contract.FACADE_SETPOINTS, lambda m: self.setpoints.append(
            (panel_states.stamp_ns(m.header) * 1e-9, dict(zip(m.name, m.position)),
             time.monotonic())))
        subscription(node, contract.DIAGNOSTICS, self._on_diagnostics)
        self.now_s = None
        self.wind_m_s = None
        self.next_sample_s = None

    def _on_states(self, message, lookup):
        table = panel_states.unpack(message)
        closure = np.full(len(self.panel_ids), np.nan)
        index = panel_states.indices(table, lookup)
        closure[index[index >= 0]] = table['closure'][index >= 0]
        self.states.append((time.monotonic(), panel_states.stamp_ns(message.header) * 1e-9,
                            closure))

    def _on_diagnostics(self, message):
        for status in message.status:
            if status.name == '/facade/bacnet_gateway: bacnet':
                self.gateway_status = {kv.key: kv.value for kv in status.values}

    def closure(self, panel):
        """Return the last reported closure of panel number ``panel`` (NaN before any)."""
        for _, _, closure in reversed(self.states):
            if not np.isnan(closure[panel]):
                return float(closure[panel])
        return float('nan')

    def tick(self, epoch_s):
        self.now_s = epoch_s
        self.clock.publish(Clock(clock=stamp(epoch_s)))
        self.graph.spin_for(0.02)
        if self.wind_m_s is not None and epoch_s >= self.next_sample_s - 1e-9:
            self._sample()
        self.graph.spin_until(lambda: not self.states
                              or self.states[-1][1] >= self.now_s - FOLLOW_S, 10.0)

    def weather(self, wind_m_s):
        self.wind_m_s = wind_m_s
        self._sample()

    def _sample(self):
        self.wind.publish(Float64(data=self.wind_m_s))
        self.dni.publish(Float64(data=0.0))
        self.next_sample_s = self.now_s + SAMPLE_S

    def run(self, until_s, condition):
        while self.now_s < until_s - 1e-9 and not condition():
            self.tick(round(self.now_s + STEP_S, 6))
        return condition()


@pytest.fixture(scope='module')
def site(small_facade_text, tmp_path_factory):
    path = tmp_path_factory.mktemp('facade') / 'small.yaml'
    path.write_text(small_facade_text(CONTROL))
    facade = build_facade(path.read_text())
    port = free_udp_port()
    graph = Graph(domain_for(32))
    client = None
    try:
        panels = graph.start('panel_group', '--panels', ','.join(facade.panel_ids),
                             '--facade', str(path), '--ros-args', '-p', 'use_sim_time:=true',
                             '-p', 'setpoint_timeout_s:=60.0')
        coordinator = graph.start('coordinator_node', '--ros-args', '-p', 'use_sim_time:=true',
                                  '-p', f'facade_file:={path}')
        gateway = graph.start('bacnet_gateway', '--ros-args', '-p', f'facade_file:={path}',
                              '-p', f'address:=127.0.0.1/32:{port}',
                              '-p', f'device_instance:={INSTANCE}',
                              '-p', f'device_name:={NAME}')
        day = Day(graph, facade.panel_ids)
        epochs, vectors = (lambda data: (data[:, 0], data[:, 1:]))(
            np.loadtxt(SUN_PATH, delimiter=',', skiprows=2))
        noon = len(epochs) // 2
        ready = lambda: (day.sun.get_subscription_count() and day.states  # noqa: E731
                         and graph.node.count_publishers(contract.OVERRIDE.name)
                         and day.gateway_status)
        start_s = float(np.floor(epochs[noon]))
        for attempt in range(600):
            day.tick(start_s + 0.1 * attempt)
            if graph.spin_until(ready, 0.2):
                break
        assert ready(), [graph.stop(p)[1] for p in (panels, coordinator, gateway)]
        message = Vector3Stamped()
        message.header.stamp, message.header.frame_id = stamp(day.now_s), contract.SITE_FRAME
        message.vector.x, message.vector.y, message.vector.z = (float(c) for c in vectors[noon])
        for _ in range(50):
            day.sun.publish(message)
            day.tick(day.now_s)
            if graph.spin_until(lambda: day.setpoints, 0.2):
                break
        day.weather(3.0)
        closed = day.run(day.now_s + 90.0, lambda: day.states and np.all(
            day.states[-1][2] > 0.95))
        assert closed, day.states[-1:]
        client = BmsClient(port)
        yield day, client
        client.close()
        client = None
        codes = [graph.stop(p) for p in (gateway, coordinator, panels)]
    finally:
        if client is not None:
            client.close()
        graph.close()
    assert all(code == 0 for code, _ in codes), codes


def test_who_is_finds_the_gateway_and_its_objects_read_back(site):
    day, client = site

    async def who_is():  # bacpypes3's who_is returns a future: it must be called in the loop
        return await client.app.who_is(INSTANCE, INSTANCE, client.address)
    i_ams = client.call(who_is())
    assert [i.iAmDeviceIdentifier[1] for i in i_ams] == [INSTANCE]
    assert len(NAME) == 64 and str(client.read(f'device,{INSTANCE}', 'object-name')) == NAME
    objects = client.read(f'device,{INSTANCE}', 'object-list')
    assert len(objects) == 2 + 2 + 4 * len(day.panel_ids)
    assert str(client.read('analog-value,1', 'object-name')) == 'r00c00 closure command'
    assert str(client.read('binary-input,0', 'present-value')) == 'inactive'
    assert str(client.read('analog-input,1', 'reliability')) == 'no-fault-detected'
    assert client.read('analog-input,1', 'present-value') == pytest.approx(
        100.0 * day.closure(0), abs=2.0)
    assert client.read('analog-value,1', 'present-value') == pytest.approx(100.0)  # automatic
    assert client.read('analog-input,1001', 'present-value') > 100000.0  # absolute [Pa]


def test_a_write_at_priority_8_moves_the_panel_with_cov_notifications(site):
    day, client = site
    closure_cov = client.watch('analog-input,1', 11)
    before = day.closure(0)
    count, setpoints = len(day.states), len(day.setpoints)
    target = OVERRIDE_PERCENT / 100.0
    written_s, written_clock_s = time.monotonic(), day.now_s
    assert client.write('analog-value,1', OVERRIDE_PERCENT) is None
    acked_s = time.monotonic()
    # the coordinator commands the override through its rate limit: the first step toward it
    commanded = lambda: [arrived for _, closures, arrived  # noqa: E731
                         in day.setpoints[setpoints:] if closures['r00c00'] < 1.0]
    assert day.graph.spin_until(commanded, 20.0), day.setpoints[-1:]
    moving = lambda: [(arrived, clock) for arrived, clock, c  # noqa: E731
                      in day.states[count:] if before - c[0] > MOVED]
    assert day.run(day.now_s + 30.0, moving), day.states[-1:]
    moved_s, moved_clock_s = moving()[0]
    print(f'BACnet write acknowledged in {(acked_s - written_s) * 1e3:.1f} ms; the '
          f"coordinator's setpoint {(commanded()[0] - written_s) * 1e3:.0f} ms after the write; "
          f'first reported closure change {(moved_s - written_s) * 1e3:.0f} ms (wall) and '
          f'{moved_clock_s - written_clock_s:.1f} s of ROS time after the write')
    assert day.run(day.now_s + 120.0, lambda: abs(day.closure(0) - target) < NEAR), \
        day.closure(0)
    assert day.run(day.now_s + 60.0, lambda: day.setpoints[-1][1]['r00c00'] == target)
    assert all(abs(c[1] - 1.0) < NEAR for _, _, c in day.states[-3:])  # the others stay
    # COV: notifications of the closure as it moved, each after the state that carried it
    day.graph.spin_for(1.0)
    values = [(t, v) for t, prop, v in closure_cov if prop == 'present-value']
    assert len(values) >= 5 and values[-1][1] == pytest.approx(100.0 * day.closure(0), abs=1.5)
    latencies = []
    for notified_s, value in values[1:]:
        carried = [t for t, _, c in day.states if abs(100.0 * c[0] - value) < 1e-3]
        if carried and carried[0] <= notified_s:
            latencies.append(notified_s - carried[0])
    assert len(latencies) >= len(values) // 2, (values, len(day.states))
    print(f'COV: {len(values)} notifications of the closure, state -> notification '
          f'p50 {np.median(latencies) * 1e3:.1f} ms, max {max(latencies) * 1e3:.1f} ms')


def test_relinquishing_returns_the_panel_to_automatic(site):
    day, client = site
    assert client.write('analog-value,1', Null(())) is None
    assert day.graph.spin_until(lambda: day.setpoints[-1][1]['r00c00'] > 0.2 + 1e-6, 20.0) or \
        day.run(day.now_s + 10.0, lambda: day.setpoints[-1][1]['r00c00'] > 0.2 + 1e-6)
    assert day.run(day.now_s + 120.0, lambda: day.closure(0) > 1.0 - NEAR), day.closure(0)
    slots = client.read('analog-value,1', 'priority-array')
    assert [s.null for s in slots] == [()] * 16
    assert day.graph.spin_until(lambda: day.gateway_status['overrides_in_force'] == '0', 10.0)
    assert int(day.gateway_status['clears_sent']) == 1


def test_the_storm_latch_object_goes_active_and_a_write_is_refused(site):
    day, client = site
    storm_cov = client.watch('binary-input,0', 12)
    assert client.write('analog-value,2', 50.0) is None  # held, then ended by the storm
    tripped_s = None
    day.weather(15.0)
    active = lambda: any(p == 'present-value' and str(v) == 'active'  # noqa: E731
                         for _, p, v in storm_cov)
    started_s = time.monotonic()
    assert day.run(day.now_s + 40.0, active), (storm_cov, day.gateway_status)
    tripped_s = time.monotonic() - started_s
    print(f'storm latch object active {tripped_s:.1f} s (wall) after the first gust sample')
    assert str(client.read('binary-input,0', 'event-state')) == 'offnormal'
    assert client.write('analog-value,1', 50.0) == 'write-access-denied'
    assert [s.null for s in client.read('analog-value,2', 'priority-array')] == [()] * 16
    assert day.run(day.now_s + 60.0, lambda: all(
        abs(day.closure(p)) < NEAR for p in range(len(day.panel_ids))))
    day.graph.spin_for(1.5)
    assert int(day.gateway_status['refused_writeAccessDenied']) >= 1
    assert day.gateway_status['storm_latched'] == 'True'


@pytest.mark.parametrize('arguments, reason', [
    (['-p', 'address:=10.1.1.1/32:{port}'], 'binds 127.0.0.1 only'),
    (['-p', 'address:=127.0.0.1/32:{held}'], 'cannot be bound'),
    (['-p', 'device_instance:=4194303'], 'device_instance out of range'),
    (['-p', f'device_name:={NAME}x'], 'printable characters'),
])
def test_a_bad_address_or_device_stops_the_gateway_at_start_with_exit_2(arguments, reason):
    graph = Graph(domain_for(34))
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as holder:
            holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)  # as bacpypes3 binds
            holder.bind(('127.0.0.1', 0))
            held = holder.getsockname()[1]
            process = graph.start('bacnet_gateway', '--ros-args', *(
                a.format(port=free_udp_port(), held=held) for a in arguments))
            process.wait(START_S)  # it stops by itself; a hang fails here
            code, output = graph.stop(process)
    finally:
        graph.close()
    assert code == 2, output
    assert output.startswith('bacnet_gateway: ') and reason in output, output
    assert 'Traceback' not in output
