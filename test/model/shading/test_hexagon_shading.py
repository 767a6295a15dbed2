"""Shading and view of hexagonal panels: the ray casting against independent geometry."""

import math

import numpy as np
import pytest
from shadow_area import blocked_share, hexagon_footprint

from flectofold_model.kinematics.hexagon_closure import HexagonFoldModel
from flectofold_model.kinematics.hexagon_mesh import HexagonTopology
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonBatch, HexagonPanel
from flectofold_model.kinematics.mesh import MeshTopology
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch
from flectofold_model.shading.hexagon_tiling import SIDE_NORMALS
from flectofold_model.shading.ray_casting import (blocked_fraction, closure_for_shading,
                                                  DEFAULT_STANDOFF_M, HEXAGON_SHADING_TOPOLOGY,
                                                  view_fraction)
from flectofold_model.shading.table import ShadingTable

#: Nearly flat: the smallest pre-fold the model takes, so closure 0 is all but the flat sheet.
NEARLY_FLAT = HexagonPanel(circumradius_m=0.62, fold_line_sag_m=0.06, hinge_width_m=0.03,
                           prefold_rad=1e-3)
SMALL = HexagonPanel(circumradius_m=0.35, fold_line_sag_m=0.03, hinge_width_m=0.02,
                     prefold_rad=math.radians(8.0))
SAMPLES = 12
#: Largest error of the default scan lines against the exact shadow area over the cases of
#: bench/bench_shading_accuracy.py is 0.0037 (msg_docs/scheduling.md); the tests allow 0.005.
TOLERANCE = 0.005


def toward(off_normal_deg, azimuth_deg=0.0):
    """Sun vector ``off_normal_deg`` from the facade normal, leaning toward the azimuth."""
    off, azimuth = math.radians(off_normal_deg), math.radians(azimuth_deg)
    return np.array([math.sin(off) * math.cos(azimuth), math.sin(off) * math.sin(azimuth),
                     math.cos(off)])


def model_of(*panels):
    return HexagonFoldModel(HexagonBatch.from_panels(panels))


def rise_at(model, closure):
    return model.state_from_closure(closure).shape_parameter


@pytest.fixture(scope='module')
def module():
    return model_of(HEXAGON_MODULE)


@pytest.fixture(scope='module')
def flat():
    return model_of(NEARLY_FLAT)


def hexagon_corners(radius_m, centre=(0.0, 0.0)):
    angles = np.radians(30.0 + 60.0 * np.arange(6))
    return np.column_stack([centre[0] + radius_m * np.cos(angles),
                            centre[1] + radius_m * np.sin(angles)])


def clip(polygon, convex):
    """Sutherland-Hodgman: ``polygon`` clipped by the counter-clockwise convex polygon."""
    for a, b in zip(convex, np.roll(convex, -1, axis=0)):
        edge = b - a

        def inside(p):
            return edge[0] * (p[1] - a[1]) - edge[1] * (p[0] - a[0]) >= 0.0
        result = []
        for p, q in zip(polygon, np.roll(polygon, -1, axis=0)):
            if inside(q):
                if not inside(p):
                    result.append(_crossing(p, q, a, edge))
                result.append(q)
            elif inside(p):
                result.append(_crossing(p, q, a, edge))
        polygon = np.array(result)
    return polygon


def _crossing(p, q, a, edge):
    d = q - p
    t = (edge[0] * (a[1] - p[1]) - edge[1] * (a[0] - p[0])) / (edge[0] * d[1] - edge[1] * d[0])
    return p + t * d


def area(polygon):
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def former_ray_grid(samples, radius_m):
    """(S, 2) ray origins of the former sampling [m]: centroids of 6 n**2 equal triangles.

    Each of the hexagon's six triangles (centre, corner j, corner j + 1) cut into n**2 by n
    equal steps along its sides, ``n = round(samples / sqrt 6)``: 600 rays for 24.
    """
    n = max(1, round(samples / math.sqrt(6.0)))
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing='ij')
    up, down = (i + j <= n - 1), (i + j <= n - 2)
    a = np.concatenate([(i[up] + 1 / 3) / n, (i[down] + 2 / 3) / n])
    b = np.concatenate([(j[up] + 1 / 3) / n, (j[down] + 2 / 3) / n])
    corner = hexagon_corners(radius_m)
    following = np.roll(corner, -1, axis=0)
    return (a[None, :, None] * corner[:, None, :]
            + b[None, :, None] * following[:, None, :]).reshape(-1, 2)


