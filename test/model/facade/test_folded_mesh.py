"""The facade's folded mesh in the site frame, the CAD files' axes and the surface quads."""

import textwrap

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from flectofold_model.facade import build_facade, load_facade
from flectofold_model.facade.description import surface_quads
from flectofold_model.facade.folded_mesh import (EXPORT_VERTEX_BUDGET, FacadeMesher,
                                                 fold_angles, folded_meshes, weld)
from flectofold_model.facade.mesh_files import enu_to_gltf, mesh_format, write_quad_obj

#: Two 1.0 m x 1.0 m panels side by side on an east-facing plane, no pre-fold: flat at
#: closure 0. Facing east, "right seen from outside" is north.
FLAT_EAST = textwrap.dedent("""
    name: flat-east
    site: {latitude_deg: 48.78, longitude_deg: 9.18}
    facade: {azimuth_deg: 90}
    surface: {type: plane, width_m: 2.2, height_m: 1.1}
    grid: {rows: 1, columns: 2, gap_m: 0.1, midrib_along: v}
    panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03,
            min_prefold_rad: 0.0, max_moulded_prefold_rad: 0.0}
""")


def test_a_flat_panel_is_its_footprint_from_the_description():
    facade = build_facade(FLAT_EAST)
    meshes = folded_meshes(facade, closure=0.0)
    assert [mesh.panel_id for mesh in meshes] == ['r00c00', 'r00c01']
    # By hand from the YAML: column centres at u = -0.55 and +0.55 m (north), v = 0 (up),
    # on the plane x = 0 (east); each panel 1.1 - 0.1 = 1.0 m square.
    for mesh, north_m in zip(meshes, (-0.55, 0.55)):
        east, north, up = mesh.vertices_m.T
        np.testing.assert_allclose(east, 0.0, atol=1e-12)
        corners = [(0.0, north_m + a, b) for a in (-0.5, 0.5) for b in (-0.5, 0.5)]
        for corner in corners:
            assert np.min(np.linalg.norm(mesh.vertices_m - corner, axis=1)) < 1e-9, corner
        np.testing.assert_allclose([north.min(), north.max(), up.min(), up.max()],
                                   [north_m - 0.5, north_m + 0.5, -0.5, 0.5], atol=1e-12)


def test_the_demonstrator_has_its_36_panels_by_name():
    facade = load_facade('demonstrator_6x6')
    meshes = folded_meshes(facade, closure=0.3)
    expected = [f'r{r:02d}c{c:02d}' for r in range(6) for c in range(6)]
    assert sorted(mesh.panel_id for mesh in meshes) == expected
    assert [mesh.panel_id for mesh in meshes] == facade.panel_ids
    for mesh, origin in zip(meshes, facade.origin_m @ facade.facade_to_enu.T):
        # a south facade: every panel within its 1.0 m x 1.0 m of its origin, in front of it
        assert np.max(np.linalg.norm(mesh.vertices_m - origin, axis=1)) < 0.75


@pytest.mark.parametrize('closure', [0.25, 0.6, 1.0])
def test_the_mesh_folds_by_the_models_apex_angle(closure):
    """The dihedral at mid-span between the mid-rib and a flap, measured on the mesh."""
    facade = load_facade('demonstrator_6x6')
    mesher = FacadeMesher(facade, vertex_budget=EXPORT_VERTEX_BUDGET)
    expected = mesher.model.fold_angle_from_closure(closure)
    meshes = folded_meshes(mesher, closure=closure, weld_vertices=False)
    topology = mesher.topology
    middle = topology.stations // 2
    for mesh, angle in zip(meshes, expected):
        rows = [_block_normal(mesh, topology, block, middle) for block in ('midrib', +1, -1)]
        for flap in rows[1:]:
            measured = np.arccos(np.clip(np.dot(rows[0], flap), -1.0, 1.0))
            assert measured == pytest.approx(angle, abs=2e-3)


def _block_normal(mesh, topology, block, station):
    """Return the front normal of a block's strip around ``station`` (its rows are straight).

    The rows run along x and the columns across: from the -y crease to the +y one on the
    mid-rib, from the crease outward on a flap, so toward -y on the -y flap, where
    (along x across) points to the back.
    """
    if block == 'midrib':
        part, columns = topology.midrib, topology.midrib_columns
    else:
        part, columns = topology.flap(block), topology.flap_columns
    grid = mesh.vertices_m[part].reshape(topology.stations, columns, 3)
    across = grid[station, -1] - grid[station, 0]
    along = grid[station + 1, 0] - grid[station - 1, 0]
    normal = np.cross(along, across) * (-1.0 if block == -1 else 1.0)
    return normal / np.linalg.norm(normal)


def test_the_viewer_tables_agree_with_the_root_finders():
    for name, tolerance in (('demonstrator_6x6', 1e-9), ('hexagon_6x6', 1e-5)):
        mesher = FacadeMesher(load_facade(name))
        angle = fold_angles(mesher, closure=np.linspace(0.0, 1.0, len(mesher)))
        panels = np.arange(len(mesher))
        np.testing.assert_allclose(mesher.shapes(panels, angle), mesher.exact_shapes(angle),
                                   atol=tolerance)


