"""Folded hexagonal meshes: developable, mirrored, creased where the model says, symmetric."""

import math

import numpy as np
import pytest

from flectofold_model import HEXAGON_MODULE, HexagonBatch, HexagonFoldModel, HexagonPanel
from flectofold_model.kinematics.hexagon_mesh import (DEFAULT_HEXAGON_TOPOLOGY,
                                                      flat_coordinates, hexagon_mesh,
                                                      HexagonTopology)
from flectofold_model.kinematics.hexagon_panel import hexagon_radius_m
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry

CLOSURES = np.array([0.0, 0.4, 0.8, 1.0])
TOPOLOGY = HexagonTopology(rulings_per_sector=10, rings=3, flap_columns=5)


@pytest.fixture(scope='module')
def model():
    panels = [HEXAGON_MODULE,
              HexagonPanel(circumradius_m=0.45, fold_line_sag_m=0.03, hinge_width_m=0.02,
                           prefold_rad=math.radians(4.0))]
    return HexagonFoldModel(HexagonBatch.from_panels(panels))


def edges(faces):
    return np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]],
                                             faces[:, [2, 0]]]), axis=1), axis=0)


def flap_grid(topology, index):
    block = topology.flap(index)
    return np.arange(block.start, block.stop).reshape(topology.rulings_per_sector + 1, -1)


def cone_grid(topology):
    return 1 + np.arange(3 * topology.rulings_per_sector * topology.rings).reshape(
        3 * topology.rulings_per_sector, topology.rings)


