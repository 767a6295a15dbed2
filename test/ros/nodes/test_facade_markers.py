"""The RViz/Foxglove markers: their vertices against the fold model, what changes, the node.

The expected triangles are computed here from the fold model itself (the root finder's shape
at each fold angle, ``fold_mesh`` in the panel frame) and the facade description's frames,
not through the mesher the markers use.
"""

import time

import numpy as np
import pytest
from ros_graph import domain_for, Graph
from sensor_msgs.msg import PointCloud2, PointField

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_model.kinematics.mesh import fold_mesh
from flectofold_ros.runtime.interfaces import publisher, qos_profile, subscription
from flectofold_ros.wire import colours, contract, panel_states
from flectofold_ros.wire.markers import FacadeMarkers

pytestmark = pytest.mark.graph
#: Tables against the root finder (the viewer's path against the export's) [m].
VERTEX_TOLERANCE_M = 1e-3


@pytest.fixture(scope='module')
def demonstrator():
    return load_facade(DEFAULT_FACADE)


def expected_triangles(facade, topology, fold_angle_rad):
    """(N, 3 T, 3) triangle corners in ENU from the fold model and the facade's frames."""
    model = fold_model_of(facade.panels)
    mesh = fold_mesh(model.batch, model.shape_from_fold_angle(fold_angle_rad),
                     topology=topology)
    origins = facade.origin_m @ facade.facade_to_enu.T
    enu = np.einsum('nij,nvj->nvi', facade.panel_to_enu, mesh.vertices) + origins[:, None, :]
    return enu[:, np.asarray(topology.faces)].reshape(len(facade), -1, 3)


def states_table(facade, closure, fault=None):
    """Return a panel_states table of every panel of ``facade`` at ``closure``."""
    model = fold_model_of(facade.panels)
    table = panel_states.new_table(len(facade))
    table['row'], table['column'] = panel_states.id_numbers(facade.panel_ids)
    table['closure'] = closure
    table['fold_angle_rad'] = model.fold_angle_from_closure(closure)
    table['fault'] = 0 if fault is None else fault
    return table


def test_marker_triangles_are_the_folded_panels_of_the_fold_model(demonstrator):
    markers = FacadeMarkers(demonstrator)
    closure = np.linspace(0.0, 0.99, len(demonstrator))  # float32 angles: not 1 itself
    table = states_table(demonstrator, closure)
    assert markers.take(table) == len(demonstrator)
    assert list(markers.changed()) == list(range(len(demonstrator)))
    expected = expected_triangles(demonstrator, markers.mesher.topology,
                                  table['fold_angle_rad'].astype(float))
    for index in range(len(demonstrator)):
        error = np.abs(markers.triangles(index) - expected[index]).max()
        assert error < VERTEX_TOLERANCE_M, (index, error)
    assert markers.colour(0) == colours.ramp_colour(0.0)
    assert markers.colour(len(demonstrator) - 1) == colours.ramp_colour(np.float32(0.99))


def test_only_panels_that_moved_or_changed_colour_are_handed_out_again(demonstrator):
    markers = FacadeMarkers(demonstrator)
    table = states_table(demonstrator, np.full(len(demonstrator), 0.3))
    markers.take(table)
    markers.changed()
    assert len(markers.changed()) == 0  # nothing new
    assert len(markers.changed(everything=True)) == len(demonstrator)
    table['closure'][4] = 0.9
    table['fold_angle_rad'][4] = fold_model_of(demonstrator.panels).fold_angle_from_closure(
        np.full(len(demonstrator), 0.9))[4]
    table['fault'][7] = 1
    markers.take(table)
    assert list(markers.changed()) == [4, 7]
    assert markers.colour(7) == colours.FAULT_RGBA


def test_panels_not_heard_are_grey_and_flat_open_and_foreign_points_are_ignored(demonstrator):
    markers = FacadeMarkers(demonstrator)
    assert all(markers.colour(i) == (0, 0, 0, 0) for i in range(3))  # nothing handed out
    markers.changed()
    assert markers.colour(0) == colours.NO_STATE_RGBA
    foreign = panel_states.new_table(1)
    foreign['row'], foreign['column'] = 99, 99
    assert markers.take(foreign) == 0
    nan = states_table(demonstrator, np.full(len(demonstrator), 0.5))
    nan['fold_angle_rad'][0] = np.nan
    assert markers.take(nan) == len(demonstrator) - 1


