"""bag_recorder, rerun_bridge and replay on a real graph: counts, signals, equivalence, errors."""

import signal

import numpy as np
import pytest
from ros_graph import domain_for, Graph
from rosbags.rosbag2 import Reader
from rrd_reading import latest_at, Rrd
from sensor_msgs.msg import FluidPressure
from std_msgs.msg import Float64, String

from flectofold_model.facade.description import build_facade
from flectofold_ros.recording import bag_topics, read_messages
from flectofold_ros.rerun.bag_to_rrd import convert, decode
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph
#: The test's own topics (not the facade's), recorded by a recorder told to record /test/**.
CMD = contract.Topic('/test/cmd', 'std_msgs/msg/Float64')
PRESSURE = contract.Topic('/test/pressure', 'sensor_msgs/msg/FluidPressure')
STATE = contract.Topic('/test/state', 'std_msgs/msg/String', contract.LATCHED)


@pytest.fixture
def graph():
    graph = Graph(domain_for(11), name='recording_probe')
    yield graph
    graph.close()


def finish(process, timeout_s=60.0):
    """Wait for a process that ends by itself; return its exit code and output."""
    output, _ = process.communicate(timeout=timeout_s)
    return process.returncode, output


def bag_counts(path):
    with Reader(path) as reader:
        counts = {}
        for connection in reader.connections:
            counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        return counts, qos


def start_recorder(graph, output, *parameters):
    process = graph.start('bag_recorder', '--ros-args', '-p', f'output:={output}',
                          '-p', 'topics:=[/test/**]', *parameters)
    assert graph.spin_until(lambda: 'bag_recorder' in graph.node.get_node_names(), 30.0), \
        'the recorder never came up'
    return process


def publish_known_numbers(graph):
    node = graph.node
    numbers = publisher(node, CMD)
    pressure = publisher(node, PRESSURE)
    state = publisher(node, STATE)
    state.publish(String(data='ready'))
    assert graph.spin_until(lambda: numbers.get_subscription_count() >= 1 and
                            pressure.get_subscription_count() >= 1 and
                            state.get_subscription_count() >= 1, 30.0)
    graph.spin_for(0.5)
    for k in range(300):
        numbers.publish(Float64(data=float(k)))
        if k % 3 == 0:
            pressure.publish(FluidPressure(fluid_pressure=101325.0 + k))
        graph.spin_for(0.002)
    graph.spin_for(1.0)
    return {CMD.name: 300, PRESSURE.name: 100, STATE.name: 1}


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_the_bag_holds_what_was_published_and_survives_the_signal(graph, tmp_path, sig):
    start = start_recorder(graph, tmp_path / 'bag')
    reports = []
    subscription(graph.node, contract.DIAGNOSTICS, lambda m: reports.extend(
        s for s in m.status if s.hardware_id == contract.RECORDER_NODE))
    # The recorder discovers /test/pressure and /test/state when they appear.
    published = publish_known_numbers(graph)
    assert graph.spin_until(lambda: reports and reports[-1].message == '401 written', 10.0)
    figures = {item.key: item.value for item in reports[-1].values}
    assert (figures['dropped_queue'], figures['lost_in_transport']) == ('0', '0')
    code, output = graph.stop(start, sig=sig, timeout_s=30.0)
    assert code == 0, output
    counts, qos = bag_counts(tmp_path / 'bag')
    assert counts == published, output
    assert qos[STATE.name][0].durability.name == 'TRANSIENT_LOCAL'
    values = [decode(raw, 'std_msgs/msg/Float64').data
              for topic, _, _, raw in read_messages(tmp_path / 'bag', [CMD.name])]
    assert values == [float(k) for k in range(300)]
    assert 'dropped: 0 by the recorder, 0 lost in transport' in output


def test_a_hard_kill_keeps_the_closed_segments(graph, tmp_path):
    start = start_recorder(graph, tmp_path / 'bag', '-p', 'max_segment_mb:=0.002')
    publish_known_numbers(graph)
    graph.spin_for(1.0)
    start.kill()
    start.wait()
    counts, _ = bag_counts(tmp_path / 'bag')
    assert 0 < counts[CMD.name] < 300  # segments of ~2 kB were closed; the open one is lost
    assert len(list((tmp_path / 'bag').glob('*.mcap'))) >= 3


@pytest.mark.parametrize('output, message', [
    ('/proc/flectofold_bag', 'not writable'),
    ('{tmp}', 'exists already'),
    ('{tmp}/missing/bag', 'parent directory'),
])
def test_bad_outputs_are_refused_clearly(graph, tmp_path, output, message):
    process = graph.start('bag_recorder', '--ros-args', '-p',
                          f'output:={output.format(tmp=tmp_path)}')
    code, text = finish(process)
    assert code == 2 and message in text, text


def test_a_bad_topic_pattern_is_refused(graph, tmp_path):
    process = graph.start('bag_recorder', '--ros-args', '-p', f'output:={tmp_path}/bag',
                          '-p', 'topics:=[facade]')
    code, output = finish(process)
    assert code == 2 and 'must be an absolute topic name' in output, output


# -- the facade day: bridge and recorder together, then the bag replayed ----------------------

@pytest.fixture(scope='module')
def recorded_day(tmp_path_factory, small_facade_text):
    directory = tmp_path_factory.mktemp('day')
    facade_path = directory / 'small.yaml'
    facade_path.write_text(small_facade_text(
        'period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0'))
    graph = Graph(domain_for(13), name='day_probe')
    graph.env['RERUN_STRICT'] = '1'  # a logging error in the bridge raises
    try:
        process = graph.start('facade', '--facade', str(facade_path), '--start', '12:00',
                              '--end', '13:00', '--panel-processes', '1', '--record',
                              '--rerun', 'none', '--out', str(directory / 'out'))
        code, output = finish(process, timeout_s=240.0)
    finally:
        graph.close()
    assert code == 0, output
    run = (directory / 'out' / 'latest').resolve()
    return build_facade(facade_path.read_text()), run, output


