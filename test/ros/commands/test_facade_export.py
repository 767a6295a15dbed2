"""facade_export as a user runs it, its files read back by other readers, and bad input.

The executable runs as ``python -m flectofold_ros facade_export`` (what the console script
runs) with this tree first on the path. The OBJ is parsed here by hand and by trimesh, the
glTF and GLB by trimesh and by pygltflib's own loader.
"""

import os
from pathlib import Path
import subprocess
import sys
import textwrap

import numpy as np
import pygltflib
import pytest
from setup_script import console_scripts
import trimesh

from flectofold_model.facade import load_facade
from flectofold_model.facade.folded_mesh import folded_meshes
from flectofold_ros.runtime.executables import EXECUTABLES

ROOT = Path(__file__).resolve().parents[3]


def export(*args, timeout=120):
    environment = {**os.environ, 'PYTHONPATH': os.pathsep.join(
        [str(ROOT), os.environ.get('PYTHONPATH', '')])}
    return subprocess.run([sys.executable, '-m', 'flectofold_ros', 'facade_export', *args],
                          capture_output=True, text=True, timeout=timeout, env=environment,
                          cwd=ROOT)


def read_obj(path):
    """{object name: (V, 3) vertices} of an OBJ file, and its faces per object (1-based)."""
    objects, faces, name = {}, {}, None
    for line in Path(path).read_text().splitlines():
        fields = line.split()
        if not fields or fields[0] == '#':
            continue
        if fields[0] == 'o':
            name = fields[1]
            objects[name], faces[name] = [], []
        elif fields[0] == 'v':
            objects[name].append([float(x) for x in fields[1:4]])
        elif fields[0] == 'f':
            faces[name].append([int(x) for x in fields[1:]])
    return {k: np.array(v) for k, v in objects.items()}, {k: np.array(v) for k, v in
                                                          faces.items()}


def test_facade_export_is_an_executable_stopped_like_a_command():
    assert EXECUTABLES['facade_export'] == ('flectofold_ros.commands.facade_export', 130)
    assert console_scripts()['facade_export'] == 'flectofold_ros.runtime.executables:facade_export'


def test_obj_has_one_object_per_panel_in_site_coordinates(tmp_path):
    out = tmp_path / 'demonstrator.obj'
    run = export('--facade', 'demonstrator_6x6', '--closure', '0.5', '--out', str(out))
    assert run.returncode == 0, run.stderr
    assert 'folded panels:' in run.stdout and '36 panels' in run.stdout
    header = out.read_text().splitlines()[:3]
    assert any('site_enu, x east, y north, z up; units: metres' in line for line in header)
    objects, faces = read_obj(out)
    facade = load_facade('demonstrator_6x6')
    assert list(objects) == facade.panel_ids
    expected = {mesh.panel_id: mesh for mesh in folded_meshes(facade, closure=0.5)}
    base = 1
    for name, vertices in objects.items():
        np.testing.assert_allclose(vertices, expected[name].vertices_m, atol=1e-6)
        np.testing.assert_array_equal(faces[name] - base, expected[name].faces)
        base += len(vertices)
    everything = np.concatenate(list(objects.values()))
    # a south facade 6.6 m wide and high, centred on the site origin: x east, z up
    assert everything[:, 0].min() > -3.4 and everything[:, 0].max() < 3.4
    assert everything[:, 2].min() > -3.4 and everything[:, 2].max() < 3.4
    scene = trimesh.load(out, force='scene', process=False, split_objects=True)
    assert sorted(scene.geometry) == sorted(objects)
    for name, geometry in scene.geometry.items():
        assert len(geometry.vertices) == len(objects[name])
        assert len(geometry.faces) == len(faces[name])
        np.testing.assert_allclose(geometry.bounds, [objects[name].min(axis=0),
                                                     objects[name].max(axis=0)], atol=1e-9)
    np.testing.assert_allclose(scene.bounds, [everything.min(axis=0), everything.max(axis=0)],
                               atol=1e-6)


@pytest.mark.parametrize('suffix', ['glb', 'gltf'])
def test_gltf_is_y_up_with_one_named_node_per_panel(tmp_path, suffix):
    out, obj = tmp_path / f'hexagon.{suffix}', tmp_path / 'hexagon.obj'
    for path in (out, obj):
        run = export('--facade', 'hexagon_6x6', '--closure', '0.8', '--out', str(path))
        assert run.returncode == 0, run.stderr
    objects, _ = read_obj(obj)
    document = pygltflib.GLTF2().load(str(out))
    assert [node.name for node in document.nodes] == list(objects)
    assert [mesh.name for mesh in document.meshes] == list(objects)
    assert document.asset.extras['units'] == 'm'
    scene = trimesh.load(out, force='scene', process=False)
    assert len(scene.geometry) == len(objects)
    for node in scene.graph.nodes_geometry:
        transform, geometry = scene.graph[node]
        np.testing.assert_allclose(transform, np.eye(4))
        gltf = scene.geometry[geometry].vertices
        enu = np.stack([gltf[:, 0], -gltf[:, 2], gltf[:, 1]], axis=-1)  # (E, U, -N) back
        np.testing.assert_allclose(enu, objects[node], atol=2e-6)  # float32 in glTF


