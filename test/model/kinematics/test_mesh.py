"""Folded meshes: developable, mirrored, creased where the model says, and consistent."""

import numpy as np
import pytest

from flectofold_model import (DEMONSTRATOR_MODULE, fold_mesh, FoldModel, MeshTopology, PanelBatch,
                              PanelGeometry, PROTOTYPE)
from flectofold_model.kinematics import reflection
from flectofold_model.kinematics.mesh import flat_coordinates

CLOSURES = np.array([0.0, 0.35, 0.8, 1.0])


@pytest.fixture(scope='module')
def model():
    panels = [PROTOTYPE, DEMONSTRATOR_MODULE,
              PanelGeometry.with_lens_midrib(0.52, 0.42, 0.5, 0.02, 0.02, prefold_rad=0.1),
              PanelGeometry(length_m=0.8, width_m=0.5, fold_radius_m=1.5, midrib_width_m=0.15,
                            hinge_width_m=0.02)]
    return FoldModel(PanelBatch.from_panels(panels))


def column(topology, block, index):
    """Vertex indices of one column of a block, one per station."""
    columns = topology.midrib_columns if block == 'midrib' else topology.flap_columns
    vertex_slice = topology.midrib if block == 'midrib' else topology.flap(block)
    return np.arange(vertex_slice.start, vertex_slice.stop).reshape(-1, columns)[:, index]


def edges(faces):
    return np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]],
                                             faces[:, [2, 0]]]), axis=1), axis=0)


def face_normals(vertices, faces):
    a, b, c = (vertices[:, faces[:, i]] for i in range(3))
    normal = np.cross(b - a, c - a)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