def brute_force_blocked(vertices, faces, radius_m, sun, points_m, tessellated, copies=6):
    """Blocked share of the footprint rays by plain float64 Moller-Trumbore with ``t > 0``.

    Every ray from the points ``points_m`` (S, 2) of the footprint is tested against every
    triangle of the mesh and of its copies on the hexagonal lattice
    ``i (sqrt3 R, 0) + j (sqrt3 R / 2, 3 R / 2)``, ``|i|, |j| <= copies``: no culling, no
    cells, no affine factors.
    """
    origins = np.column_stack([points_m, np.full(len(points_m), -DEFAULT_STANDOFF_M)])
    triangles = vertices[faces]
    e1 = triangles[:, 1] - triangles[:, 0]
    e2 = triangles[:, 2] - triangles[:, 0]
    p = np.cross(sun, e2)
    det = np.einsum('fi,fi->f', e1, p)
    facing = np.abs(det) > 1e-15
    inverse = np.where(facing, 1.0 / np.where(facing, det, 1.0), 0.0)
    hit = np.zeros(len(origins), dtype=bool)
    offsets = [(i, j) for i in range(-copies, copies + 1)
               for j in range(-copies, copies + 1)] if tessellated else [(0, 0)]
    for i, j in offsets:
        shift = np.array([math.sqrt(3.0) * radius_m * (i + j / 2), 1.5 * radius_m * j, 0.0])
        to_origin = origins[:, None, :] - (triangles[:, 0] + shift)[None]
        u = np.einsum('rfi,fi->rf', to_origin, p) * inverse
        q = np.cross(to_origin, e1[None])
        v = np.einsum('rfi,i->rf', q, sun) * inverse
        t = np.einsum('rfi,fi->rf', q, e2) * inverse
        hit |= np.any(facing & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0), axis=1)
    return hit.mean()


def exact_share(module, rise, sun, tessellated=True):
    """Blocked share of HEXAGON_MODULE from the exact area of its (and its copies') shadows."""
    mesh = module.mesh(rise, HEXAGON_SHADING_TOPOLOGY)
    return blocked_share(mesh.vertices[0], mesh.faces,
                         hexagon_footprint(HEXAGON_MODULE.circumradius_m), sun,
                         DEFAULT_STANDOFF_M, tessellated)


@pytest.mark.parametrize('closure, off_normal_deg, azimuth_deg', [
    (1.0, 40.0, 30.0), (0.5, 70.0, 200.0), (0.75, 70.0, 90.0)])
def test_the_exact_area_agrees_with_an_independent_ray_triangle_caster(
        module, closure, off_normal_deg, azimuth_deg):
    """The reference of these tests against plain ray casting from many random points."""
    rng = np.random.default_rng(11)
    radius = HEXAGON_MODULE.circumradius_m
    points = rng.uniform(-radius, radius, (6000, 2))
    inside = np.all(np.abs(points @ SIDE_NORMALS.T) <= math.sqrt(3.0) / 2 * radius, axis=1)
    points = points[inside][:3000]
    sun = toward(off_normal_deg, azimuth_deg)
    rise = rise_at(module, closure)
    mesh = module.mesh(rise, HEXAGON_SHADING_TOPOLOGY)
    cast = brute_force_blocked(mesh.vertices[0], mesh.faces, radius, sun, points, True,
                               copies=3)
    # 3,000 random rays: a standard error of at most 0.009.
    assert cast == pytest.approx(exact_share(module, rise, sun), abs=0.03)


@pytest.mark.parametrize('sun', [(0.0, 0.0, -1.0), toward(120.0, 30.0), toward(179.0, 250.0),
                                 (1.0, 0.0, 0.0), (0.0, -1.0, 0.0)])
def test_no_direct_sun_from_behind_or_along_the_facade(module, sun):
    for closure in (0.0, 0.5, 1.0):
        shading = blocked_fraction(module.batch, rise_at(module, closure), sun)
        assert not shading.sunlit.any()
        np.testing.assert_array_equal(shading.blocked_fraction, 0.0)


