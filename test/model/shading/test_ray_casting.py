"""Shading and view of folded panels: the ray casting against independent geometry."""

import math

import numpy as np
import pytest
from shadow_area import blocked_share, quad_footprint

from flectofold_model import (DEMONSTRATOR_MODULE, fold_mesh, FoldModel, PanelBatch, PanelGeometry,
                              PROTOTYPE)
from flectofold_model.shading.ray_casting import (blocked_fraction, closure_for_shading,
                                                  DEFAULT_STANDOFF_M, SHADING_TOPOLOGY,
                                                  view_fraction)

#: A flat panel: no pre-fold, so closure 0 is the flat sheet.
FLAT = PanelGeometry.with_lens_midrib(0.52, 0.42, 0.75, 0.02, 0.015)
SAMPLES = 24
CLOSURES = np.linspace(0.0, 1.0, 21)
#: Largest error of the default scan lines against the exact shadow area over the cases of
#: bench/bench_shading_accuracy.py is 0.0031 (msg_docs/scheduling.md); the tests allow 0.005.
TOLERANCE = 0.005


def toward(off_normal_deg, azimuth_deg=0.0):
    """Sun vector ``off_normal_deg`` from the facade normal, leaning toward the azimuth.

    The azimuth is measured in the facade plane from +x (along the mid-rib) toward +y.
    """
    off, azimuth = math.radians(off_normal_deg), math.radians(azimuth_deg)
    return np.array([math.sin(off) * math.cos(azimuth), math.sin(off) * math.sin(azimuth),
                     math.cos(off)])


@pytest.fixture(scope='module')
def flat_model():
    return FoldModel(PanelBatch.from_panels([FLAT]))


@pytest.fixture(scope='module')
def model():
    return FoldModel(PanelBatch.from_panels([PROTOTYPE, DEMONSTRATOR_MODULE, FLAT]))


def k_at(fold_model, closure):
    return fold_model.state_from_closure(closure).elastica_k


def projected_cover(vertices, faces, length_m, width_m, count):
    """Raster (count, count) of a footprint: which cell centres the sheets' projection covers.

    The mesh is projected onto z = 0 along z and each cell centre tested against every
    projected triangle by the signs of its three edge functions (only the centres inside the
    triangle's bounding box), a 2-D method independent of the 3-D ray casting under test.
    Triangles projected to zero area (flaps standing edge-on) cover nothing.
    """
    fractions = (np.arange(count) + 0.5) / count - 0.5
    xs, ys = fractions * length_m, fractions * width_m
    covered = np.zeros((count, count), dtype=bool)
    for corners in vertices[faces][:, :, :2]:
        a, b, c = corners
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(area) < 1e-12:
            continue
        rows = np.flatnonzero((xs >= corners[:, 0].min()) & (xs <= corners[:, 0].max()))
        columns = np.flatnonzero((ys >= corners[:, 1].min()) & (ys <= corners[:, 1].max()))
        x, y = np.meshgrid(xs[rows], ys[columns], indexing='ij')
        inside = np.ones(x.shape, dtype=bool)
        for first, second in ((a, b), (b, c), (c, a)):
            edge = second - first
            inside &= (edge[0] * (y - first[1]) - edge[1] * (x - first[0])) * area >= 0.0
        covered[np.ix_(rows, columns)] |= inside
    return covered


def shadow_cover(vertices, faces, length_m, width_m, count, sun, tessellated):
    """Raster of the footprint: which cell centres lie in the shadow of the sheets.

    The shadow of the mesh on the footprint plane ``z = -standoff`` along the sun, found by
    projecting its vertices, ``p = v - (v_z + standoff) s / s_z``; with ``tessellated`` the
    shadows of its copies in every cell near enough to reach the footprint are added.
    """
    run = sun[:2] / sun[2]
    shadow = vertices[:, :2] - (vertices[:, 2:3] + DEFAULT_STANDOFF_M) * run
    cells = [(0, 0)]
    if tessellated:
        reach = (vertices[:, 2].max() + DEFAULT_STANDOFF_M) * run / (length_m, width_m)
        low = np.floor(np.minimum(reach, 0.0)).astype(int) - 1
        high = np.ceil(np.maximum(reach, 0.0)).astype(int) + 1
        cells = [(i, j) for i in range(low[0], high[0] + 1) for j in range(low[1], high[1] + 1)]
    covered = np.zeros((count, count), dtype=bool)
    for i, j in cells:
        copy = np.column_stack([shadow + (i * length_m, j * width_m), np.zeros(len(shadow))])
        covered |= projected_cover(copy, faces, length_m, width_m, count)
    return covered