def test_night_time_gives_the_default_closure(tmp_path):
    at_night, closed = tmp_path / 'night.obj', tmp_path / 'closed.obj'
    run = export('--time', '2026-06-21T03:00:00+02:00', '--out', str(at_night))
    assert run.returncode == 0, run.stderr
    assert 'schedule: closure min 1.00, mean 1.00, max 1.00' in run.stdout
    assert export('--closure', '1', '--out', str(closed)).returncode == 0
    body = [line for line in at_night.read_text().splitlines() if not line.startswith('#')]
    assert body == [line for line in closed.read_text().splitlines()
                    if not line.startswith('#')]


FLAT = textwrap.dedent("""
    name: flat-round-trip
    site: {latitude_deg: 48.78, longitude_deg: 9.18}
    facade: {azimuth_deg: 200}
    surface: SURFACE
    grid: GRID
    panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03}
""")


def test_surface_quads_round_trip_through_the_obj_import(tmp_path):
    """A flat facade -> its surface quads -> an OBJ surface -> the same panels."""
    flat = tmp_path / 'flat.yaml'
    flat.write_text(FLAT.replace('SURFACE', '{type: plane, width_m: 4.4, height_m: 3.3}')
                    .replace('GRID', '{rows: 3, columns: 4, gap_m: 0.1, midrib_along: v}'))
    quads = tmp_path / 'flat_quads.obj'
    run = export('--facade', str(flat), '--surface-quads', str(quads), '--closure', '0',
                 '--out', str(tmp_path / 'flat.obj'))
    assert run.returncode == 0, run.stderr
    assert 'surface quads:' in run.stdout and '12 quads, 20 vertices' in run.stdout
    from_obj = tmp_path / 'from_obj.yaml'
    from_obj.write_text(FLAT.replace('SURFACE', '{type: obj, path: flat_quads.obj}')
                        .replace('GRID', '{gap_m: 0.1, midrib_along: v}'))
    original, again = load_facade(flat), load_facade(from_obj)
    assert again.panel_ids == original.panel_ids
    np.testing.assert_allclose(again.origin_m, original.origin_m, atol=1e-9)
    np.testing.assert_allclose(again.rotation, original.rotation, atol=1e-9)
    np.testing.assert_allclose([(p.length_m, p.width_m, p.prefold_rad) for p in again.panels],
                               [(p.length_m, p.width_m, p.prefold_rad) for p in original.panels],
                               atol=1e-12)
    # and the folded panels of both are the same, in the site frame
    exported, _ = read_obj(tmp_path / 'flat.obj')
    for mesh in folded_meshes(again, closure=0.0):
        np.testing.assert_allclose(mesh.vertices_m, exported[mesh.panel_id], atol=1e-6)


def bad_inputs(tmp_path):
    good = str(tmp_path / 'ok.obj')
    return [
        (['--facade', 'no_such_facade', '--closure', '0.5', '--out', good], 'no_such_facade'),
        (['--closure', '1.5', '--out', good], 'must lie in [0, 1]'),
        (['--closure', '-0.1', '--out', good], 'must lie in [0, 1]'),
        (['--closure', 'nan', '--out', good], 'got nan'),
        (['--time', 'noon', '--out', good], 'not an ISO 8601'),
        (['--time', '6500-01-01T00:00:00Z', '--out', good], 'epoch'),
        (['--closure', '0.5', '--out', str(tmp_path / 'missing' / 'a.obj')], 'does not exist'),
        (['--closure', '0.5', '--out', str(tmp_path)], 'unknown suffix'),
        (['--closure', '0.5', '--out', str(tmp_path / 'folder.obj')], 'is a folder'),
        (['--closure', '0.5', '--out', str(tmp_path / 'a.stl')], 'unknown suffix'),
        (['--out', good], 'needs --closure'),
        ([], 'nothing to write'),
        (['--facade', 'hexagon_6x6', '--surface-quads', good], 'hexagon'),
        (['--surface-quads', str(tmp_path / 'a.glb')], 'writes an .obj'),
    ]


def test_bad_input_is_one_line_and_exit_2(tmp_path):
    (tmp_path / 'folder.obj').mkdir()
    for args, words in bad_inputs(tmp_path):
        run = export(*args)
        assert run.returncode == 2, (args, run.stdout, run.stderr)
        lines = run.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith('facade_export: '), (args, run.stderr)
        assert words in lines[0], (args, lines[0])
        assert not (tmp_path / 'ok.obj').exists()