@pytest.mark.parametrize('off_normal_deg, azimuth_deg', [
    (0, 0), (30, 0), (60, 90), (45, 37), (75, 200), (85, 300)])
def test_a_nearly_flat_facade_blocks_all_direct_sun(flat, off_normal_deg, azimuth_deg):
    shading = blocked_fraction(flat.batch, rise_at(flat, 0.0), toward(off_normal_deg,
                                                                      azimuth_deg))
    assert shading.blocked_fraction[0] == 1.0  # not one ray between the hexagons


def test_a_nearly_flat_hexagon_covers_its_own_aperture_along_the_normal(flat):
    rise = rise_at(flat, 0.0)
    lone = blocked_fraction(flat.batch, rise, toward(0.0), tessellated=False)
    assert lone.blocked_fraction[0] == 1.0
    assert view_fraction(flat.batch, rise)[0] == 0.0


@pytest.mark.parametrize('off_normal_deg, azimuth_deg', [(60, 0), (60, 90), (45, 200),
                                                         (70, 330)])
def test_a_lone_flat_hexagon_lets_oblique_sun_past_its_edges(flat, off_normal_deg, azimuth_deg):
    """Analytic: the footprint rays that meet the sheet start in the hexagon shifted back.

    The sheet lies at z ~ 0, so a footprint point p is blocked iff p + standoff tan(theta) u
    lies in the hexagon: the blocked share is the overlap of the hexagon with its copy
    shifted by that run, over its area (polygon clipping).
    """
    sun = toward(off_normal_deg, azimuth_deg)
    radius = NEARLY_FLAT.circumradius_m
    blocked = blocked_fraction(flat.batch, rise_at(flat, 0.0), sun, tessellated=False,
                               samples=24).blocked_fraction[0]
    run = DEFAULT_STANDOFF_M * sun[:2] / sun[2]
    hexagon = hexagon_corners(radius)
    expected = area(clip(hexagon_corners(radius, -run), hexagon)) / area(hexagon)
    assert expected < 0.95
    # The overlap's outline runs across the scan lines: measured all but exactly (600 rays
    # of the former sampling resolved it to ~0.01).
    assert blocked == pytest.approx(expected, abs=1e-3)


def test_view_opens_and_normal_sun_gets_through_as_the_panel_closes(module):
    closures = np.linspace(0.0, 1.0, 11)
    views = np.array([view_fraction(module.batch, rise_at(module, c))[0] for c in closures])
    normal = np.array([blocked_fraction(module.batch, rise_at(module, c), toward(0.0))
                       .blocked_fraction[0] for c in closures])
    np.testing.assert_allclose(views, 1.0 - normal, atol=1e-15)
    assert np.all(np.diff(views) >= 0.0)
    assert views[0] < 0.01
    assert views[-1] > 0.3
    assert views[-1] > views[2] + 0.2


@pytest.mark.parametrize('azimuth_deg', [0.0, 90.0, 210.0])
def test_standing_flaps_block_grazing_sun(module, azimuth_deg):
    rise = rise_at(module, 1.0)
    normal = blocked_fraction(module.batch, rise, toward(0.0)).blocked_fraction[0]
    grazing = blocked_fraction(module.batch, rise, toward(85.0, azimuth_deg)).blocked_fraction[0]
    assert grazing > normal + 0.3


@pytest.mark.parametrize('closure, off_normal_deg, azimuth_deg', [
    (0.0, 30.0, 0.0), (0.5, 0.0, 0.0), (0.5, 60.0, 90.0), (0.5, 80.0, 45.0),
    (1.0, 0.0, 0.0), (1.0, 70.0, 200.0), (1.0, 45.0, 300.0), (0.3, 85.0, 150.0)])
@pytest.mark.parametrize('tessellated', [True, False])
def test_agrees_with_the_exact_shadow_area(module, closure, off_normal_deg, azimuth_deg,
                                           tessellated):
    sun = toward(off_normal_deg, azimuth_deg)
    rise = rise_at(module, closure)
    blocked = blocked_fraction(module.batch, rise, sun,
                               tessellated=tessellated).blocked_fraction[0]
    assert blocked == pytest.approx(exact_share(module, rise, sun, tessellated), abs=TOLERANCE)