@pytest.mark.parametrize('off_normal_deg, azimuth_deg', [
    (0, 0), (30, 0), (60, 0), (30, 90), (60, 90), (60, 180), (60, 270), (45, 37), (85, 60)])
def test_flat_panel_blocks_all_direct_sun(flat_model, off_normal_deg, azimuth_deg):
    k = k_at(flat_model, 0.0)
    assert k[0] == 0.0
    shading = blocked_fraction(flat_model.batch, k, toward(off_normal_deg, azimuth_deg))
    assert shading.sunlit.tolist() == [True]
    # Not a gap anywhere: the neighbouring cells are flat sheets too.
    assert shading.blocked_fraction[0] == 1.0


@pytest.mark.parametrize('standoff_m', [DEFAULT_STANDOFF_M, 0.02, 0.0])
@pytest.mark.parametrize('azimuth_deg, across_m', [(0, FLAT.length_m), (90, FLAT.width_m)])
def test_lone_flat_panel_lets_oblique_sun_past_its_edges(flat_model, azimuth_deg, across_m,
                                                         standoff_m):
    """A lone panel: footprint rays leave through the gap ``standoff tan(theta)`` wide."""
    k = k_at(flat_model, 0.0)
    normal = blocked_fraction(flat_model.batch, k, toward(0.0), tessellated=False,
                              standoff_m=standoff_m)
    assert normal.blocked_fraction[0] == 1.0
    oblique = blocked_fraction(flat_model.batch, k, toward(60.0, azimuth_deg), tessellated=False,
                               standoff_m=standoff_m)
    expected = 1.0 - standoff_m * math.tan(math.radians(60.0)) / across_m
    # The gap's edge runs along x or y, across the scan lines: it is measured exactly (a grid
    # of points, whose rows run along it, was off by up to a row, 1 / 24).
    assert oblique.blocked_fraction[0] == pytest.approx(expected, abs=1e-3)


