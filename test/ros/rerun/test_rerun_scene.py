"""The Rerun scene: what an .rrd written by it holds, read back with the SDK's reader.

The scene is fed ``/facade/panel_states`` messages as the bridge gets them (``PointCloud2``
built with :func:`panel_states.fill_message`), usually from two panel processes, each with its
half of the demonstrator's panels.
"""

from pathlib import Path
import socket

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from rclpy.serialization import serialize_message
import rerun as rr
from rrd_reading import latest_at, Rrd
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Float64

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade.description import build_facade, DEFAULT_FACADE, load_facade
from flectofold_model.facade.folded_mesh import FacadeMesher, folded_meshes
from flectofold_model.kinematics import elastica
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.mesh import DEFAULT_TOPOLOGY, fold_mesh
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_ros.recording import BagError, SegmentedBagWriter
from flectofold_ros.rerun.bag_to_rrd import convert
from flectofold_ros.rerun.scene import (CLOSURE_BAND, facade_topology, FACADE_VERTEX_BUDGET,
                                        FacadeScene, FAULT_RGBA, feed, k_from_sag,
                                        NO_STATE_RGBA, packed, ramp_colour, ramp_colours,
                                        scene_topics)
from flectofold_ros.rerun.sinks import (check_rrd_path, choose_sinks, open_recording,
                                        spawn_viewer)
from flectofold_ros.wire import contract, panel_states

T0_NS = 1782036000 * 10**9  # 2026-06-21 10:00 UTC
STEP_NS = 10**8  # the panels' 10 Hz state grid
TRACKING = contract.STATUSES.index('tracking')


@pytest.fixture(scope='module')
def facade():
    return load_facade(DEFAULT_FACADE)