@pytest.mark.parametrize('closure, off_normal_deg, azimuth_deg', [
    (0.75, 70.0, 90.0), (0.75, 70.0, 210.0), (0.75, 70.0, 330.0)])
def test_oblique_sun_is_within_a_hundredth_of_the_exact_area(module, closure, off_normal_deg,
                                                             azimuth_deg):
    """Hard cases for a fixed set of points: the former 600 rays erred by more than 0.02.

    Their blocked share is found here by the independent caster at those rays.
    """
    sun = toward(off_normal_deg, azimuth_deg)
    rise = rise_at(module, closure)
    blocked = blocked_fraction(module.batch, rise, sun).blocked_fraction[0]
    expected = exact_share(module, rise, sun)
    assert abs(blocked - expected) < 0.01
    mesh = module.mesh(rise, HEXAGON_SHADING_TOPOLOGY)
    radius = HEXAGON_MODULE.circumradius_m
    former = brute_force_blocked(mesh.vertices[0], mesh.faces, radius, sun,
                                 former_ray_grid(24, radius), True, copies=3)
    assert abs(former - expected) > 0.02


@pytest.mark.parametrize('off_normal_deg, azimuth_deg', [(40, 30), (65, 100), (80, 200)])
@pytest.mark.parametrize('closure', [0.4, 1.0])
def test_mirrored_and_turned_sun_blocks_the_same(module, off_normal_deg, azimuth_deg, closure):
    """The panel is symmetric about its y axis and under turns of 120 degrees."""
    rise = rise_at(module, closure)
    sun = toward(off_normal_deg, azimuth_deg)
    blocked = blocked_fraction(module.batch, rise, sun).blocked_fraction[0]
    mirrored = toward(off_normal_deg, 180.0 - azimuth_deg)
    for other in (mirrored, toward(off_normal_deg, azimuth_deg + 120.0),
                  toward(off_normal_deg, azimuth_deg - 120.0)):
        assert blocked_fraction(module.batch, rise, other).blocked_fraction[0] == \
            pytest.approx(blocked, abs=TOLERANCE)


def test_a_batch_equals_its_panels_one_by_one():
    panels = [HEXAGON_MODULE, SMALL, NEARLY_FLAT, SMALL, HEXAGON_MODULE]
    model = model_of(*panels)
    rise = rise_at(model, np.array([0.2, 1.0, 0.0, 0.6, 0.9]))
    suns = np.array([toward(0.0), toward(35.0, 20.0), toward(70.0, 95.0), toward(110.0, 0.0),
                     toward(85.0, 300.0)])
    for tessellated in (True, False):
        together = blocked_fraction(model.batch, rise, suns, tessellated=tessellated)
        views = view_fraction(model.batch, rise)
        for index in range(len(panels)):
            one = model.batch.take([index])
            alone = blocked_fraction(one, rise[index], suns[index], tessellated=tessellated)
            assert alone.blocked_fraction[0] == together.blocked_fraction[index]
            assert view_fraction(one, rise[index])[0] == views[index]


def test_shading_topology_converges(module):
    """The default mesh is near a mesh 20 times finer at the same scan lines; coarser is worse.

    msg_docs/hexagon_shading.md has the full convergence table (bench/bench_hexagon_shading.py).
    """
    closures = np.array([0.25, 0.5, 0.75, 1.0])
    suns = np.array([toward(0.0), toward(20.0, 10.0), toward(45.0, 100.0), toward(60.0, 250.0),
                     toward(75.0, 30.0), toward(85.0, 170.0)])
    rise = np.repeat([rise_at(module, c)[0] for c in closures], len(suns))
    batch = module.batch.take(np.zeros(rise.size, dtype=np.intp))
    sun = np.tile(suns, (closures.size, 1))

    def error(topology):
        value = blocked_fraction(batch, rise, sun, topology).blocked_fraction
        return np.abs(value - dense)
    dense = blocked_fraction(batch, rise, sun, HexagonTopology(24, 8, 16)).blocked_fraction
    chosen, coarse = error(HEXAGON_SHADING_TOPOLOGY), error(HexagonTopology(2, 1, 2))
    assert np.mean(chosen) < 0.005 and np.max(chosen) <= 0.025
    assert np.mean(coarse) > 2 * np.mean(chosen)