def three_point_plane(vertices, crease, side):
    """Plane through crease end C', crease end E and apex M', read off the mesh alone."""
    end_c, end_e, apex = (vertices[:, crease[i]] for i in (-1, 0, len(crease) // 2))
    normal = np.cross(end_e - end_c, apex - end_c)
    normal *= np.sign(normal[:, 2:3]) / np.linalg.norm(normal, axis=-1, keepdims=True)
    return normal, np.einsum('ij,ij->i', normal, end_c)


@pytest.mark.parametrize('closure', CLOSURES)
def test_every_edge_keeps_its_flat_length(model, closure):
    state = model.state_from_closure(closure)
    topology = MeshTopology(15, 5, 9)
    mesh = fold_mesh(model.batch, state.elastica_k, topology)
    flat = flat_coordinates(model.batch, state.elastica_k, topology)
    pairs = edges(mesh.faces)
    folded = np.linalg.norm(np.diff(mesh.vertices[:, pairs], axis=2)[:, :, 0], axis=-1)
    unfolded = np.linalg.norm(np.diff(flat[:, pairs], axis=2)[:, :, 0], axis=-1)
    np.testing.assert_allclose(folded, unfolded, rtol=1e-12)


def test_flat_pattern_converges_to_the_sheet(model):
    state = model.state_from_closure(1.0)
    errors = []
    for stations in (11, 41, 161):
        flat = flat_coordinates(model.batch, state.elastica_k, MeshTopology(stations, 3, 3))
        errors.append(np.max(np.abs(2 * flat[:, :, 0].max(axis=1) - model.batch.length_m)))
        np.testing.assert_allclose(np.abs(flat[:, :, 1]).max(axis=1), model.batch.width_m / 2)
    assert errors[2] < 1e-5 and errors[1] < errors[0] / 10 and errors[2] < errors[1] / 10


@pytest.mark.parametrize('closure', CLOSURES)
def test_crease_lies_in_the_three_point_plane_and_flaps_mirror_the_midrib(model, closure):
    state = model.state_from_closure(closure)
    topology = MeshTopology(21, 7, 11)
    vertices = fold_mesh(model.batch, state.elastica_k, topology).vertices
    midrib = vertices[:, topology.midrib].reshape(len(model), topology.stations, -1, 3)
    for side, midrib_column in ((+1, -1), (-1, 0)):
        crease = column(topology, 'midrib', midrib_column)
        np.testing.assert_allclose(vertices[:, column(topology, side, 0)], vertices[:, crease],
                                   atol=1e-15)
        normal, offset = three_point_plane(vertices, crease, side)
        distance = np.einsum('nvi,ni->nv', vertices[:, crease], normal) - offset[:, None]
        np.testing.assert_allclose(distance, 0.0, atol=1e-12)
        flap = vertices[:, topology.flap(side)].reshape(len(model), topology.stations, -1, 3)
        back = reflection.reflect(flap, normal[:, None, None, :], offset[:, None, None])
        # Mirrored back, a flap row lies on the extended mid-rib cylinder of its station.
        np.testing.assert_allclose(back[..., 0], np.broadcast_to(midrib[:, :, :1, 0],
                                                                 back.shape[:-1]), atol=1e-12)
        np.testing.assert_allclose(back[..., 2], np.broadcast_to(midrib[:, :, :1, 2],
                                                                 back.shape[:-1]), atol=1e-12)
        assert np.all(side * back[..., 1] >= side * midrib[:, :, :1, 1] - 1e-12)


@pytest.mark.parametrize('closure', [0.2, 0.6, 1.0])
def test_mesh_dihedral_matches_the_model_fold_angle_along_the_crease(model, closure):
    state = model.state_from_closure(closure)
    errors = []
    for stations in (21, 81):
        topology = MeshTopology(stations, 5, 5)
        mesh = fold_mesh(model.batch, state.elastica_k, topology)
        normals = face_normals(mesh.vertices, mesh.faces)
        crease = column(topology, 'midrib', -1)
        flap_crease = column(topology, +1, 0)
        fraction = (topology.station_fractions[:-1] + topology.station_fractions[1:]) / 2
        expected = reflection.fold_angle_along_crease(
            model.batch, state.elastica_k, state.midrib_sag_m,
            model.batch.length_m[:, None] * fraction)
        measured = np.empty_like(expected)
        for i in range(stations - 1):
            midrib_face = _face_with(mesh.faces, crease[i], crease[i + 1])
            flap_face = _face_with(mesh.faces, flap_crease[i], flap_crease[i + 1])
            cosine = np.sum(normals[:, midrib_face] * normals[:, flap_face], axis=-1)
            measured[:, i] = np.arccos(np.clip(cosine, -1, 1))
        errors.append(np.max(np.abs(measured - expected)))
    assert errors[1] < np.radians(0.01)
    assert errors[1] < errors[0] / 8  # second-order convergence: the gap is discretisation


def _face_with(faces, a, b):
    hits = np.flatnonzero(np.any(faces == a, axis=1) & np.any(faces == b, axis=1))
    assert len(hits) == 1
    return hits[0]


@pytest.mark.parametrize('closure', CLOSURES)
def test_flaps_are_symmetric(model, closure):
    state = model.state_from_closure(closure)
    topology = MeshTopology(9, 3, 6)
    vertices = fold_mesh(model.batch, state.elastica_k, topology).vertices
    np.testing.assert_allclose(vertices[:, topology.flap(-1)],
                               vertices[:, topology.flap(+1)] * [1, -1, 1], atol=1e-15)


def test_normals_are_unit_and_agree_with_the_winding(model):
    state = model.state_from_closure(np.array([0.0, 0.5, 0.9, 1.0]))
    mesh = fold_mesh(model.batch, state.elastica_k, MeshTopology(31, 5, 9))
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=-1), 1.0, atol=1e-12)
    winding = face_normals(mesh.vertices, mesh.faces)
    vertex = mesh.normals[:, mesh.faces].mean(axis=2)
    vertex /= np.linalg.norm(vertex, axis=-1, keepdims=True)
    assert np.min(np.sum(winding * vertex, axis=-1)) > 0.999