def stamp(ns):
    return Time(sec=ns // 10**9, nanosec=ns % 10**9)


def closures_at(step, count):
    return 0.5 + 0.45 * np.sin(step / 3.0 + np.arange(count) / 5.0)


def states(scene, closure, panels=None, pressure_pa=None, fault=0, status=TRACKING):
    """Return a panel_states table of ``panels`` (facade indices); values per facade panel."""
    count = len(scene)
    panels = np.arange(count) if panels is None else np.asarray(panels)
    closure = np.broadcast_to(np.asarray(closure, dtype=float), (count,))
    if pressure_pa is None:
        pressure_pa = ATMOSPHERIC_PRESSURE_PA + 8e3 * closure
    table = panel_states.new_table(len(panels))
    table['x'], table['y'], table['z'] = scene.positions_enu[panels].T
    table['closure'] = closure[panels]
    table['fold_angle_rad'] = scene.model.fold_angle_from_closure(closure)[panels]
    table['pressure_pa'] = np.broadcast_to(pressure_pa, (count,))[panels]
    table['setpoint'] = closure[panels]
    rows, columns = panel_states.id_numbers([scene.panel_ids[i] for i in panels])
    table['row'], table['column'] = rows, columns
    table['fault'] = np.broadcast_to(fault, (count,))[panels]
    table['status'] = np.broadcast_to(status, (count,))[panels]
    return table


def message(table, stamp_ns):
    return panel_states.fill_message(PointCloud2(), table, stamp(stamp_ns), PointField)


def processes(scene):
    """Return the two panel processes' panels: the first and second half of the facade."""
    half = len(scene) // 2
    return np.arange(half), np.arange(half, len(scene))


def send(scene, closure, stamp_ns, panels=None, **kwargs):
    feed(scene, contract.PANEL_STATES.name,
         message(states(scene, closure, panels, **kwargs), stamp_ns))


def sun_message(stamp_ns, vector):
    sun = Vector3Stamped()
    sun.header.stamp = stamp(stamp_ns)
    sun.vector.x, sun.vector.y, sun.vector.z = vector
    return sun


class Recording:
    """A scene writing to an .rrd in strict mode; :meth:`close` returns its :class:`Rrd`."""

    def __init__(self, path, facade, **options):
        self.path = path
        self.recording = open_recording('test', None, check_rrd_path(path), strict=True)
        self.scene = FacadeScene(facade, self.recording, **options)
        self.scene.log_static()

    def close(self):
        self.recording.flush()
        self.recording.disconnect()
        return Rrd(self.path)


def record_steps(path, facade, steps, **options):
    """Both processes send a state per step, then the scene flushes; return (scene, rrd)."""
    rec = Recording(path, facade, **options)
    for step in range(steps):
        for panels in processes(rec.scene):
            send(rec.scene, closures_at(step, len(facade)), T0_NS + step * STEP_NS, panels)
        rec.scene.flush()
    return rec.scene, rec.close()


def world_mesh(scene, closure):
    """Vertices and normals the model gives for ``closure``, in the site's ENU frame."""
    model = FoldModel(PanelBatch.from_panels(scene.facade.panels))
    mesh = fold_mesh(model.batch, model.state_from_closure(closure).elastica_k,
                     topology=scene.topology)
    rotation, facade = scene.facade.panel_to_enu, scene.facade
    origin = facade.origin_m @ facade.facade_to_enu.T
    return (np.einsum('nij,nvj->nvi', rotation, mesh.vertices) + origin[:, None, :],
            np.einsum('nij,nvj->nvi', rotation, mesh.normals))


# -- the mesh ---------------------------------------------------------------------------------

def test_the_facade_is_one_mesh_whose_vertices_match_the_model(tmp_path, facade):
    scene, rrd = record_steps(tmp_path / 'day.rrd', facade, steps=4, min_change_rad=0.0)
    assert not any(e.endswith('/mesh') for e in rrd.entities())  # no per-panel entities
    assert rrd.panel_ids() == facade.panel_ids
    assert rrd.vertices_per_panel() == scene.topology.vertex_count
    meshes = rrd.meshes()
    normals = rrd.meshes('Mesh3D:vertex_normals')
    assert [t for t, _ in meshes] == [T0_NS + step * STEP_NS for step in range(4)]
    for step, ((_, vertices), (_, normal)) in enumerate(zip(meshes, normals)):
        expected, expected_normals = world_mesh(scene, closures_at(step, len(facade)))
        np.testing.assert_allclose(vertices, expected, atol=1e-5)  # float32 at ~10 m
        np.testing.assert_allclose(normal, expected_normals, atol=1e-6)
    faces = np.array(rrd.static('/facade/panels', 'Mesh3D:triangle_indices'))
    assert faces.shape == (len(facade) * len(scene.topology.faces), 3)
    assert faces.max() == len(facade) * scene.topology.vertex_count - 1
    assert scene.counts.meshes_logged == 4 and scene.counts.panels_remeshed == 4 * len(facade)


def test_the_scene_shows_the_mesh_the_cad_export_writes(tmp_path, facade):
    """One implementation: the recorded facade is the export's, panel by panel."""
    scene, rrd = record_steps(tmp_path / 'day.rrd', facade, steps=2, min_change_rad=0.0)
    (_, vertices), = rrd.meshes()[-1:]
    shown = np.asarray(vertices).reshape(len(facade), scene.topology.vertex_count, 3)
    mesher = FacadeMesher(facade, topology=scene.topology)
    exported = folded_meshes(mesher, closure=closures_at(1, len(facade)), weld_vertices=False)
    assert [mesh.panel_id for mesh in exported] == scene.panel_ids
    np.testing.assert_allclose(shown, [mesh.vertices_m for mesh in exported], atol=1e-5)


def test_the_mesh_resolution_keeps_the_fold_and_fits_the_facade(facade):
    small, large = facade_topology(36), facade_topology(1000)
    assert (small.stations, small.midrib_columns, small.flap_columns) == (21, 2, 2)
    assert large.stations == 9 and 1000 * large.vertex_count <= FACADE_VERTEX_BUDGET
    assert facade_topology(10**6).stations == 3
    # Two columns a block are the fine mesh's outer columns: the same surface.
    model = FoldModel(PanelBatch.from_panels(facade.panels))
    k = model.state_from_closure(0.7).elastica_k
    fine = fold_mesh(model.batch, k, DEFAULT_TOPOLOGY)
    coarse = fold_mesh(model.batch, k, small)
    for fine_block, coarse_block, columns in (
            (DEFAULT_TOPOLOGY.midrib, small.midrib, DEFAULT_TOPOLOGY.midrib_columns),
            (DEFAULT_TOPOLOGY.flap(+1), small.flap(+1), DEFAULT_TOPOLOGY.flap_columns),
            (DEFAULT_TOPOLOGY.flap(-1), small.flap(-1), DEFAULT_TOPOLOGY.flap_columns)):
        for kind in ('vertices', 'normals'):
            outer = getattr(fine, kind)[:, fine_block].reshape(len(facade), 21, columns, 3)
            mine = getattr(coarse, kind)[:, coarse_block].reshape(len(facade), 21, 2, 3)
            np.testing.assert_allclose(mine, outer[:, :, [0, -1]], atol=1e-12)


def test_the_fast_modulus_is_the_model_root_finders(facade):
    rng = np.random.default_rng(1)
    length = rng.uniform(0.5, 2.0, 5000)
    k = np.concatenate([[0.0, 1e-9, elastica.K_MAX], rng.uniform(0.0, elastica.K_MAX, 4997)])
    sag = elastica.sag_from_k(k, length)
    np.testing.assert_allclose(k_from_sag(sag, length), elastica.k_from_sag(sag, length),
                               rtol=0, atol=1e-14)


def test_panel_frames_and_the_blueprint_are_static(tmp_path, facade):
    _, rrd = record_steps(tmp_path / 'pose.rrd', facade, steps=1)
    origins = np.array(rrd.static('/facade/panel_frames', 'Points3D:positions'))
    np.testing.assert_allclose(origins, facade.origin_m @ facade.facade_to_enu.T, atol=1e-6)
    assert rrd.static('/facade/panel_frames', 'Points3D:labels') == facade.panel_ids
    frames = np.array(rrd.static('/facade/panel_frames', 'panel_to_enu')).reshape(-1, 3, 3)
    np.testing.assert_allclose(frames, facade.panel_to_enu, atol=1e-12)
    assert len(rrd.reader.blueprints()) == 1


def test_unchanged_panels_are_not_remeshed_and_a_still_facade_logs_nothing(tmp_path, facade):
    rec = Recording(tmp_path / 'still.rrd', facade)
    scene, count = rec.scene, len(facade)
    closure = np.full(count, 0.5)
    send(scene, closure, T0_NS)
    assert scene.flush() == count
    closure[4] = 0.6
    send(scene, closure, T0_NS + STEP_NS)
    assert scene.flush() == 1
    send(scene, closure + 1e-6, T0_NS + 2 * STEP_NS)  # well under 1 mrad, same colours
    assert scene.flush() == 0
    rrd = rec.close()
    assert [t for t, _ in rrd.meshes()] == [T0_NS, T0_NS + STEP_NS]
    assert [t for t, _ in rrd.meshes('Mesh3D:vertex_colors')] == [T0_NS, T0_NS + STEP_NS]
    assert scene.counts.panels_remeshed == count + 1
    assert scene.counts.panels_unchanged == 2 * count - 1
    expected, _ = world_mesh(scene, closure)
    np.testing.assert_allclose(rrd.meshes()[-1][1], expected, atol=1e-5)


def test_angles_past_the_closed_limit_are_clipped(tmp_path, facade):
    rec = Recording(tmp_path / 'limit.rrd', facade)
    table = states(rec.scene, 1.0)
    table['fold_angle_rad'] += 1e-6
    feed(rec.scene, contract.PANEL_STATES.name, message(table, T0_NS))
    assert rec.scene.flush() == len(facade)
    expected, _ = world_mesh(rec.scene, 1.0)
    np.testing.assert_allclose(rec.close().meshes()[0][1], expected, atol=1e-5)


# -- two processes, every state ---------------------------------------------------------------

def test_two_processes_merge_into_one_facade(tmp_path, facade):
    rec = Recording(tmp_path / 'two.rrd', facade)
    scene = rec.scene
    first, second = processes(scene)
    send(scene, 0.2, T0_NS, first)
    scene.flush()  # the second process has not been heard from yet: grey, open
    send(scene, 0.8, T0_NS, second)
    scene.flush()
    rrd = rec.close()
    (_, early), (_, merged) = rrd.meshes()
    closure = np.where(np.isin(np.arange(len(facade)), first), 0.2, 0.8)
    np.testing.assert_allclose(merged, world_mesh(scene, closure)[0], atol=1e-5)
    np.testing.assert_allclose(early[first], world_mesh(scene, 0.2)[0][first], atol=1e-5)
    np.testing.assert_allclose(early[second], world_mesh(scene, 0.0)[0][second], atol=1e-5)
    colours = rrd.meshes('Mesh3D:vertex_colors')
    assert colours[0][1][second[0], 0] == packed(NO_STATE_RGBA)
    assert colours[-1][1][second[0], 0] == packed(ramp_colours([0.8])[0])


@pytest.mark.parametrize('every_state', [True, False], ids=['offline', 'live'])
def test_every_state_keeps_each_stamp_live_merges(tmp_path, facade, every_state):
    rec = Recording(tmp_path / 'every.rrd', facade, every_state=every_state)
    scene = rec.scene
    first, second = processes(scene)
    # The second process lags: its first state arrives after the first process's second.
    send(scene, 0.1, T0_NS, first)
    send(scene, 0.3, T0_NS + STEP_NS, first)
    send(scene, 0.2, T0_NS, second)
    send(scene, 0.4, T0_NS + STEP_NS, second)
    scene.flush()
    meshes = rec.close().meshes()
    is_first = np.isin(np.arange(len(facade)), first)
    late = (T0_NS + STEP_NS, np.where(is_first, 0.3, 0.4))
    expected = [(T0_NS, np.where(is_first, 0.1, 0.2)), late] if every_state else [late]
    assert [t for t, _ in meshes] == [t for t, _ in expected]
    for (_, vertices), (_, closure) in zip(meshes, expected):
        np.testing.assert_allclose(vertices, world_mesh(scene, closure)[0], atol=1e-5)


# -- colours ----------------------------------------------------------------------------------

def test_colours_follow_closure_and_faults(tmp_path, facade):
    rec = Recording(tmp_path / 'colour.rrd', facade)
    scene, count = rec.scene, len(facade)
    closure = np.full(count, 0.2)
    send(scene, closure, T0_NS)
    scene.flush()
    closure[0] = 0.9
    send(scene, closure, T0_NS + STEP_NS)
    scene.flush()
    fault = np.zeros(count, dtype=int)
    fault[0] = contract.FAULTS.index('sensor_stuck')
    send(scene, closure, T0_NS + 2 * STEP_NS, fault=fault)
    scene.flush()
    send(scene, closure, T0_NS + 3 * STEP_NS)  # the fault reset
    scene.flush()
    colours = rec.close().colours(facade.panel_ids[0])
    ramp = [packed(ramp_colours([c])[0]) for c in (0.2, 0.9)]
    assert colours == [(T0_NS, ramp[0]), (T0_NS + STEP_NS, ramp[1]),
                       (T0_NS + 2 * STEP_NS, packed(FAULT_RGBA)),
                       (T0_NS + 3 * STEP_NS, ramp[1])]
    assert ramp[0] != ramp[1]
    assert ramp_colour(0.9) == tuple(ramp_colours([0.9])[0])


def test_colour_by_pressure_follows_the_gauge(tmp_path, facade):
    rec = Recording(tmp_path / 'pressure.rrd', facade, color_by='pressure')
    scene = rec.scene
    for step, gauge in enumerate((0.0, 1e3, 2e3, np.nan)):
        send(scene, 0.5, T0_NS + step * STEP_NS, pressure_pa=ATMOSPHERIC_PRESSURE_PA + gauge)
        scene.flush()
    colours = rec.close().colours(facade.panel_ids[2])
    expected = [packed(ramp_colours([p / 12e3])[0]) for p in (0, 1e3, 2e3)]
    assert [c for _, c in colours] == expected + [packed(NO_STATE_RGBA)]  # NaN: no reading
    assert scene.counts.rejected == 0


# -- series and events ------------------------------------------------------------------------

def test_series_have_one_value_per_panel_per_stamp_and_carry_the_rest(tmp_path, facade):
    rec = Recording(tmp_path / 'series.rrd', facade)
    scene, count = rec.scene, len(facade)
    first, second = processes(scene)
    c = [closures_at(step, count) for step in range(3)]
    send(scene, c[0], T0_NS, first)
    send(scene, c[0], T0_NS, second)
    scene.flush()
    send(scene, c[1], T0_NS + STEP_NS, first)  # the second process skips this state
    send(scene, c[2], T0_NS + 2 * STEP_NS, second)
    send(scene, c[2], T0_NS + 2 * STEP_NS, first)
    scene.flush()
    rrd = rec.close()
    names, stamps, closure = rrd.series_table('closure')
    assert names == facade.panel_ids
    assert stamps.tolist() == [T0_NS, T0_NS + STEP_NS, T0_NS + 2 * STEP_NS]
    assert closure.shape == (3, count)
    expected = np.array([c[0], np.where(np.isin(np.arange(count), first), c[1], c[0]), c[2]])
    np.testing.assert_allclose(closure, expected, rtol=1e-6)
    _, _, gauge = rrd.series_table('pressure_gauge_pa')
    np.testing.assert_allclose(gauge, 8e3 * expected, atol=0.05)  # float32 on the topic
    _, _, angle = rrd.series_table('fold_angle_rad')
    np.testing.assert_allclose(angle[2], scene.model.fold_angle_from_closure(c[2]), atol=1e-6)
    band_names, band_stamps, band = rrd.series_table('closure_mean')
    assert tuple(band_names) == CLOSURE_BAND and band_stamps.tolist() == stamps.tolist()
    np.testing.assert_allclose(band, np.stack([expected.mean(1), expected.min(1),
                                               expected.max(1)], axis=1), rtol=1e-6)
    assert rrd.series('closure', facade.panel_ids[-1])[1] == (T0_NS + STEP_NS,
                                                              pytest.approx(c[0][-1]))
    assert scene.counts.samples_logged == 3 * 3 * count


def test_a_missing_pressure_reading_is_a_gap_not_a_rejection(tmp_path, facade):
    rec = Recording(tmp_path / 'gap.rrd', facade)
    pressure = np.full(len(facade), ATMOSPHERIC_PRESSURE_PA + 500.0)
    pressure[3] = np.nan
    send(rec.scene, 0.5, T0_NS, pressure_pa=pressure)
    rec.scene.flush()
    _, _, gauge = rec.close().series_table('pressure_gauge_pa')
    assert np.isnan(gauge[0, 3]) and gauge[0, 4] == pytest.approx(500.0)
    assert rec.scene.counts.rejected == 0


def test_events_are_logged_only_on_change(tmp_path, facade):
    rec = Recording(tmp_path / 'events.rrd', facade)
    scene, count = rec.scene, len(facade)
    timeout, fault_status = (contract.STATUSES.index(s) for s in ('setpoint_timeout', 'fault'))
    first, second = processes(scene)
    status = np.full(count, TRACKING)
    fault = np.zeros(count, dtype=int)
    fault[second[0]] = contract.FAULTS.index('leak')  # first seen with a fault: news
    status[second[0]] = fault_status
    for step in range(2):  # first states, then the same again: only that fault
        for panels in (first, second):
            send(scene, 0.5, T0_NS + step * STEP_NS, panels, fault=fault, status=status)
        scene.flush()
    status[3] = timeout
    send(scene, 0.5, T0_NS + 2 * STEP_NS, first, fault=fault, status=status)
    send(scene, 0.5, T0_NS + 3 * STEP_NS, first, fault=fault, status=status)
    fault[5], status[5] = contract.FAULTS.index('sensor_stuck'), fault_status
    send(scene, 0.5, T0_NS + 4 * STEP_NS, first, fault=fault, status=status)
    fault[5], status[5] = 0, TRACKING
    send(scene, 0.5, T0_NS + 5 * STEP_NS, first, fault=fault, status=status)
    scene.flush()
    texts = rec.close().rows('/facade/events', 'TextLog:text')
    levels = [level for _, level in Rrd(rec.path).rows('/facade/events', 'TextLog:level')]
    ids = facade.panel_ids
    assert [(t, text[0]) for t, text in texts] == [
        (T0_NS, f'{ids[second[0]]} fault: leak'),
        (T0_NS + 2 * STEP_NS, f'{ids[3]} status: setpoint_timeout'),
        (T0_NS + 4 * STEP_NS, f'{ids[5]} fault: sensor_stuck'),
        (T0_NS + 4 * STEP_NS, f'{ids[5]} status: fault'),
        (T0_NS + 5 * STEP_NS, f'{ids[5]} fault: none'),
        (T0_NS + 5 * STEP_NS, f'{ids[5]} status: tracking')]
    assert [level[0] for level in levels] == ['ERROR', 'INFO', 'ERROR', 'INFO', 'INFO', 'INFO']
    assert scene.counts.events_logged == 6
    colours = Rrd(rec.path).colours(ids[second[0]])
    assert colours[-1][1] == packed(FAULT_RGBA)


def test_time_series_and_sun(tmp_path, facade):
    rec = Recording(tmp_path / 'sun.rrd', facade)
    for step in range(3):
        send(rec.scene, 0.5, T0_NS + step * STEP_NS)
        feed(rec.scene, contract.SUN.name, sun_message(
            T0_NS + step * STEP_NS, [0.0, -0.6, 0.8] if step else [0.0, -1.0, -0.1]))
        rec.scene.flush()
    arrows = rec.close().rows('/sun', 'Arrows3D:vectors')
    assert [t for t, _ in arrows] == [T0_NS + STEP_NS, T0_NS + 2 * STEP_NS]  # night: cleared
    np.testing.assert_allclose(np.linalg.norm(arrows[0][1][0]), 3.0, rtol=1e-6)


# -- bad input --------------------------------------------------------------------------------

def test_unknown_ids_and_non_finite_values_are_rejected(tmp_path, facade):
    rec = Recording(tmp_path / 'bad.rrd', facade)
    scene = rec.scene
    table = states(scene, 0.5)
    table['row'][0], table['column'][0] = 99, 99     # r99c99: not on this facade
    table['column'][1] = 7                           # r00c07: inside the grid's digits, not it
    table['closure'][2] = np.nan
    table['fold_angle_rad'][3] = np.inf
    table['pressure_pa'][4] = -np.inf
    table['pressure_pa'][5] = np.nan                 # no reading: taken
    assert scene.panel_states(T0_NS, table) == len(facade) - 5
    assert scene.counts.rejected == 5
    assert scene.flush() == len(facade) - 5
    rrd = rec.close()
    assert rrd.series('closure', facade.panel_ids[0]) == []  # never heard of: NaN
    assert len(rrd.series('closure', facade.panel_ids[6])) == 1
    assert scene.counts.states_taken == len(facade) - 5


def test_a_foreign_point_cloud_is_rejected(facade):
    recording = rr.RecordingStream('test', recording_id='foreign')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)
    topic = contract.PANEL_STATES.name
    xyz = PointCloud2(height=1, width=2, point_step=12, row_step=24, data=bytes(24), fields=[
        PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1)
        for i, n in enumerate('xyz')])
    feed(scene, topic, xyz)
    short = message(states(scene, 0.5), T0_NS)
    short.data = short.data[:-1]
    feed(scene, topic, short)
    big_endian = message(states(scene, 0.5), T0_NS)
    big_endian.is_bigendian = True
    feed(scene, topic, big_endian)
    feed(scene, contract.SUN.name, sun_message(T0_NS, [np.nan, 0.0, 1.0]))
    assert scene.counts.rejected == 4 and scene.counts.states_taken == 0
    assert scene.flush() == 0
    with pytest.raises(ValueError, match='color_by'):
        FacadeScene(facade, recording, color_by='rainbow')
    with pytest.raises(ValueError, match='min_change_rad'):
        FacadeScene(facade, recording, min_change_rad=float('nan'))


