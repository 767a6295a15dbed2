"""The Rerun scene of a hexagonal facade: one batched mesh that matches the hexagon model."""

from builtin_interfaces.msg import Time
import numpy as np
import pytest
from rclpy.serialization import serialize_message
import rerun as rr
from rrd_reading import Rrd
from sensor_msgs.msg import PointCloud2, PointField

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.hexagon_mesh import DEFAULT_HEXAGON_TOPOLOGY, HexagonTopology
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_ros.recording import BagError, SegmentedBagWriter
from flectofold_ros.rerun.bag_to_rrd import convert
from flectofold_ros.rerun.scene import (facade_topology, FACADE_VERTEX_BUDGET, FacadeScene,
                                        feed)
from flectofold_ros.rerun.sinks import check_rrd_path, open_recording
from flectofold_ros.wire import contract, panel_states

T0_NS = 1782036000 * 10**9  # 2026-06-21 10:00 UTC
STEP_NS = 10**8


@pytest.fixture(scope='module')
def facade():
    return load_facade('hexagon_6x6')


def closures_at(step, count):
    return 0.5 + 0.45 * np.sin(step / 3.0 + np.arange(count) / 5.0)


def send(scene, closure, stamp_ns):
    feed(scene, contract.PANEL_STATES.name, state_message(scene, closure, stamp_ns))


def state_message(scene, closure, stamp_ns):
    count = len(scene)
    table = panel_states.new_table(count)
    table['x'], table['y'], table['z'] = scene.positions_enu.T
    table['closure'] = closure
    table['fold_angle_rad'] = scene.model.fold_angle_from_closure(closure)
    table['pressure_pa'] = ATMOSPHERIC_PRESSURE_PA + 8e3 * closure
    table['setpoint'] = closure
    table['row'], table['column'] = panel_states.id_numbers(scene.panel_ids)
    table['status'] = contract.STATUSES.index('tracking')
    stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    return panel_states.fill_message(PointCloud2(), table, stamp, PointField)


def world_mesh(scene, closure):
    """Vertices the hexagon model gives for ``closure``, exactly, in the site's ENU frame."""
    model = scene.model
    mesh = model.mesh(model.state_from_closure(closure).shape_parameter,
                      topology=scene.topology)
    facade = scene.facade
    origin = facade.origin_m @ facade.facade_to_enu.T
    return np.einsum('nij,nvj->nvi', facade.panel_to_enu, mesh.vertices) + origin[:, None, :]


def test_the_hexagonal_facade_is_one_mesh_whose_vertices_match_the_model(tmp_path, facade):
    path = tmp_path / 'hexagon.rrd'
    recording = open_recording('test', None, check_rrd_path(path), strict=True)
    scene = FacadeScene(facade, recording, min_change_rad=0.0)
    scene.log_static()
    for step in range(3):
        send(scene, closures_at(step, len(facade)), T0_NS + step * STEP_NS)
        scene.flush()
    recording.flush()
    recording.disconnect()
    rrd = Rrd(path)
    assert rrd.panel_ids() == facade.panel_ids
    assert rrd.vertices_per_panel() == scene.topology.vertex_count == 9 * 12 + 7
    meshes = rrd.meshes()
    assert [t for t, _ in meshes] == [T0_NS + step * STEP_NS for step in range(3)]
    for step, (_, vertices) in enumerate(meshes):
        # The scene interpolates the rise in the model's table: within a micrometre.
        np.testing.assert_allclose(vertices, world_mesh(scene, closures_at(step, len(facade))),
                                   atol=2e-5)
    faces = np.array(rrd.static('/facade/panels', 'Mesh3D:triangle_indices'))
    assert faces.shape == (len(facade) * len(scene.topology.faces), 3)
    surface = np.array(rrd.static('/facade/surface', 'Mesh3D:vertex_positions'))
    assert surface.shape == (6 * len(facade), 3)
    # Each patch is the panel's flat hexagon 5 cm behind it: corners R from the origin.
    corners = surface.reshape(len(facade), 6, 3) - scene.positions_enu[:, None, :]
    radius = np.array([panel.circumradius_m for panel in facade.panels])[:, None]
    np.testing.assert_allclose(np.linalg.norm(corners, axis=-1),
                               np.broadcast_to(np.hypot(radius, 0.05), (len(facade), 6)),
                               rtol=1e-5)


def test_the_facade_resolution_is_the_fine_mesh_on_fewer_rings_and_columns(facade):
    small, large = facade_topology(30, kind='hexagon'), facade_topology(1000, kind='hexagon')
    assert (small.rulings_per_sector, small.rings, small.flap_columns) == (12, 1, 2)
    assert 1000 * large.vertex_count <= FACADE_VERTEX_BUDGET and large.rulings_per_sector >= 2
    fine_topology = DEFAULT_HEXAGON_TOPOLOGY
    assert isinstance(small, HexagonTopology) and fine_topology.rulings_per_sector == 12
    model = fold_model_of(facade.panels[:3])
    rise = model.state_from_closure(0.7).shape_parameter
    fine, coarse = model.mesh(rise, fine_topology), model.mesh(rise, small)
    rings = fine_topology.rings
    np.testing.assert_allclose(coarse.vertices[:, 1:1 + 36],
                               fine.vertices[:, 1:1 + 36 * rings][:, rings - 1::rings],
                               atol=1e-12)
    for index in range(3):
        mine = coarse.vertices[:, small.flap(index)].reshape(3, 13, 2, 3)
        outer = fine.vertices[:, fine_topology.flap(index)].reshape(3, 13, -1, 3)
        np.testing.assert_allclose(mine, outer[:, :, [0, -1]], atol=1e-12)


def test_a_hexagonal_bag_converted_with_the_quad_facade_is_refused(tmp_path, facade):
    recording = rr.RecordingStream('test', recording_id='bag')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)  # for its tables
    with SegmentedBagWriter(tmp_path / 'bag') as writer:
        writer.add_topic(contract.PANEL_STATES.name, contract.PANEL_STATES.msgtype)
        for step in range(3):
            t_ns = T0_NS + step * STEP_NS
            message = state_message(scene, np.full(len(scene), 0.5), t_ns)
            writer.write(contract.PANEL_STATES.name, t_ns, serialize_message(message))
    counts = convert(tmp_path / 'bag', tmp_path / 'right.rrd', facade)
    assert counts.misplaced == 0 and counts.states_taken == 3 * len(facade)
    # The quad demonstrator has panels of the same ids, elsewhere.
    with pytest.raises(BagError, match='not where facade .* puts their panels'):
        convert(tmp_path / 'bag', tmp_path / 'wrong.rrd', load_facade(DEFAULT_FACADE))
    assert not (tmp_path / 'wrong.rrd').exists()