def test_no_prefold_and_no_displacement_is_flat():
    panel = PanelGeometry.with_lens_midrib(0.52, 0.42, 0.75, 0.02, 0.015)
    fold_model = FoldModel(PanelBatch.from_panels([panel]))
    mesh = fold_mesh(fold_model.batch, fold_model.state_from_displacement(0.0).elastica_k)
    np.testing.assert_allclose(mesh.vertices[..., 2], 0.0, atol=1e-15)
    np.testing.assert_allclose(mesh.normals, np.broadcast_to([0, 0, 1], mesh.normals.shape),
                               atol=1e-15)
    assert np.allclose(np.abs(mesh.vertices[..., 1]).max(), 0.21)


def test_closed_flaps_stop_at_the_clearance(model):
    """At closure 1 the flaps come exactly to the clearance, and nowhere nearer before."""
    half_gap = model.batch.closed_clearance_m / 2
    for closure in np.linspace(0.0, 1.0, 11):
        state = model.state_from_closure(closure)
        mesh = fold_mesh(model.batch, state.elastica_k)
        nearest = np.abs(mesh.vertices[..., 1]).min(axis=1, initial=np.inf,
                                                    where=_flap_mask(len(model)))
        assert np.all(nearest >= half_gap - 1e-12)
    np.testing.assert_allclose(nearest, half_gap, atol=1e-12)


def _flap_mask(count):
    topology = MeshTopology(21, 7, 17)
    mask = np.ones((count, topology.vertex_count), dtype=bool)
    mask[:, topology.midrib] = False
    return mask


def test_tip_a_is_the_flap_edge_vertex_at_mid_span(model):
    state = model.state_from_closure(0.6)
    topology = MeshTopology(21, 7, 17)
    vertices = fold_mesh(model.batch, state.elastica_k, topology).vertices
    edge = column(topology, +1, -1)
    np.testing.assert_allclose(vertices[:, edge[10]],
                               reflection.flap_tip(model.batch, state.midrib_sag_m, +1),
                               atol=1e-15)


def test_batch_mesh_equals_meshes_one_at_a_time(model):
    state = model.state_from_closure(np.array([0.1, 0.4, 0.7, 1.0]))
    together = fold_mesh(model.batch, state.elastica_k)
    for index in range(len(model)):
        alone = fold_mesh(model.batch.take([index]), state.elastica_k[index:index + 1])
        np.testing.assert_array_equal(together.vertices[index], alone.vertices[0])
        np.testing.assert_array_equal(together.normals[index], alone.normals[0])


def test_float32_output_matches(model):
    state = model.state_from_closure(0.5)
    wide = fold_mesh(model.batch, state.elastica_k)
    narrow = fold_mesh(model.batch, state.elastica_k, dtype=np.float32)
    assert narrow.vertices.dtype == np.float32
    np.testing.assert_allclose(narrow.vertices, wide.vertices, atol=1e-6)


@pytest.mark.parametrize('arguments, message', [
    ((1, 5, 5), 'stations must be an integer of at least 2'),
    ((5, 1.5, 5), 'midrib_columns must be an integer'),
    ((5, 5, True), 'flap_columns must be an integer'),
])
def test_bad_resolution_is_refused(arguments, message):
    with pytest.raises(ValueError, match=message):
        MeshTopology(*arguments)


def test_topology_counts():
    topology = MeshTopology(21, 7, 17)
    assert topology.vertex_count == 861
    assert topology.faces.shape == (2 * 20 * (6 + 2 * 16), 3)
    assert topology.faces.min() == 0 and topology.faces.max() == 860


def test_refilling_a_previous_mesh_gives_the_same_result(model):
    first = fold_mesh(model.batch, model.state_from_closure(0.2).elastica_k)
    state = model.state_from_closure(0.9)
    refilled = fold_mesh(model.batch, state.elastica_k, out=first)
    assert refilled.vertices is first.vertices
    fresh = fold_mesh(model.batch, state.elastica_k)
    np.testing.assert_array_equal(refilled.vertices, fresh.vertices)
    np.testing.assert_array_equal(refilled.normals, fresh.normals)
    with pytest.raises(ValueError, match='needs float32 arrays'):
        fold_mesh(model.batch, state.elastica_k, dtype=np.float32, out=first)
    with pytest.raises(TypeError, match='out must be a FoldMesh'):
        fold_mesh(model.batch, state.elastica_k, out=first.vertices)