def test_nothing_is_placed_before_a_stamped_state(tmp_path, facade):
    rec = Recording(tmp_path / 'early.rrd', facade)
    scene = rec.scene
    first, second = processes(scene)
    status = np.full(len(facade), TRACKING)
    status[0] = contract.STATUSES.index('setpoint_timeout')
    send(scene, 0.4, 0, first)  # before the first /clock: stamp 0
    send(scene, 0.4, 0, first, status=status)
    assert scene.flush() == 0
    send(scene, 0.6, T0_NS, second)
    assert scene.flush() == len(facade)  # the unstamped state is shown from the first stamp
    rrd = rec.close()
    times = [t for e in ('/facade/panels', '/facade/events', '/metrics/closure')
             for c in ('Mesh3D:vertex_positions', 'TextLog:text', 'Scalars:scalars')
             for t, _ in rrd.rows(e, c)]
    assert times and min(times) == T0_NS
    closure = np.where(np.isin(np.arange(len(facade)), first), 0.4, 0.6)
    np.testing.assert_allclose(rrd.meshes()[0][1], world_mesh(scene, closure)[0], atol=1e-5)


# -- topics, bags, sinks ----------------------------------------------------------------------

def test_the_scene_needs_only_the_facade_level_topics(facade):
    assert scene_topics(facade) == [contract.PANEL_STATES, contract.SUN]