def plane_from_mesh(vertices, topology, index):
    """Plane through the crease's ends and apex, read off flap ``index`` of the mesh alone."""
    crease = flap_grid(topology, index)[:, 0]
    first, apex, last = (vertices[:, crease[i]] for i in (0, len(crease) // 2, -1))
    normal = np.cross(last - first, apex - first)
    normal *= np.sign(normal[:, 2:3]) / np.linalg.norm(normal, axis=-1, keepdims=True)
    return normal, np.einsum('ij,ij->i', normal, first)


@pytest.mark.parametrize('closure', CLOSURES)
def test_every_edge_keeps_its_flat_length(model, closure):
    rise = model.state_from_closure(closure).centre_rise_m
    mesh = hexagon_mesh(model.batch, rise, TOPOLOGY)
    flat = flat_coordinates(model.batch, rise, TOPOLOGY)
    pairs = edges(mesh.faces)
    folded = np.linalg.norm(np.diff(mesh.vertices[:, pairs], axis=2)[:, :, 0], axis=-1)
    unfolded = np.linalg.norm(np.diff(flat[:, pairs], axis=2)[:, :, 0], axis=-1)
    np.testing.assert_allclose(folded, unfolded, rtol=1e-12, atol=1e-15)


def test_flat_pattern_is_the_whole_hexagon(model):
    flat = flat_coordinates(model.batch, model.open_rise_m, TOPOLOGY)
    faces = TOPOLOGY.faces
    a, b, c = (flat[:, faces[:, i]] for i in range(3))
    area = ((b - a)[..., 0] * (c - a)[..., 1] - (b - a)[..., 1] * (c - a)[..., 0]) / 2
    assert np.all(area > 0), 'every face winds counter-clockwise and has an area'
    hexagon_area = 1.5 * math.sqrt(3.0) * model.batch.circumradius_m ** 2
    np.testing.assert_allclose(area.sum(axis=-1), hexagon_area, rtol=1e-12)
    edge = flap_grid(TOPOLOGY, 1)[:, -1]
    azimuth = np.arctan2(flat[:, edge, 1], flat[:, edge, 0]) - math.radians(210.0)
    np.testing.assert_allclose(np.hypot(flat[:, edge, 0], flat[:, edge, 1]),
                               hexagon_radius_m(model.batch.circumradius_m[:, None],
                                                np.mod(azimuth, 2 * math.pi)), rtol=1e-12)


@pytest.mark.parametrize('closure', CLOSURES[1:])
def test_crease_lies_in_the_plane_and_each_flap_mirrors_the_cone(model, closure):
    rise = model.state_from_closure(closure).centre_rise_m
    vertices = hexagon_mesh(model.batch, rise, TOPOLOGY).vertices
    centre = vertices[:, 0]
    np.testing.assert_allclose(centre, np.stack([0 * rise, 0 * rise, rise], -1), atol=1e-15)
    for index in range(3):
        normal, offset = plane_from_mesh(vertices, TOPOLOGY, index)
        grid = flap_grid(TOPOLOGY, index)
        on_plane = np.einsum('nvi,ni->nv', vertices[:, grid[:, 0]], normal) - offset[:, None]
        np.testing.assert_allclose(on_plane, 0.0, atol=1e-12)
        # Mirrored back, every flap vertex lies on its ruling: the line from the centre
        # through the crease vertex of that ruling.
        points = vertices[:, grid]
        distance = np.einsum('nrci,ni->nrc', points, normal) - offset[:, None, None]
        unfolded = points - 2 * distance[..., None] * normal[:, None, None]
        ruling = unfolded[:, :, 0] - centre[:, None]
        ruling /= np.linalg.norm(ruling, axis=-1, keepdims=True)
        along = unfolded - centre[:, None, None]
        off_ruling = np.cross(along, ruling[:, :, None])
        np.testing.assert_allclose(off_ruling, 0.0, atol=1e-12)
        assert np.all(np.sum(along * ruling[:, :, None], axis=-1) > 0)


@pytest.mark.parametrize('closure', CLOSURES[1:])
def test_mesh_dihedral_at_the_apex_matches_the_model(model, closure):
    state = model.state_from_closure(closure)
    errors = []
    for rulings in (8, 16, 32):
        topology = HexagonTopology(rulings_per_sector=rulings, rings=2, flap_columns=3)
        vertices = hexagon_mesh(model.batch, state.centre_rise_m, topology).vertices
        apex = flap_grid(topology, 0)[rulings // 2]
        cone_ring = cone_grid(topology)[rulings // 2 - 1: rulings // 2 + 2, -1]
        # Cone facet normal beside the apex and the flap facet mirrored across the crease.
        crease = vertices[:, cone_ring[2]] - vertices[:, cone_ring[0]]
        inner = vertices[:, 0] - vertices[:, apex[0]]
        outer = vertices[:, apex[1]] - vertices[:, apex[0]]
        cone_normal = np.cross(crease, inner)
        flap_normal = np.cross(outer, crease)
        cosine = np.sum(cone_normal * flap_normal, -1) / (
            np.linalg.norm(cone_normal, axis=-1) * np.linalg.norm(flap_normal, axis=-1))
        errors.append(np.max(np.abs(np.arccos(np.clip(cosine, -1, 1))
                                    - state.apex_fold_angle_rad)))
    assert errors[-1] < math.radians(0.5)
    assert errors[2] < errors[0]


def test_three_fold_symmetry(model):
    rise = model.state_from_closure(0.6).centre_rise_m
    vertices = hexagon_mesh(model.batch, rise, TOPOLOGY).vertices
    turn = np.array([[-0.5, -math.sqrt(3) / 2, 0.0], [math.sqrt(3) / 2, -0.5, 0.0], [0, 0, 1]])
    for index in range(3):
        following = flap_grid(TOPOLOGY, (index + 1) % 3)
        np.testing.assert_allclose(vertices[:, flap_grid(TOPOLOGY, index)] @ turn.T,
                                   vertices[:, following], atol=1e-12)


def test_spoke_ends_are_the_vertices_moved_in_by_pythagoras(model):
    state = model.state_from_closure(0.9)
    vertices = hexagon_mesh(model.batch, state.centre_rise_m, TOPOLOGY).vertices
    spoke_end = cone_grid(TOPOLOGY)[0, -1]
    np.testing.assert_allclose(vertices[:, spoke_end, :2],
                               np.stack([0 * state.centre_rise_m,
                                         model.batch.circumradius_m
                                         - state.vertex_displacement_m], -1), atol=1e-12)
    np.testing.assert_allclose(vertices[:, spoke_end, 2], 0.0, atol=1e-12)


def test_mesh_tip_converges_to_the_model_tip(model):
    state = model.state_from_closure(0.7)
    tip = SectorGeometry(model.batch, state.centre_rise_m).flap_tip
    gaps = []
    for rulings in (6, 24):
        topology = HexagonTopology(rulings_per_sector=rulings, rings=1, flap_columns=2)
        vertices = hexagon_mesh(model.batch, state.centre_rise_m, topology).vertices
        gaps.append(np.max(np.linalg.norm(vertices[:, flap_grid(topology, 0)[rulings // 2, -1]]
                                          - tip, axis=-1)))
    assert gaps[1] < 2e-3 and gaps[1] < gaps[0] / 4


def test_normals_are_unit_and_agree_with_the_winding(model):
    mesh = hexagon_mesh(model.batch, model.state_from_closure(0.5).centre_rise_m, TOPOLOGY)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=-1), 1.0, rtol=1e-12)
    a, b, c = (mesh.vertices[:, mesh.faces[:, i]] for i in range(3))
    face_normal = np.cross(b - a, c - a)
    face_normal /= np.linalg.norm(face_normal, axis=-1, keepdims=True)
    agreement = np.einsum('nfi,nfvi->nfv', face_normal, mesh.normals[:, mesh.faces])
    assert np.min(agreement) > 0.9


def test_batch_float32_and_refill_agree(model):
    rise = model.state_from_closure(np.array([0.3, 0.8])).centre_rise_m
    together = hexagon_mesh(model.batch, rise)
    alone = hexagon_mesh(model.batch.take([1]), rise[1:])
    np.testing.assert_allclose(together.vertices[1], alone.vertices[0], atol=1e-15)
    single = hexagon_mesh(model.batch, rise, dtype=np.float32)
    assert single.vertices.dtype == np.float32
    np.testing.assert_allclose(single.vertices, together.vertices, atol=1e-6)
    refilled = hexagon_mesh(model.batch, rise[::-1], out=together)
    assert refilled.vertices is together.vertices
    np.testing.assert_allclose(refilled.vertices[0], hexagon_mesh(
        model.batch.take([0]), rise[1:]).vertices[0], atol=1e-15)
    assert model.mesh(rise).vertices.shape == (2, DEFAULT_HEXAGON_TOPOLOGY.vertex_count, 3)


@pytest.mark.parametrize('arguments, message', [
    ({'rulings_per_sector': 7}, 'must be even'),
    ({'rulings_per_sector': 0}, 'at least 2'),
    ({'rings': 0}, 'at least 1'),
    ({'flap_columns': 1.5}, 'must be an integer'),
])
def test_bad_resolution_is_refused(arguments, message):
    values = {'rulings_per_sector': 4, 'rings': 2, 'flap_columns': 3, **arguments}
    with pytest.raises(ValueError, match=message):
        HexagonTopology(**values)


def test_topology_counts():
    topology = DEFAULT_HEXAGON_TOPOLOGY
    assert topology.vertex_count == 1 + 3 * 12 * 4 + 3 * 13 * 8
    assert topology.faces.max() == topology.vertex_count - 1
    unused = np.setdiff1d(np.arange(topology.vertex_count), topology.faces)
    # Only vertices of the rows where a flap narrows to a point (all at that point) go unused.
    spoke_rows = np.concatenate([flap_grid(topology, i)[[0, -1]].ravel() for i in range(3)])
    assert unused.size and np.all(np.isin(unused, spoke_rows))
