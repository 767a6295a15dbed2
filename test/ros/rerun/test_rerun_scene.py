"""The Rerun scene: what an .rrd written by it holds, read back with the SDK's reader."""

import numpy as np
import pytest
import rerun as rr
from rrd_reading import latest_at, Rrd

from flectofold_model.actuation import ATMOSPHERIC_PRESSURE_PA
from flectofold_model.facade.description import build_facade, DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.mesh import fold_mesh
from flectofold_model.kinematics.panel import PanelBatch
from flectofold_ros import contract
from flectofold_ros.rerun.scene import FacadeScene, FAULT_RGBA, feed, ramp_colour, scene_topics
from flectofold_ros.rerun.sinks import check_rrd_path, choose_sinks, open_recording

T0_NS = 1782036000 * 10**9  # 2026-06-21 10:00 UTC
STEP_NS = 72 * 10**9


@pytest.fixture(scope='module')
def facade():
    return load_facade(DEFAULT_FACADE)


def closures_at(step, count):
    return 0.5 + 0.45 * np.sin(step / 3.0 + np.arange(count) / 5.0)


def record(path, facade, steps, fault_at=None, color_by='closure', hold_panel=None):
    """Log ``steps`` states of every panel; return the fold angles fed per step."""
    recording = open_recording('test', None, check_rrd_path(path), strict=True)
    scene = FacadeScene(facade, recording, color_by=color_by)
    scene.log_static()
    fed = []
    for step in range(steps):
        stamp = T0_NS + step * STEP_NS
        closure = closures_at(step, len(facade))
        if hold_panel is not None:
            closure[hold_panel] = 0.3
        angles = scene.model.fold_angle_from_closure(closure)
        for i, panel_id in enumerate(facade.panel_ids):
            scene.fold_angle(panel_id, stamp, float(angles[i]))
            scene.closure_value(panel_id, stamp, float(closure[i]))
            scene.pressure(panel_id, stamp, ATMOSPHERIC_PRESSURE_PA + 1000.0 * step)
        scene.sun(stamp, [0.0, -0.6, 0.8] if step else [0.0, -1.0, -0.1])
        if step == fault_at:
            scene.status(facade.panel_ids[0], stamp, 'pressure_sensor_stuck', is_fault=True)
        scene.flush()
        fed.append(angles)
    recording.flush()
    recording.disconnect()
    return scene, np.array(fed)


def test_one_mesh_per_panel_whose_vertices_match_the_model(tmp_path, facade):
    path = tmp_path / 'day.rrd'
    _, fed = record(path, facade, steps=4)
    rrd = Rrd(path)
    meshes = {e for e in rrd.entities() if e.endswith('/mesh')}
    assert meshes == {f'/facade/panels/{p}/mesh' for p in facade.panel_ids}
    model = FoldModel(PanelBatch.from_panels(facade.panels))
    for step in range(4):
        expected = fold_mesh(model.batch, model.state_from_closure(closures_at(
            step, len(facade))).elastica_k).vertices
        for i in (0, 17, 35):
            rows = rrd.vertices(facade.panel_ids[i])
            assert len(rows) == 4
            time_ns, vertices = rows[step]
            assert time_ns == T0_NS + step * STEP_NS
            np.testing.assert_allclose(vertices, expected[i], atol=2e-6)
    faces = rrd.static(f'/facade/panels/{facade.panel_ids[0]}/mesh', 'Mesh3D:triangle_indices')
    assert np.array(faces).max() == expected.shape[1] - 1


def test_panels_sit_at_their_facade_pose(tmp_path, facade):
    path = tmp_path / 'pose.rrd'
    record(path, facade, steps=1)
    rrd = Rrd(path)
    i = 7
    translation = rrd.static(f'/facade/panels/{facade.panel_ids[i]}', 'Transform3D:translation')
    np.testing.assert_allclose(translation[0], facade.facade_to_enu @ facade.origin_m[i],
                               atol=1e-6)
    matrix = np.array(rrd.static(f'/facade/panels/{facade.panel_ids[i]}',
                                 'Transform3D:mat3x3')[0]).reshape(3, 3).T  # column-major
    np.testing.assert_allclose(matrix, facade.panel_to_enu[i], atol=1e-6)
    assert len(rrd.reader.blueprints()) == 1


def test_time_series_and_sun(tmp_path, facade):
    path = tmp_path / 'series.rrd'
    record(path, facade, steps=3)
    rrd = Rrd(path)
    pressure = rrd.series('pressure_gauge_pa', facade.panel_ids[3])
    assert [t for t, _ in pressure] == [T0_NS + k * STEP_NS for k in range(3)]
    np.testing.assert_allclose([v for _, v in pressure], [0.0, 1000.0, 2000.0])
    arrows = rrd.rows('/sun', 'Arrows3D:vectors')
    assert [t for t, _ in arrows] == [T0_NS + STEP_NS, T0_NS + 2 * STEP_NS]  # night: cleared
    np.testing.assert_allclose(np.linalg.norm(arrows[0][1][0]), 3.0, rtol=1e-6)