def write_bag(path, facade, topics):
    """Write a bag as the recorder does (rclpy-serialized), with the scene's topics."""
    recording = rr.RecordingStream('test', recording_id='bag')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)  # for its tables
    with SegmentedBagWriter(path) as writer:
        for topic in topics:
            writer.add_topic(topic.name, topic.msgtype)
        for step in range(3):
            t_ns = T0_NS + step * STEP_NS
            if contract.PANEL_STATES in topics:
                for j, panels in enumerate(processes(scene)):
                    writer.write(contract.PANEL_STATES.name, t_ns + 1000 + j, serialize_message(
                        message(states(scene, closures_at(step, len(facade)), panels), t_ns)))
            if contract.SUN in topics:
                writer.write(contract.SUN.name, t_ns + 10,
                             serialize_message(sun_message(t_ns, [0.0, -0.6, 0.8])))
            for topic in topics:
                if topic.msgtype == 'std_msgs/msg/Float64':
                    writer.write(topic.name, t_ns, serialize_message(Float64(data=0.5)))
    return scene


def test_a_bag_of_panel_states_converts_to_the_same_scene(tmp_path, facade):
    scene = write_bag(tmp_path / 'bag', facade, [contract.PANEL_STATES, contract.SUN])
    counts = convert(tmp_path / 'bag', tmp_path / 'bag.rrd', facade, strict=True,
                     min_change_rad=0.0)
    assert counts.rejected == 0 and counts.meshes_logged == 3
    rrd = Rrd(tmp_path / 'bag.rrd')
    for step, (time_ns, vertices) in enumerate(rrd.meshes()):
        assert time_ns == T0_NS + step * STEP_NS
        expected = world_mesh(scene, closures_at(step, len(facade)))[0]
        np.testing.assert_allclose(vertices, expected, atol=1e-5)
    assert len(rrd.rows('/sun', 'Arrows3D:vectors')) == 3


