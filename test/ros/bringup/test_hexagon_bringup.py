"""A hexagonal facade through the bringup as a user runs it: recorded, in Rerun, replayed."""

import subprocess

import numpy as np
import pytest
from ros_graph import BIN, domain_for, Graph
from rosbags.highlevel import AnyReader
from rrd_reading import Rrd

from flectofold_model.facade import load_facade
from flectofold_ros.rerun.scene import facade_topology
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph

HEXAGON_FACADE = """
name: small-hexagon
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {type: saddle, width_m: 2.8, height_m: 2.4, curvature_u_per_m: -0.08,
          curvature_v_per_m: 0.08}
grid: {gap_m: 0.1}
panel: {type: hexagon, circumradius_m: 0.62, fold_line_sag_m: 0.06, hinge_width_m: 0.03}
control: {period_s: 60.0, shading_target: 0.9, min_dwell_s: 300.0, default_closure: 1.0}
"""


@pytest.fixture()
def hexagon_facade_file(tmp_path):
    path = tmp_path / 'small_hexagon.yaml'
    path.write_text(HEXAGON_FACADE)
    return path


def test_a_hexagonal_day_is_recorded_drawn_and_replayed(hexagon_facade_file, tmp_path):
    facade = load_facade(hexagon_facade_file)
    count = len(facade)
    assert facade.panel_kind == 'hexagon' and count >= 3
    graph = Graph(domain_for(60))
    try:
        bringup = graph.start('facade', '--facade', str(hexagon_facade_file), '--start',
                              '11:00', '--end', '11:30', '--speedup', '120',
                              '--panel-processes', '1', '--progress-period', '2', '--record',
                              '--rerun', 'none', '--out', str(tmp_path / 'out'))
        output, _ = bringup.communicate(timeout=300)
    finally:
        graph.close()
    assert bringup.returncode == 0, output
    assert f'panels reporting: {count}/{count}' in output, output
    assert 'faults: none' in output and 'Traceback' not in output, output
    run = (tmp_path / 'out' / 'latest').resolve()
    assert f'bag {run / "bag"}: complete' in output, output

    with AnyReader([run / 'bag']) as reader:
        joints = [c for c in reader.connections if c.topic == contract.FACADE_JOINT_STATES.name]
        states = [reader.deserialize(raw, c.msgtype)
                  for c, _, raw in reader.messages(connections=joints)]
    assert states, 'the bag holds the facade joint states'
    expected = [name for panel in facade.panel_ids
                for name in contract.flap_joint_names(panel, 'hexagon')]
    assert list(states[-1].name) == expected and expected[0].endswith('_flap_0')
    position = np.array(states[-1].position).reshape(count, 3)
    assert np.all(position[:, 0] == position[:, 2]) and np.all(position > 0.05)

    rrd = Rrd(run / 'facade.rrd')
    assert rrd.panel_ids() == facade.panel_ids
    assert rrd.vertices_per_panel() == facade_topology(count, kind='hexagon').vertex_count
    assert len(rrd.meshes()) > 2

    replayed = tmp_path / 'replayed.rrd'
    converted = subprocess.run([str(BIN / 'replay'), str(run / 'bag'), '--to-rrd',
                                str(replayed), '--facade', str(hexagon_facade_file)],
                               capture_output=True, text=True, timeout=180)
    assert converted.returncode == 0, converted.stdout + converted.stderr
    assert ' 0 rejected' in converted.stdout, converted.stdout
    assert Rrd(replayed).panel_ids() == facade.panel_ids