def test_unchanged_panels_are_not_remeshed(tmp_path, facade):
    scene, _ = record(tmp_path / 'still.rrd', facade, steps=5, hold_panel=4)
    assert len(Rrd(tmp_path / 'still.rrd').vertices(facade.panel_ids[4])) == 1
    assert scene.counts.meshes_unchanged >= 4  # the held panel; others may pause at a peak
    assert scene.counts.meshes_logged + scene.counts.meshes_unchanged == 5 * len(facade)


def test_a_fault_turns_the_panel_red_and_is_logged(tmp_path, facade):
    path = tmp_path / 'fault.rrd'
    record(path, facade, steps=3, fault_at=1)
    rrd = Rrd(path)
    colours = rrd.rows(f'/facade/panels/{facade.panel_ids[0]}/mesh', 'Mesh3D:albedo_factor')
    fault_rgba = int.from_bytes(bytes(FAULT_RGBA), 'big')
    assert latest_at(colours, T0_NS)[0] != fault_rgba
    assert latest_at(colours, T0_NS + STEP_NS)[0] == fault_rgba
    events = rrd.rows('/facade/events', 'TextLog:text')
    assert any('pressure_sensor_stuck' in text[0] for _, text in events)


def test_colour_by_pressure_follows_the_gauge(tmp_path, facade):
    path = tmp_path / 'pressure.rrd'
    record(path, facade, steps=3, color_by='pressure')
    colours = Rrd(path).rows(f'/facade/panels/{facade.panel_ids[2]}/mesh',
                             'Mesh3D:albedo_factor')
    expected = [int.from_bytes(bytes(ramp_colour(p / 12e3)), 'big') for p in (0, 1e3, 2e3)]
    assert [c[0] for _, c in colours] == expected


def test_bad_input_is_rejected_and_counted(tmp_path, facade):
    recording = rr.RecordingStream('test', recording_id='bad')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)
    scene.fold_angle('r99c99', T0_NS, 0.3)
    scene.fold_angle(facade.panel_ids[0], T0_NS, float('nan'))
    scene.pressure(facade.panel_ids[0], T0_NS, float('inf'))
    scene.sun(T0_NS, [float('nan'), 0.0, 1.0])
    scene.status('nobody', T0_NS, 'fault', is_fault=True)
    assert scene.counts.rejected == 5
    assert scene.flush() == 0
    with pytest.raises(ValueError, match='color_by'):
        FacadeScene(facade, recording, color_by='rainbow')
    with pytest.raises(ValueError, match='min_change_rad'):
        FacadeScene(facade, recording, min_change_rad=float('nan'))


def test_angles_past_the_closed_limit_are_clipped(tmp_path, facade):
    path = tmp_path / 'limit.rrd'
    recording = open_recording('test', None, check_rrd_path(path), strict=True)
    scene = FacadeScene(facade, recording)
    closed = scene.angle_limits_rad[1][0]
    scene.fold_angle(facade.panel_ids[0], T0_NS, float(closed) + 1e-9)
    assert scene.flush() == 1


def test_feed_routes_topics(facade):
    recording = rr.RecordingStream('test', recording_id='feed')
    rr.binary_stream(recording=recording)
    scene = FacadeScene(facade, recording)
    topics = {topic.name for topic in scene_topics(facade)}
    assert contract.SUN.name in topics and len(topics) == 1 + 5 * len(facade)

    class Stamp:
        sec, nanosec = 1782036000, 5

    class Header:
        stamp = Stamp

    class Pressure:
        header, fluid_pressure = Header, ATMOSPHERIC_PRESSURE_PA + 500.0

    feed(scene, contract.PRESSURE.of(facade.panel_ids[1]).name, Pressure, 0)
    assert scene.gauge_pa[1] == pytest.approx(500.0)


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
    url, path, spawn = choose_sinks('auto', '', 9876, environ={'DISPLAY': ':0'})
    assert (url, path, spawn) == (None, None, True)
    url, _, _ = choose_sinks('rerun+http://127.0.0.1:9000/proxy', '', 9876, environ={})
    assert url == 'rerun+http://127.0.0.1:9000/proxy'


def test_small_facade_scene(tmp_path, small_facade_text):
    facade = build_facade(small_facade_text('period_s: 60'))
    scene, _ = record(tmp_path / 'small.rrd', facade, steps=2)
    assert scene.counts.meshes_logged == 2 * len(facade)


def test_nothing_is_placed_before_a_stamped_state(tmp_path, facade):
    path = tmp_path / 'early.rrd'
    recording = open_recording('test', None, check_rrd_path(path), strict=True)
    scene = FacadeScene(facade, recording)
    scene.closure_value(facade.panel_ids[0], 0, 0.4)  # before the first /clock: stamp 0
    scene.status(facade.panel_ids[0], 0, 'tracking')
    assert scene.flush() == 0
    scene.pressure(facade.panel_ids[1], T0_NS, ATMOSPHERIC_PRESSURE_PA)  # no fold angle yet
    assert scene.flush() == 0
    scene.fold_angle(facade.panel_ids[0], T0_NS + 1, 0.5)
    assert scene.flush() == 1
    recording.flush()
    recording.disconnect()
    rrd = Rrd(path)
    components = ('Mesh3D:vertex_positions', 'Mesh3D:albedo_factor', 'TextLog:text')
    times = [t for e in rrd.entities() for c in components for t, _ in rrd.rows(e, c)]
    assert times and min(times) >= T0_NS