def test_the_conversion_says_how_far_it_has_got(tmp_path, facade):
    write_bag(tmp_path / 'bag', facade, [contract.PANEL_STATES, contract.SUN])
    said = []
    convert(tmp_path / 'bag', tmp_path / 'bag.rrd', facade, progress=said.append,
            progress_period_s=0.0)
    assert said and said[0].startswith('0 messages converted, up to ') and 'UTC' in said[0]


def test_a_bag_without_panel_states_is_refused_clearly(tmp_path, facade):
    write_bag(tmp_path / 'old', facade, [contract.CLOSURE.of(facade.panel_ids[0]),
                                         contract.SUN])
    with pytest.raises(BagError, match='no /facade/panel_states in the bag.*per-panel'):
        convert(tmp_path / 'old', tmp_path / 'old.rrd', facade)
    write_bag(tmp_path / 'new', facade, [contract.PANEL_STATES, contract.SUN])
    with pytest.raises(BagError, match='no /facade/panel_states in the chosen topics'):
        convert(tmp_path / 'new', tmp_path / 'new.rrd', facade, topics=[contract.SUN.name])


def test_sinks_are_checked(tmp_path):
    with pytest.raises(ValueError, match='must end in .rrd'):
        check_rrd_path(tmp_path / 'day.txt')
    with pytest.raises(ValueError, match='does not exist'):
        check_rrd_path(tmp_path / 'missing' / 'day.rrd')
    with pytest.raises(ValueError, match='cannot be written'):
        check_rrd_path('/proc/flectofold.rrd')  # unwritable, also for root
    with pytest.raises(ValueError, match='gRPC URL'):
        choose_sinks('http://example.org', '', 9876, environ={})
    url, path, spawn = choose_sinks('auto', '', 9876, environ={})
    assert (url, spawn) == (None, False) and path.suffix == '.rrd'
    path.unlink()