def test_surface_and_sun(demonstrator):
    markers = FacadeMarkers(demonstrator)
    surface = markers.surface_triangles()
    assert surface.shape == (len(demonstrator) * 2 * 3, 3)  # two triangles per quad outline
    tail, head = markers.sun_arrow(np.array([0.0, -0.6, 0.8]))
    assert np.linalg.norm(head - tail) == pytest.approx(3.0)


def test_the_node_publishes_latched_markers_in_the_site_frame(small_facade_text, tmp_path):
    facade_file = tmp_path / 'small.yaml'
    facade_file.write_text(small_facade_text('shading_target: 0.9'))
    facade = load_facade(facade_file)
    graph = Graph(domain_for(24))
    try:
        node = graph.start('facade_markers', '--ros-args', '-p', f'facade_file:={facade_file}',
                           '-p', 'publish_rate_hz:=5.0', '-p', 'full_period_s:=1.0')
        states = publisher(graph.node, contract.PANEL_STATES)
        heard = []
        subscription(graph.node, contract.MARKERS, heard.append)
        assert graph.spin_until(lambda: heard, 60.0), graph.stop(node)[1]
        closure = np.array([0.0, 0.4, 0.8, 0.99])
        table = states_table(facade, closure)
        message = panel_states.fill_message(PointCloud2(), table, graph.node.get_clock()
                                            .now().to_msg(), PointField)

        def folded():
            for array in heard:
                panels = {m.id: m for m in array.markers if m.ns == 'panels'}
                if len(panels) == 4 and panels[3].color.b < 0.5:  # the closed ramp end
                    return panels
            return None
        deadline = time.monotonic() + 20.0
        while folded() is None and time.monotonic() < deadline:
            states.publish(message)
            graph.spin_for(0.3)
        panels = folded()
        assert panels is not None, [len(a.markers) for a in heard]
        # a display started now gets the last message at once (latched), and the whole
        # facade within full_period_s
        late = []
        subscription(graph.node, contract.MARKERS, late.append)
        assert graph.spin_until(lambda: late, 30.0)
        offered = graph.node.get_publishers_info_by_topic(contract.MARKERS.name)
        assert contract.MARKERS.qos.latched  # the last message to a late display
        assert [info.qos_profile.durability for info in offered] == \
            [qos_profile(contract.MARKERS.qos).durability]

        def whole():
            return {m.ns for array in late for m in array.markers} >= {'panels', 'surface',
                                                                       'sun'}
        assert graph.spin_until(whole, 5.0)
        code, output = graph.stop(node)
    finally:
        graph.close()
    assert code == 0 and 'Traceback' not in output, output
    marker = panels[2]
    assert marker.header.frame_id == contract.SITE_FRAME and marker.type == marker.TRIANGLE_LIST
    points = np.array([[p.x, p.y, p.z] for p in marker.points])
    markers = FacadeMarkers(facade)
    expected = expected_triangles(facade, markers.mesher.topology,
                                  table['fold_angle_rad'].astype(float))
    assert points.shape == expected[2].shape
    assert np.abs(points - expected[2]).max() < VERTEX_TOLERANCE_M


def test_facade_markers_shows_the_bringup_s_day(small_facade_text, tmp_path):
    """``facade --markers``: the markers follow the panels of a simulated day."""
    facade_file = tmp_path / 'small.yaml'
    facade_file.write_text(small_facade_text('period_s: 60.0, shading_target: 0.9, '
                                             'min_dwell_s: 300.0, default_closure: 1.0'))
    graph = Graph(domain_for(26))
    heard = []
    try:
        subscription(graph.node, contract.MARKERS, heard.append)
        bringup = graph.start('facade', '--facade', str(facade_file), '--start', '11:00',
                              '--end', '11:20', '--speedup', '60', '--panel-processes', '1',
                              '--markers')

        def coloured():  # every panel reported: none grey any more
            grey = np.array(colours.NO_STATE_RGBA[:3]) / 255.0
            panels = {m.id: m for array in heard for m in array.markers if m.ns == 'panels'}
            return len(panels) == 4 and all(
                np.abs(np.array([m.color.r, m.color.g, m.color.b]) - grey).max() > 1e-3
                for m in panels.values())
        assert graph.spin_until(coloured, 150.0), heard[-1:] or bringup.poll()
        output, _ = bringup.communicate(timeout=150)
    finally:
        graph.close()
    assert bringup.returncode == 0 and 'Traceback' not in output, output
    assert '/facade/markers' in output  # facade_markers said what it publishes