@pytest.mark.parametrize('sun', [
    (0.0, 0.0, -1.0), toward(120.0, 30.0), toward(179.0, 250.0),
    (1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (math.cos(0.3), math.sin(0.3), 0.0)])
def test_no_direct_sun_from_behind_or_along_the_facade(model, sun):
    for closure in (0.0, 1.0):
        shading = blocked_fraction(model.batch, k_at(model, closure), sun)
        assert not shading.sunlit.any()
        np.testing.assert_array_equal(shading.blocked_fraction, 0.0)


def test_sunlit_mask_is_per_panel(model):
    suns = np.array([toward(30.0, 10.0), toward(100.0, 10.0), [0.0, 1.0, 0.0]])
    shading = blocked_fraction(model.batch, k_at(model, 1.0), suns)
    assert shading.sunlit.tolist() == [True, False, False]
    assert shading.blocked_fraction[0] > 0.0
    np.testing.assert_array_equal(shading.blocked_fraction[1:], 0.0)


def exact_share(fold_model, index, k, sun, tessellated=True):
    """Blocked share of panel ``index`` of ``fold_model`` from the exact area of its shadows."""
    mesh = fold_mesh(fold_model.batch.take([index]), k[index:index + 1], SHADING_TOPOLOGY)
    footprint = quad_footprint(fold_model.batch.length_m[index], fold_model.batch.width_m[index])
    return blocked_share(mesh.vertices[0], mesh.faces, footprint, sun, DEFAULT_STANDOFF_M,
                         tessellated)


@pytest.mark.parametrize('closure', [1.0, 0.5])
def test_normal_incidence_blocks_the_projection_of_the_sheets(model, closure):
    """Compare with the exact area of the projection of the same mesh onto the footprint."""
    k = k_at(model, closure)
    blocked = blocked_fraction(model.batch, k, toward(0.0)).blocked_fraction
    for index in range(len(model)):
        expected = exact_share(model, index, k, toward(0.0), tessellated=False)
        assert blocked[index] == pytest.approx(expected, abs=TOLERANCE)


@pytest.mark.parametrize('closure, off_normal_deg, azimuth_deg', [
    (1.0, 80.0, 90.0), (1.0, 60.0, 30.0), (0.6, 45.0, 200.0), (0.3, 70.0, -60.0),
    (0.5, 80.0, 0.0), (1.0, 85.0, 10.0)])
@pytest.mark.parametrize('tessellated', [True, False])
def test_oblique_sun_blocks_the_shadows_of_the_sheets(model, closure, off_normal_deg,
                                                      azimuth_deg, tessellated):
    """Compare with the exact area of the shadows of the mesh (and its neighbours' copies)."""
    sun = toward(off_normal_deg, azimuth_deg)
    k = k_at(model, closure)
    blocked = blocked_fraction(model.batch, k, sun, tessellated=tessellated).blocked_fraction
    for index in range(2):
        expected = exact_share(model, index, k, sun, tessellated)
        assert blocked[index] == pytest.approx(expected, abs=TOLERANCE)


@pytest.mark.parametrize('off_normal_deg, azimuth_deg', [(70.0, 90.0), (80.0, 270.0),
                                                         (70.0, 270.0), (60.0, 90.0)])
def test_closed_panel_in_oblique_sun_is_within_a_hundredth_of_the_exact_area(
        model, off_normal_deg, azimuth_deg):
    """The hard cases: the flaps' shadow edges run along x, as rows of a grid of points do.

    The former estimate, a 24 x 24 grid of cell centres, errs by more than 0.02 here (the
    same grid on the exact shadows, checked below); the scan lines stay within 0.01.
    """
    sun = toward(off_normal_deg, azimuth_deg)
    k = k_at(model, 1.0)
    blocked = blocked_fraction(model.batch, k, sun).blocked_fraction
    index = 1  # DEMONSTRATOR_MODULE
    expected = exact_share(model, index, k, sun)
    assert abs(blocked[index] - expected) < 0.01
    mesh = fold_mesh(model.batch, k, SHADING_TOPOLOGY)
    batch = model.batch
    points = shadow_cover(mesh.vertices[index], mesh.faces, batch.length_m[index],
                          batch.width_m[index], SAMPLES, sun, True).mean()
    assert abs(points - expected) > 0.02


def test_closed_demonstrator_blocks_about_its_midrib_at_normal_incidence(model):
    """Closed, the flaps stand on the creases: what is left is about the mid-rib lens."""
    batch = model.batch
    blocked = blocked_fraction(batch, k_at(model, 1.0), toward(0.0)).blocked_fraction
    # Area of the flat lens: the strip between the fold-line ends plus two circular segments.
    radius, chord, sag = batch.fold_radius_m, batch.length_m, batch.fold_line_sag_m
    segment = radius**2 * np.arccos(1.0 - sag / radius) - (radius - sag) * chord / 2
    lens_share = (2 * batch.end_y_m * chord + 2 * segment) / (chord * batch.width_m)
    # The bent mid-rib projects onto less than its flat area; at 90 deg the flaps add nothing.
    assert np.all(blocked <= lens_share + TOLERANCE)
    assert np.all(blocked >= 0.7 * lens_share)


def test_view_opens_and_normal_sun_gets_through_as_the_panel_closes(model):
    closures = np.linspace(0.0, 1.0, 11)
    views = np.array([view_fraction(model.batch, k_at(model, c)) for c in closures])
    blocked = np.array([blocked_fraction(model.batch, k_at(model, c), toward(0.0))
                        .blocked_fraction for c in closures])
    np.testing.assert_allclose(views, 1.0 - blocked, atol=1e-15)
    assert np.all(np.diff(views, axis=0) >= 0.0)
    assert np.all(views[0] < 0.01)
    assert np.all(views[-1] > 0.3)
    assert np.all(views[-1] > views[5] + 0.2)
    assert np.all(np.diff(blocked, axis=0) <= 0.0)


@pytest.mark.parametrize('azimuth_deg', [90.0, -90.0])
def test_standing_flaps_block_grazing_sun_like_fins(model, azimuth_deg):
    k = k_at(model, 1.0)
    normal = blocked_fraction(model.batch, k, toward(0.0)).blocked_fraction
    grazing = blocked_fraction(model.batch, k, toward(80.0, azimuth_deg)).blocked_fraction
    assert np.all(normal < 0.3)
    assert np.all(grazing > normal + 0.5)


@pytest.mark.parametrize('off_normal_deg, azimuth_deg', [(40, 30), (65, 120), (80, 200),
                                                         (20, 90)])
@pytest.mark.parametrize('closure', [0.4, 1.0])
def test_mirrored_sun_blocks_the_same(model, off_normal_deg, azimuth_deg, closure):
    k = k_at(model, closure)
    sun = toward(off_normal_deg, azimuth_deg)
    blocked = blocked_fraction(model.batch, k, sun).blocked_fraction
    for mirror in ((1, -1, 1), (-1, 1, 1), (-1, -1, 1)):
        mirrored = blocked_fraction(model.batch, k, sun * mirror).blocked_fraction
        # Mirrored, the shadows cross the (unmirrored) scan lines differently: each estimate
        # is within TOLERANCE of the exact area, which is the same.
        np.testing.assert_allclose(mirrored, blocked, atol=TOLERANCE)


def test_a_batch_equals_its_panels_one_by_one():
    rng = np.random.default_rng(7)
    panels = [PROTOTYPE, DEMONSTRATOR_MODULE, FLAT, PROTOTYPE, DEMONSTRATOR_MODULE, FLAT,
              PanelGeometry.with_lens_midrib(0.8, 0.6, 1.0, 0.03, 0.03, prefold_rad=0.1)]
    fold_model = FoldModel(PanelBatch.from_panels(panels))
    k = k_at(fold_model, rng.uniform(0.0, 1.0, len(panels)))
    suns = np.array([toward(0.0), toward(35.0, 20.0), toward(70.0, 95.0), toward(110.0, 0.0),
                     toward(85.0, 300.0), toward(50.0, 180.0), toward(60.0, 45.0)])
    for tessellated in (True, False):
        together = blocked_fraction(fold_model.batch, k, suns, tessellated=tessellated)
        views = view_fraction(fold_model.batch, k)
        for index in range(len(panels)):
            alone = blocked_fraction(fold_model.batch.take([index]), k[index], suns[index],
                                     tessellated=tessellated)
            assert alone.blocked_fraction[0] == together.blocked_fraction[index]
            assert alone.sunlit[0] == together.sunlit[index]
            assert (view_fraction(fold_model.batch.take([index]), k[index])[0]
                    == views[index])


def candidate_table(fold_model, sun):
    """Blocked (for ``sun``) and view fractions of every panel at every candidate closure."""
    blocked = np.stack([blocked_fraction(fold_model.batch, k_at(fold_model, c), sun)
                        .blocked_fraction for c in CLOSURES], axis=1)
    views = np.stack([view_fraction(fold_model.batch, k_at(fold_model, c)) for c in CLOSURES],
                     axis=1)
    return blocked, views


def rule_by_hand(blocked, views, target, sunlit):
    """Apply the documented decision rule, one panel and one candidate at a time."""
    chosen = []
    for n in range(blocked.shape[0]):
        goal = target[n] if sunlit[n] else 0.0
        feasible = [c for c in range(len(CLOSURES)) if blocked[n, c] >= goal]
        if feasible:
            key = [(views[n, c], blocked[n, c], -CLOSURES[c]) for c in feasible]
        else:
            feasible = list(range(len(CLOSURES)))
            key = [(blocked[n, c], views[n, c], -CLOSURES[c]) for c in feasible]
        chosen.append(CLOSURES[feasible[max(range(len(key)), key=key.__getitem__)]])
    return np.array(chosen)


@pytest.mark.parametrize('sun', [toward(0.0), toward(45.0, 90.0), toward(70.0, 10.0)])
def test_target_zero_takes_the_most_view(model, sun):
    choice = closure_for_shading(model, sun, 0.0)
    np.testing.assert_array_equal(choice.closure, 1.0)
    _, views = candidate_table(model, sun)
    np.testing.assert_array_equal(choice.view_fraction, views.max(axis=1))
    assert choice.meets_target.all()


def test_target_one_at_normal_incidence_keeps_the_sheet_flat(model):
    """Closure 0 blocks the most; only the flat panel (no pre-fold) blocks all of the sun.

    The pre-folded panels' flaps are tilted by 5 deg at closure 0, so their projection leaves
    a sliver of the footprint open along the normal (0.3 %, the exact area); the target is
    then out of reach and the rule takes the most blocking closure, still the flattest.
    """
    choice = closure_for_shading(model, toward(0.0), 1.0)
    np.testing.assert_array_equal(choice.closure, 0.0)
    assert choice.blocked_fraction[2] == 1.0 and choice.view_fraction[2] == 0.0
    assert choice.meets_target.tolist() == [False, False, True]
    k = k_at(model, 0.0)
    for index in range(2):
        expected = exact_share(model, index, k, toward(0.0), tessellated=False)
        assert 0.99 < expected < 1.0
        assert choice.blocked_fraction[index] == pytest.approx(expected, abs=TOLERANCE)
        assert choice.view_fraction[index] == 1.0 - choice.blocked_fraction[index]


@pytest.mark.parametrize('sun, target', [
    (toward(0.0), 0.5), (toward(50.0, 80.0), [0.6, 0.9, 0.75]), (toward(80.0, 0.0), 0.95),
    (toward(30.0, 200.0), [0.2, 1.0, 0.45])])
def test_choice_follows_the_documented_rule(model, sun, target):
    choice = closure_for_shading(model, sun, target)
    blocked, views = candidate_table(model, sun)
    target = np.broadcast_to(target, (len(model),))
    np.testing.assert_array_equal(choice.closure,
                                  rule_by_hand(blocked, views, target, choice.sunlit))
    rows = np.arange(len(model))
    chosen = np.searchsorted(CLOSURES, choice.closure)
    np.testing.assert_array_equal(choice.blocked_fraction, blocked[rows, chosen])
    np.testing.assert_array_equal(choice.view_fraction, views[rows, chosen])
    reachable = (blocked >= target[:, None]).any(axis=1)
    np.testing.assert_array_equal(choice.meets_target, reachable)
    assert np.all(choice.blocked_fraction[reachable] >= target[reachable])
    # Where the target is out of reach, the panel blocks as much as it can.
    np.testing.assert_array_equal(choice.blocked_fraction[~reachable],
                                  blocked[~reachable].max(axis=1))


def test_unreachable_target_takes_the_most_blocking_closure(model):
    """A lone panel in grazing sun cannot block everything: it does its best."""
    sun = toward(75.0, 90.0)
    choice = closure_for_shading(model, sun, 1.0, tessellated=False)
    lone = np.stack([blocked_fraction(model.batch, k_at(model, c), sun, tessellated=False)
                     .blocked_fraction for c in CLOSURES], axis=1)
    assert np.all(lone.max(axis=1) < 1.0)
    assert not choice.meets_target.any()
    np.testing.assert_array_equal(choice.blocked_fraction, lone.max(axis=1))


def test_panels_without_direct_sun_take_the_most_view(model):
    suns = np.array([toward(100.0, 0.0), [0.0, 1.0, 0.0], toward(30.0, 45.0)])
    choice = closure_for_shading(model, suns, 1.0)
    assert choice.sunlit.tolist() == [False, False, True]
    np.testing.assert_array_equal(choice.closure[:2], 1.0)
    np.testing.assert_array_equal(choice.blocked_fraction[:2], 0.0)
    assert choice.meets_target[:2].all()
    assert choice.closure[2] < 1.0


def test_candidate_closures_can_be_chosen(model):
    choice = closure_for_shading(model, toward(0.0), 0.0, closures=[0.0, 0.3, 0.6])
    np.testing.assert_array_equal(choice.closure, 0.6)


@pytest.mark.parametrize('kwargs, message', [
    ({'target_blocked': float('nan')}, 'target_blocked must be finite'),
    ({'target_blocked': 1.5}, r'target_blocked must lie in \[0, 1\]'),
    ({'target_blocked': -0.1}, r'target_blocked must lie in \[0, 1\]'),
    ({'target_blocked': [0.5, 0.5]}, r'target_blocked has shape \(2,\)'),
    ({'sun_panel': (0.0, 0.0, 2.0)}, 'unit vectors toward the sun; vector 0 has length 2'),
    ({'sun_panel': (0.0, 0.0, 0.0)}, 'vector 0 has length 0'),
    ({'sun_panel': np.tile([0.0, 0.0, 1.0], (4, 1))}, r'sun_panel has shape \(4, 3\)'),
    ({'sun_panel': (0.0, 1.0)}, r'sun_panel has shape \(2,\)'),
    ({'sun_panel': (0.0, float('inf'), 0.0)}, 'sun_panel must be finite'),
    ({'closures': []}, 'closures must be a non-empty 1-D array'),
    ({'closures': [[0.0, 1.0]]}, 'closures must be a non-empty 1-D array'),
    ({'closures': [0.0, 1.2]}, r'closures must lie in \[0, 1\]'),
    ({'samples': 0}, 'samples must be a positive integer'),
    ({'standoff_m': -0.01}, 'standoff_m must not be negative'),
])
def test_closure_for_shading_refuses_bad_input(model, kwargs, message):
    arguments = {'sun_panel': toward(20.0), 'target_blocked': 0.5, **kwargs}
    with pytest.raises(ValueError, match=message):
        closure_for_shading(model, **arguments)


def test_blocked_fraction_refuses_bad_input(model):
    k = k_at(model, 0.5)
    with pytest.raises(TypeError, match='batch must be a PanelBatch'):
        blocked_fraction([PROTOTYPE], k, toward(0.0))
    with pytest.raises(TypeError, match='fold_model must be a FoldModel'):
        closure_for_shading(model.batch, toward(0.0), 0.5)
    with pytest.raises(ValueError, match=r'k must lie in \[0, 0.7071'):
        blocked_fraction(model.batch, [0.1, 0.2, 0.9], toward(0.0))
    with pytest.raises(ValueError, match=r'k has shape \(2,\)'):
        blocked_fraction(model.batch, k[:2], toward(0.0))
    with pytest.raises(ValueError, match='vector 1 has length 0.5'):
        blocked_fraction(model.batch, k, [toward(0.0), toward(0.0) / 2, toward(0.0)])
    with pytest.raises(ValueError, match='max_cells must be a positive integer'):
        blocked_fraction(model.batch, k, toward(0.0), max_cells=2.5)
    with pytest.raises(TypeError, match='tessellated must be a bool'):
        blocked_fraction(model.batch, k, toward(0.0), tessellated='yes')
    with pytest.raises(TypeError, match='topology must be a MeshTopology'):
        view_fraction(model.batch, k, topology=(11, 3, 7))


def test_a_ray_is_followed_across_at_most_max_cells(model):
    """Near-grazing sun: fewer cells followed can only miss sheets (a lower bound)."""
    k = k_at(model, 1.0)
    sun = toward(88.0, 5.0)
    fractions = [blocked_fraction(model.batch, k, sun, max_cells=cells).blocked_fraction
                 for cells in (2, 8, 32)]
    assert np.all(np.diff(fractions, axis=0) >= 0.0)
    assert np.all(fractions[2] > fractions[0] + 0.3)


def test_sun_vectors_within_a_rounding_of_unit_length_are_normalised(model):
    k = k_at(model, 1.0)
    sun = toward(40.0, 70.0)
    exact = blocked_fraction(model.batch, k, sun).blocked_fraction
    np.testing.assert_array_equal(blocked_fraction(model.batch, k, sun * (1 + 1e-8))
                                  .blocked_fraction, exact)