def test_a_viewer_comes_with_the_rrd_unless_it_is_at_a_url(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    warnings = []
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        port = taken.getsockname()[1]
        url = f'rerun+http://127.0.0.1:{port}/proxy'
        chosen = choose_sinks(url, '', 9876, environ={}, warn=warnings.append)
        assert chosen == (url, None, False)
        spawned = choose_sinks('auto', '', port, environ={'DISPLAY': ':0'},
                               warn=warnings.append)
        assert spawned[1].suffix == '.rrd' and spawned[2] is False  # the port is taken
        assert 'is taken' in warnings[-1]
    url, path, spawn = choose_sinks('auto', '', port, environ={'DISPLAY': ':0'},
                                    warn=warnings.append)
    assert url is None and spawn and path.suffix == '.rrd'
    url, path, spawn = choose_sinks('spawn', 'day.rrd', port, environ={}, warn=warnings.append)
    assert (url, path, spawn) == (None, Path('day.rrd'), False)
    assert 'without a display' in warnings[-1]
    url, path, spawn = choose_sinks(f'rerun+http://127.0.0.1:{port}/proxy', '', 9876,
                                    environ={}, warn=warnings.append)
    assert url is None and path.suffix == '.rrd' and 'no Rerun viewer answers' in warnings[-1]


def test_a_viewer_that_cannot_start_is_warned_about(tmp_path):
    warnings = []
    assert spawn_viewer('rerun+http://127.0.0.1:9/proxy', warnings.append,
                        binary=str(tmp_path / 'no_rerun')) is None
    assert 'cannot start the Rerun viewer' in warnings[-1]
    failing = tmp_path / 'failing'
    failing.write_text('#!/bin/sh\nexit 3\n')
    failing.chmod(0o755)
    assert spawn_viewer('rerun+http://127.0.0.1:9/proxy', warnings.append,
                        binary=str(failing)) is None
    assert 'exited at once (exit 3)' in warnings[-1]


def test_small_facade_scene(tmp_path, small_facade_text):
    facade = build_facade(small_facade_text('period_s: 60'))
    scene, rrd = record_steps(tmp_path / 'small.rrd', facade, steps=2)
    assert scene.counts.meshes_logged == 2 and scene.counts.panels_remeshed == 2 * len(facade)
    expected = world_mesh(scene, closures_at(1, len(facade)))[0]
    np.testing.assert_allclose(latest_at(rrd.meshes(), T0_NS + STEP_NS), expected, atol=1e-5)