def test_closure_and_fold_angle_are_checked():
    facade = load_facade('demonstrator_6x6')
    for bad in (1.5, -0.1, float('nan'), float('inf')):
        with pytest.raises(ValueError):
            folded_meshes(facade, closure=bad)
    with pytest.raises(ValueError, match='either closure or fold_angle_rad'):
        folded_meshes(facade)
    with pytest.raises(ValueError, match='either closure or fold_angle_rad'):
        folded_meshes(facade, closure=0.5, fold_angle_rad=0.5)
    with pytest.raises(ValueError):
        folded_meshes(facade, fold_angle_rad=3.0)
    with pytest.raises(ValueError, match='shape'):
        folded_meshes(facade, closure=[0.5, 0.5])
    meshes = folded_meshes(facade, fold_angle_rad=fold_angles(facade, closure=0.4))
    reference = folded_meshes(facade, closure=0.4)
    np.testing.assert_allclose(meshes[7].vertices_m, reference[7].vertices_m, atol=1e-12)


@pytest.mark.parametrize('name', ['demonstrator_6x6', 'hexagon_6x6'])
def test_a_welded_panel_is_one_sheet_without_open_crease(name):
    facade = load_facade(name)
    mesher = FacadeMesher(facade, vertex_budget=EXPORT_VERTEX_BUDGET)
    welded = folded_meshes(mesher, closure=0.7)
    loose = folded_meshes(mesher, closure=0.7, weld_vertices=False)
    for mesh, raw in zip(welded, loose):
        assert len(mesh.vertices_m) < len(raw.vertices_m)
        count = len(mesh.vertices_m)
        edges = np.concatenate([mesh.faces[:, [0, 1]], mesh.faces[:, [1, 2]],
                                mesh.faces[:, [2, 0]]])
        graph = coo_matrix((np.ones(len(edges)), tuple(edges.T)), shape=(count, count))
        assert connected_components(graph, directed=False)[0] == 1
        undirected = np.sort(edges, axis=1)
        _, uses = np.unique(undirected, axis=0, return_counts=True)
        assert uses.max() <= 2  # a manifold sheet: no edge shared by three triangles
        # each directed edge once: the welded triangles keep one orientation
        assert len(np.unique(edges, axis=0)) == len(edges)


def test_weld_merges_only_coincident_points():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 1e-9], [0, 0, 1e-3]], float)
    points, faces = weld(vertices, np.array([[0, 1, 2], [3, 2, 4], [1, 3, 2]]))
    assert len(points) == 4
    np.testing.assert_array_equal(faces, [[0, 1, 2], [1, 2, 3]])


def test_enu_maps_to_gltf_y_up():
    east, north, up = np.eye(3)
    np.testing.assert_allclose(enu_to_gltf(east), [1, 0, 0])
    np.testing.assert_allclose(enu_to_gltf(up), [0, 1, 0])  # glTF +Y up
    np.testing.assert_allclose(enu_to_gltf(north), [0, 0, -1])  # north is glTF -Z
    np.testing.assert_allclose(enu_to_gltf([[2.0, 3.0, 5.0]]), [[2.0, 5.0, -3.0]])
    matrix = enu_to_gltf(np.eye(3))
    assert np.linalg.det(matrix) == pytest.approx(1.0)  # a rotation: handedness kept
    # a Z-up importer's glTF -> Z-up turn, (x, y, z) -> (x, -z, y), gives back ENU
    x, y, z = enu_to_gltf([4.0, -7.0, 9.0])
    np.testing.assert_allclose([x, -z, y], [4.0, -7.0, 9.0])


def test_mesh_format_knows_three_suffixes():
    assert [mesh_format(p) for p in ('a.obj', 'b.GLB', 'c.gltf')] == ['obj', 'glb', 'gltf']
    for bad in ('a.stl', 'a', 'a.obj.txt'):
        with pytest.raises(ValueError, match='unknown suffix'):
            mesh_format(bad)


@pytest.mark.parametrize('surface, grid, tolerance_m', [
    ('{type: plane, width_m: 4.4, height_m: 3.3}', '{rows: 3, columns: 4, gap_m: 0.1}', 1e-9),
    ('{type: cylinder, width_m: 4.4, height_m: 3.3, radius_m: 10.0}',
     '{rows: 3, columns: 4, gap_m: 0.1, midrib_along: u}', 0.02),
])
def test_surface_quads_read_back_to_the_same_panels(tmp_path, surface, grid, tolerance_m):
    text = FLAT_EAST.replace('{type: plane, width_m: 2.2, height_m: 1.1}', surface).replace(
        '{rows: 1, columns: 2, gap_m: 0.1, midrib_along: v}', grid).replace(
        'min_prefold_rad: 0.0, max_moulded_prefold_rad: 0.0', 'min_prefold_rad: 0.05')
    (tmp_path / 'parametric.yaml').write_text(text)
    vertices, quads = surface_quads(tmp_path / 'parametric.yaml')
    write_quad_obj(vertices, quads, tmp_path / 'quads.obj')
    midrib = 'u' if 'midrib_along: u' in grid else 'v'
    (tmp_path / 'from_obj.yaml').write_text(text.replace(surface, '{type: obj, path: quads.obj}')
                                            .replace(grid, f'{{gap_m: 0.1, midrib_along: '
                                                           f'{midrib}}}'))
    original = load_facade(tmp_path / 'parametric.yaml')
    again = load_facade(tmp_path / 'from_obj.yaml')
    assert again.panel_ids == original.panel_ids
    offset = np.linalg.norm(again.origin_m - original.origin_m, axis=1)
    assert offset.max() < tolerance_m
    sizes = [(p.length_m, p.width_m) for p in original.panels]
    np.testing.assert_allclose([(p.length_m, p.width_m) for p in again.panels], sizes,
                               atol=tolerance_m)


def test_hexagon_facades_have_no_surface_quads():
    with pytest.raises(ValueError, match='hexagon'):
        surface_quads('hexagon_6x6')
