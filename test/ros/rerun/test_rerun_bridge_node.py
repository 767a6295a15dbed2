"""The rerun_bridge as a process: panel_states published on a graph end up in its .rrd."""

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
import rerun as rr
from ros_graph import domain_for, Graph
from rrd_reading import Rrd
from sensor_msgs.msg import PointCloud2, PointField

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade.description import DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.mesh import fold_mesh
from flectofold_ros.rerun.scene import FacadeScene
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph
T0_NS = 1782036000 * 10**9
STEP_NS = 10**8


def closures_at(step, count):
    return 0.5 + 0.45 * np.sin(step / 2.0 + np.arange(count) / 5.0)


def cloud(scene, closure, panels, stamp_ns):
    table = panel_states.new_table(len(panels))
    table['x'], table['y'], table['z'] = scene.positions_enu[panels].T
    table['closure'] = closure[panels]
    table['fold_angle_rad'] = scene.model.fold_angle_from_closure(closure)[panels]
    table['pressure_pa'] = ATMOSPHERIC_PRESSURE_PA + 8e3 * closure[panels]
    table['setpoint'] = closure[panels]
    table['row'], table['column'] = panel_states.id_numbers([scene.panel_ids[i]
                                                             for i in panels])
    table['status'] = contract.STATUSES.index('tracking')
    stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    return panel_states.fill_message(PointCloud2(), table, stamp, PointField)


def test_the_bridge_logs_published_panel_states(tmp_path):
    facade = load_facade(DEFAULT_FACADE)
    recording = rr.RecordingStream('test', recording_id='tables')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)  # for its model, positions and topology
    count, rrd_path = len(facade), tmp_path / 'bridge.rrd'
    graph = Graph(domain_for(25), name='bridge_probe')
    try:
        bridge = graph.start('rerun_bridge', '--ros-args', '-p', 'viewer:=none',
                             '-p', f'rrd_path:={rrd_path}', '-p', 'strict:=true',
                             '-p', 'flush_period_s:=0.05')
        states = publisher(graph.node, contract.PANEL_STATES)
        sun = publisher(graph.node, contract.SUN)
        figures = {}  # the bridge's latest /diagnostics figures

        def on_diagnostics(message):
            for status in message.status:
                if status.hardware_id == contract.RERUN_BRIDGE_NODE:
                    figures.update((item.key, int(float(item.value))) for item in status.values
                                   if item.key in ('states_taken', 'rejected'))
        subscription(graph.node, contract.DIAGNOSTICS, on_diagnostics)
        assert graph.spin_until(lambda: states.get_subscription_count() >= 1
                                and sun.get_subscription_count() >= 1, 60.0), \
            'the bridge never subscribed'
        graph.spin_for(0.5)
        halves = np.array_split(np.arange(count), 2)  # two panel processes
        for step in range(3):
            stamp_ns = T0_NS + step * STEP_NS
            for panels in (halves[step % 2], halves[1 - step % 2]):  # either comes first
                states.publish(cloud(scene, closures_at(step, count), panels, stamp_ns))
            vector = Vector3Stamped()
            vector.header.stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
            vector.vector.y, vector.vector.z = -0.6, 0.8
            sun.publish(vector)
            graph.spin_for(0.3)
        foreign = PointCloud2(height=1, width=1, point_step=4, row_step=4, data=bytes(4),
                              fields=[PointField(name='x', offset=0, datatype=7, count=1)])
        states.publish(foreign)
        # the bridge took every state and refused the foreign cloud
        assert graph.spin_until(lambda: figures.get('states_taken', 0) >= 3 * count and
                                figures.get('rejected', 0) >= 1, 30.0), figures
        code, output = graph.stop(bridge)
    finally:
        graph.close()
    assert code == 0, output
    assert '1 rejected' in output, output
    rrd = Rrd(rrd_path)
    names, stamps, closure = rrd.series_table('closure')
    assert names == facade.panel_ids
    # A flush that falls between a step's two halves logs that stamp twice, the second row
    # complete; Rerun shows the last row logged at a time, so compare those.
    last = np.append(stamps[1:] != stamps[:-1], True)
    stamps, closure = stamps[last], closure[last]
    assert stamps.tolist() == [T0_NS + step * STEP_NS for step in range(3)]
    np.testing.assert_allclose(closure, [closures_at(step, count) for step in range(3)],
                               rtol=1e-6)
    meshes = rrd.meshes()
    assert meshes and meshes[-1][0] == T0_NS + 2 * STEP_NS
    model = scene.model
    mesh = fold_mesh(model.batch, model.state_from_closure(closures_at(2, count)).elastica_k,
                     topology=scene.topology)
    expected = (np.einsum('nij,nvj->nvi', facade.panel_to_enu, mesh.vertices)
                + scene.positions_enu[:, None, :])
    np.testing.assert_allclose(meshes[-1][1], expected, atol=1e-5)
    assert len(rrd.rows('/sun', 'Arrows3D:vectors')) >= 1