def test_closure_for_shading_takes_a_hexagonal_fold_model(module):
    # Leaning past upright, the flaps cover the centre again: the most view may come before
    # closure 1; the rule takes the first closure with the most view.
    candidates = np.linspace(0.0, 1.0, 21)
    views = np.array([view_fraction(module.batch, rise_at(module, c))[0] for c in candidates])
    most_view = closure_for_shading(module, toward(0.0), 0.0)
    assert most_view.closure[0] == candidates[np.argmax(views)]
    assert most_view.view_fraction[0] == views.max() > 0.3
    # Closure 0 blocks the most, all but a sliver (0.15 %) left open by the 5 deg pre-fold.
    flat_sheet = closure_for_shading(module, toward(0.0), 1.0)
    assert flat_sheet.closure[0] == 0.0 and not flat_sheet.meets_target[0]
    assert flat_sheet.blocked_fraction[0] == pytest.approx(
        exact_share(module, rise_at(module, 0.0), toward(0.0), tessellated=False),
        abs=TOLERANCE)
    assert 0.99 < flat_sheet.blocked_fraction[0] < 1.0
    middle = closure_for_shading(module, toward(30.0, 60.0), 0.8)
    assert middle.meets_target[0] and middle.blocked_fraction[0] >= 0.8
    assert 0.0 < middle.closure[0] < 1.0


def test_shading_table_of_a_hexagonal_panel_reproduces_ray_casting_at_its_nodes():
    table = ShadingTable(HEXAGON_MODULE, step_deg=20.0, max_profile_deg=80.0, samples=SAMPLES)
    alpha, beta = np.radians([-80.0, 0.0, 40.0]), np.radians([20.0, 0.0, -60.0])
    sun = np.stack([np.tan(alpha), np.tan(beta), np.ones(3)], axis=-1)
    sun /= np.linalg.norm(sun, axis=-1, keepdims=True)
    model = HexagonFoldModel(HexagonBatch.repeat(HEXAGON_MODULE, 3))
    for index in (0, 5, 10):
        exact = blocked_fraction(model.batch, rise_at(model, table.closures[index]), sun,
                                 samples=SAMPLES).blocked_fraction
        np.testing.assert_allclose(table.blocked_fractions(sun)[:, index], exact, atol=1e-12)
    # Without direct sun the panel takes the (first) closure with the most view.
    np.testing.assert_array_equal(table.choose(np.array([[0.0, 0.0, -1.0]]), 0.9),
                                  table.closures[np.argmax(table.view)])
    assert table.view[0] < 0.01 and table.view.max() > 0.3


def test_bad_input_is_refused_clearly(module):
    rise = rise_at(module, 0.5)
    quads = PanelBatch.from_panels([DEMONSTRATOR_MODULE])
    with pytest.raises(TypeError, match='topology must be a HexagonTopology for a HexagonBatch'):
        blocked_fraction(module.batch, rise, toward(0.0), topology=MeshTopology(11, 3, 7))
    with pytest.raises(TypeError, match='topology must be a MeshTopology for a PanelBatch'):
        view_fraction(quads, 0.3, topology=HEXAGON_SHADING_TOPOLOGY)
    with pytest.raises(TypeError, match='batch must be a PanelBatch or a HexagonBatch'):
        blocked_fraction([HEXAGON_MODULE], rise, toward(0.0))
    with pytest.raises(TypeError, match='fold_model must be a FoldModel or a HexagonFoldModel'):
        closure_for_shading(module.batch, toward(0.0), 0.5)
    with pytest.raises(ValueError, match=r'centre_rise_m must lie in \[0, inf\] m, got -0.01'):
        blocked_fraction(module.batch, -0.01, toward(0.0))
    with pytest.raises(ValueError, match='centre_rise_m of panel 0 is 0.3 m, above the highest'):
        view_fraction(module.batch, 0.3)
    with pytest.raises(ValueError, match='centre_rise_m must be finite'):
        view_fraction(module.batch, float('nan'))
    with pytest.raises(ValueError, match='vector 0 has length 0.5'):
        blocked_fraction(module.batch, rise, toward(0.0) / 2)
    with pytest.raises(TypeError, match='panel must be a PanelGeometry or a HexagonPanel'):
        ShadingTable(module.batch)