def test_the_bringup_says_where_its_outputs_are(recorded_day):
    _, run, output = recorded_day
    assert f'bag (rosbag2, MCAP): {run / "bag"}' in output
    assert f'Rerun recording: {run / "facade.rrd"}' in output
    assert 'dropped: 0 by the recorder, 0 lost in transport' in output


def test_the_live_rrd_shows_every_panel_as_the_model_folds_it(recorded_day):
    facade, run, _ = recorded_day
    rrd = Rrd(run / 'facade.rrd')
    assert rrd.panel_ids() == list(facade.panel_ids)
    import rerun as rr

    from flectofold_ros.rerun.scene import FacadeScene
    recording = rr.RecordingStream('check', recording_id='check')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)
    model = scene.model
    origins = facade.origin_m @ facade.facade_to_enu.T
    from flectofold_model.kinematics.mesh import fold_mesh
    for i, panel_id in enumerate(facade.panel_ids):
        angles = dict(rrd.series('fold_angle_rad', panel_id))
        rows = rrd.vertices(panel_id)
        assert len(rows) >= 2, panel_id  # it moved during the hour
        for time_ns, vertices in rows:
            # the facade mesh is logged at a state's stamp; a panel that moved less than
            # min_change_rad (1 mrad) since its last mesh keeps it: under a millimetre here
            closure = model.closure_from_fold_angle(np.full(len(facade), angles[time_ns]))
            local = fold_mesh(model.batch, model.state_from_closure(closure).elastica_k,
                              topology=scene.topology).vertices[i]
            world = local @ facade.panel_to_enu[i].T + origins[i]
            np.testing.assert_allclose(vertices, world, atol=2e-3)


def test_a_replayed_bag_gives_the_live_rrd(recorded_day, tmp_path):
    facade, run, _ = recorded_day
    counts = convert(run / 'bag', tmp_path / 'replayed.rrd', facade, strict=True)
    assert counts.rejected == 0
    live, replayed = Rrd(run / 'facade.rrd'), Rrd(tmp_path / 'replayed.rrd')
    assert live.entities() == replayed.entities()
    for panel_id in facade.panel_ids:
        for name in ('pressure_gauge_pa', 'fold_angle_rad'):
            assert replayed.series(name, panel_id) == live.series(name, panel_id)
        live_rows, replayed_rows = live.vertices(panel_id), replayed.vertices(panel_id)
        # The live bridge merges states that arrive between two flushes, and each side skips
        # states within min_change_rad (1 mrad, under a millimetre here) of the mesh it last
        # logged: compare what was on screen at every live mesh and at the end.
        for time_ns, vertices in live_rows + [(live_rows[-1][0] + 10**12, live_rows[-1][1])]:
            np.testing.assert_allclose(latest_at(replayed_rows, time_ns), vertices, atol=2e-3)


def test_replay_plays_the_bag_onto_the_graph(recorded_day, graph):
    _, run, _ = recorded_day
    received = []
    states = contract.PANEL_STATES
    subscription(graph.node, states, lambda m: received.append(bytes(m.data)), contract.REPLAY)
    expected = [bytes(decode(raw, states.msgtype).data)
                for *_, raw in read_messages(run / 'bag', [states.name])]
    assert expected
    process = graph.start('replay', str(run / 'bag'), '--rate', '1000',
                          '--topics', states.name, contract.CLOCK.name)
    graph.spin_until(lambda: process.poll() is not None, 60.0)
    graph.spin_until(lambda: len(received) >= len(expected), 30.0)
    code, output = graph.stop(process)
    assert code == 0, output
    assert received == expected


def test_the_default_recording_holds_the_facade_state_not_the_panel_topics(recorded_day):
    _, run, _ = recorded_day
    topics = set(bag_topics(run / 'bag'))
    assert {contract.PANEL_STATES.name, contract.FACADE_JOINT_STATES.name,
            contract.SUN.name, contract.DIAGNOSTICS.name, contract.CLOCK.name} <= topics
    assert not any(contract.PANEL_ID.search(topic) for topic in topics)


@pytest.mark.parametrize('arguments, message', [
    (['--topics', '/no/such'], 'has no topic /no/such'),
    (['--to-rrd', '{tmp}/x.rrd', '--topics', '/no/such'], 'has no topic /no/such'),
    (['--to-rrd', '/proc/x.rrd'], 'cannot be written'),
    (['--to-rrd', '{tmp}/missing/x.rrd'], 'does not exist'),
    (['--rate', 'nan'], '--rate must lie'),
])
def test_replay_refuses_bad_requests_clearly(recorded_day, graph, tmp_path, arguments, message):
    _, run, _ = recorded_day
    process = graph.start('replay', str(run / 'bag'),
                          *[a.format(tmp=tmp_path) for a in arguments])
    code, output = finish(process)
    assert code == 2 and message in output, output


def test_replay_of_a_missing_bag(graph, tmp_path):
    process = graph.start('replay', str(tmp_path / 'nothing'), '--to-rrd',
                          str(tmp_path / 'a.rrd'))
    code, output = finish(process)
    assert code == 2 and 'does not exist' in output, output


def test_the_bridge_refuses_an_unwritable_rrd(graph):
    process = graph.start('rerun_bridge', '--ros-args', '-p', 'rrd_path:=/proc/x.rrd',
                          '-p', 'viewer:=none')
    code, output = finish(process)
    assert code == 2 and 'cannot be written' in output, output
