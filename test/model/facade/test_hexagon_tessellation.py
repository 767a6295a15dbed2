"""Hexagonal facades: lattice, frames, edge cells, OBJ hexagon meshes, pre-fold, bad YAML."""

import math
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from flectofold_model.facade import hexagon_cells, surfaces
from flectofold_model.facade.description import (build_facade, DATA_DIRECTORY, DEFAULT_FACADE,
                                                 facade_path, FacadeError, load_facade)
from flectofold_model.kinematics.hexagon_panel import HEXAGON_MODULE, HexagonPanel
from flectofold_model.kinematics.hexagon_panel import HexagonBatch
from flectofold_model.kinematics.hexagon_reflection import SectorGeometry
from flectofold_model.kinematics.kinds import fold_model_of

BASE = """
name: hex
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {SURFACE}
grid: {gap_m: 0.1}
panel: {type: hexagon, circumradius_m: 0.62, fold_line_sag_m: 0.06, hinge_width_m: 0.03}
"""
SPHERE_RADIUS_M = 8.0
#: Independent depth functions w(u, v) of each parametric kind, as YAML and as numpy.
SURFACES = {
    'plane': ('{type: plane, width_m: 4.4, height_m: 3.3}', lambda u, v: 0 * u),
    'cylinder': ('{type: cylinder, width_m: 4.4, height_m: 3.3, radius_m: 5.0}',
                 lambda u, v: np.sqrt(25.0 - u**2) - 5.0),
    'dome': (f'{{type: dome, width_m: 4.4, height_m: 3.3, semi_axis_u_m: {SPHERE_RADIUS_M}, '
             f'semi_axis_v_m: {SPHERE_RADIUS_M}, depth_m: {SPHERE_RADIUS_M}}}',
             lambda u, v: np.sqrt(SPHERE_RADIUS_M**2 - u**2 - v**2) - SPHERE_RADIUS_M),
    'saddle': ('{type: saddle, width_m: 4.4, height_m: 3.3, curvature_u_per_m: 0.08, '
               'curvature_v_per_m: -0.08}', lambda u, v: -(0.08 * u**2 - 0.08 * v**2) / 2),
}
SHAPES = {'plane': lambda: surfaces.plane(6.6, 6.6),
          'cylinder': lambda: surfaces.cylinder(6.6, 4.0, -6.0),
          'dome': lambda: surfaces.dome(6.6, 4.0, 5.0, 4.0, 2.0),
          'saddle': lambda: surfaces.saddle(6.6, 4.0, 0.08, -0.08)}
APOTHEM = math.sqrt(3.0) / 2
MESSAGE_LIMIT = 400


def facade_text(kind, **replace):
    text = BASE.replace('{SURFACE}', SURFACES[kind][0])
    for old, new in replace.items():
        assert old in text, old
        text = text.replace(old, new)
    return text


def graph_normal(depth, u, v, step=1e-5):
    w_u = (depth(u + step, v) - depth(u - step, v)) / (2 * step)
    w_v = (depth(u, v + step) - depth(u, v - step)) / (2 * step)
    normal = np.stack([-w_u, -w_v, np.ones_like(u)], axis=-1)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


def inside_hexagon(points, centre, radius):
    """Points (P, 2) strictly inside a corner-up regular hexagon (apothems along 0, 60, 120)."""
    offset = points - centre
    normals = np.array([[math.cos(a), math.sin(a)] for a in np.radians([0, 60, 120])])
    return np.all(np.abs(offset @ normals.T) < APOTHEM * radius * (1 - 1e-9), axis=-1)


@pytest.mark.parametrize('kind', sorted(SURFACES))
def test_every_surface_tessellates_into_framed_hexagons_on_the_surface(kind):
    facade = build_facade(facade_text(kind))
    depth = SURFACES[kind][1]
    assert facade.panel_kind == 'hexagon' and len(facade) >= 4
    assert all(isinstance(panel, HexagonPanel) for panel in facade.panels)
    assert len(set(facade.panel_ids)) == len(facade)
    assert all(re.fullmatch(r'r\d{2}c\d{2}', panel_id) for panel_id in facade.panel_ids)
    rotation = facade.rotation
    np.testing.assert_allclose(np.einsum('nji,njk->nik', rotation, rotation),
                               np.broadcast_to(np.eye(3), rotation.shape), atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(rotation), 1.0, atol=1e-9)
    u, v, w = facade.origin_m.T
    np.testing.assert_allclose(w, depth(u, v), atol=1e-9)  # origins on the surface
    np.testing.assert_allclose(rotation[..., 2], graph_normal(depth, u, v), atol=1e-6)
    assert np.all(rotation[:, 1, 1] > 0.95)  # the +y corner points up the facade
    assert np.all(np.abs(u) + APOTHEM * 0.62 < 2.2) and np.all(np.abs(v) + 0.62 < 1.65)
    for panel in facade.panels:
        assert panel.circumradius_m == pytest.approx(0.62, rel=0.02)
    model = fold_model_of(facade.panels)  # the kinematics take the facade's panels as they are
    assert np.all(model.state_from_closure(0.5).apex_fold_angle_rad > 0)


def test_the_plane_lattice_shares_edges_without_overlap_and_keeps_every_whole_cell():
    radius = 0.5
    cells = hexagon_cells.tessellate(surfaces.plane(6.6, 4.4), radius)
    centre = cells.origin_m[:, :2]
    distance = np.linalg.norm(centre[:, None] - centre[None], axis=-1)
    np.fill_diagonal(distance, np.inf)
    np.testing.assert_allclose(distance.min(axis=1), math.sqrt(3) * radius, rtol=1e-9)
    neighbours = np.argwhere(np.abs(distance - math.sqrt(3) * radius) < 1e-9)
    assert len(neighbours) > len(cells)  # a connected lattice, most cells with several
    for first, second in neighbours:  # neighbours share a whole edge: two corners each
        gap = np.linalg.norm(cells.corners_m[first][:, None] - cells.corners_m[second][None],
                             axis=-1)
        assert np.sum(gap < 1e-9) == 2
    np.testing.assert_allclose(cells.circumradius_m, radius, rtol=1e-9)
    grid = np.stack(np.meshgrid(np.linspace(-3.3, 3.3, 331), np.linspace(-2.2, 2.2, 221)),
                    axis=-1).reshape(-1, 2)
    covered = np.sum([inside_hexagon(grid, c, radius) for c in centre], axis=0)
    assert covered.max() == 1  # no point lies inside two cells
    assert np.all(np.abs(cells.corners_m[..., 0]) <= 3.3 + 1e-9)
    assert np.all(np.abs(cells.corners_m[..., 1]) <= 2.2 + 1e-9)
    # Every lattice neighbour left out would stick out of the boundary: no whole cell missed.
    for c in centre:
        for angle in np.radians(np.arange(0, 360, 60)):
            candidate = c + math.sqrt(3) * radius * np.array([math.cos(angle), math.sin(angle)])
            if np.min(np.linalg.norm(centre - candidate, axis=-1)) < 1e-9:
                continue
            corners = candidate + hexagon_cells.corner_offsets(radius)
            assert np.any(np.abs(corners[:, 0]) > 3.3 + 1e-9) or \
                np.any(np.abs(corners[:, 1]) > 2.2 + 1e-9)


@pytest.mark.parametrize('kind', sorted(SHAPES))
def test_cells_of_every_kind_lie_inside_the_boundary_and_do_not_overlap(kind):
    shape = SHAPES[kind]()
    cells = hexagon_cells.tessellate(shape, 0.55)
    assert len(cells) >= 6
    assert np.all(np.abs(cells.corners_m[..., 0]) <= shape.width_m / 2 + 1e-9)
    assert np.all(np.abs(cells.corners_m[..., 1]) <= shape.height_m / 2 + 1e-9)
    corners = cells.corners_m
    np.testing.assert_allclose(corners[..., 2], shape.point(corners[..., 0],
                                                            corners[..., 1])[..., 2], atol=1e-12)
    distance = np.linalg.norm(cells.origin_m[:, None] - cells.origin_m[None], axis=-1)
    np.fill_diagonal(distance, np.inf)
    # Centres stay a cell's width apart on the surface (within the development's stretch).
    assert distance.min() > math.sqrt(3) * 0.55 * 0.95
    np.testing.assert_allclose(cells.circumradius_m, 0.55, rtol=0.06)


def test_the_cylinder_is_developed_exactly_along_its_arc():
    radius_cylinder, radius = 6.0, 0.55
    cells = hexagon_cells.tessellate(surfaces.cylinder(6.6, 4.0, radius_cylinder), radius)
    arc = radius_cylinder * np.arcsin(cells.origin_m[:, 0] / radius_cylinder)
    for line in np.unique(cells.row):
        along = np.sort(arc[cells.row == line])
        np.testing.assert_allclose(np.diff(along), math.sqrt(3) * radius, rtol=1e-6)
    rows = np.unique(np.round(cells.origin_m[:, 1], 9))
    np.testing.assert_allclose(np.diff(rows), 1.5 * radius, rtol=1e-6)


def hexagon_mesh_obj(path, radius, sphere_radius=None, rows=3, columns=4, distort=None):
    """Write a corner-up hexagon mesh with shared vertices, optionally lifted onto a sphere."""
    centres = np.array([((i + 0.5 * (j % 2)) * math.sqrt(3) * radius, 1.5 * radius * j)
                        for j in range(rows) for i in range(columns)])
    centres -= centres.mean(axis=0)
    index, vertices, faces = {}, [], []
    for cx, cy in centres:
        face = []
        for x, y in np.array([cx, cy]) + hexagon_cells.corner_offsets(radius):
            key = (round(x, 6), round(y, 6))
            if key not in index:
                index[key] = len(vertices)
                z = 0.0 if sphere_radius is None else \
                    math.sqrt(sphere_radius**2 - x**2 - y**2) - sphere_radius
                vertices.append((x, y, z))
            face.append(index[key] + 1)
        faces.append(face)
    lines = [f'v {x:.9f} {y:.9f} {z:.9f}' for x, y, z in vertices]
    lines += ['f ' + ' '.join(f'{i}/1' for i in face) for face in faces]
    if distort:
        lines = distort(lines)
    path.write_text('\n'.join(lines) + '\n')
    return centres, np.array(vertices)[np.array(faces) - 1]


def obj_facade(tmp_path, name='mesh.obj'):
    text = BASE.replace('{SURFACE}', f'{{type: obj, path: {name}}}')
    (tmp_path / 'facade.yaml').write_text(text)
    return load_facade(tmp_path / 'facade.yaml')


def test_an_obj_hexagon_mesh_gives_one_panel_per_face(tmp_path):
    cell = 0.62 + 0.1 / math.sqrt(3)
    centres, corners = hexagon_mesh_obj(tmp_path / 'mesh.obj', cell,
                                        sphere_radius=SPHERE_RADIUS_M)
    facade = obj_facade(tmp_path)
    assert len(facade) == 12 and facade.panel_kind == 'hexagon'
    np.testing.assert_allclose(np.sort(facade.origin_m[:, 0]), np.sort(centres[:, 0]),
                               atol=1e-9)
    rotation = facade.rotation
    np.testing.assert_allclose(np.einsum('nji,njk->nik', rotation, rotation),
                               np.broadcast_to(np.eye(3), rotation.shape), atol=1e-9)
    normal = graph_normal(SURFACES['dome'][1], *facade.origin_m[:, :2].T)
    assert np.all(np.einsum('ni,ni->n', rotation[..., 2], normal) > 0.999)
    assert np.all(rotation[:, 1, 1] > 0.99)
    # The face's mean circumradius (the lift onto the sphere stretches it) less the joint.
    centroid = corners.mean(axis=1)
    face_radius = np.linalg.norm(corners - centroid[:, None], axis=-1).mean(axis=-1)
    order = [int(np.argmin(np.linalg.norm(centroid - origin, axis=-1)))
             for origin in facade.origin_m]
    np.testing.assert_allclose([panel.circumradius_m for panel in facade.panels],
                               face_radius[order] - 0.1 / math.sqrt(3), rtol=1e-3)
    assert facade.panel_ids[0] == 'r00c00' and facade.panel_ids[-1] == 'r02c03'
    inner = [facade.panel_ids.index(i) for i in ('r01c01', 'r01c02')]
    assert np.all(facade.gaussian_sign[inner] == 1)  # synclastic, from the face normals
    dome = build_facade(facade_text('dome'))
    assert np.all(facade.surface_prefold_rad[inner] > 0.8 * dome.surface_prefold_rad.min())
    assert np.all(facade.surface_prefold_rad[inner] < 1.2 * dome.surface_prefold_rad.max())


def replace_line(number, text):
    def distort(lines):
        return lines[:number] + [text] + lines[number + 1:]
    return distort


def shift_vertex(index, dx, dy, dz):
    def distort(lines):
        fields = lines[index].split()
        x, y, z = (float(f) for f in fields[1:4])
        return lines[:index] + [f'v {x + dx} {y + dy} {z + dz}'] + lines[index + 1:]
    return distort


@pytest.mark.parametrize('distort, message', [
    (lambda lines: lines + ['f 1 2 3 4'],
     r'mesh.obj:\d+: face 13: a hexagon facade takes only hexagonal faces .* got 4 corners'),
    (shift_vertex(0, -0.3, 0.0, 0.0), r'face 1 is not a near-regular hexagon: corner 1 is '
                                      r'0\.[0-9]+ R from its centre'),
    (shift_vertex(0, 0.0, 0.0, 0.2), r'face 1 is not a near-regular hexagon: corner 1 lies '
                                     r'0\.[0-9]+ R off its plane'),
    (lambda lines: [re.sub(r'^f (\S+) (\S+) (\S+)', r'f \2 \1 \3', lines[-12])
                    if line is lines[-12] else line for line in lines],
     r'face 1 is not a near-regular hexagon: side'),
    (lambda lines: lines + ['f 1 2 3 4 5 999'], 'a face refers to a vertex that does not exist'),
    (lambda lines: [line for line in lines if not line.startswith('f')], 'no hexagonal faces'),
])
def test_malformed_obj_hexagon_faces_are_refused_naming_the_face(tmp_path, distort, message):
    hexagon_mesh_obj(tmp_path / 'mesh.obj', 0.68, distort=distort)
    with pytest.raises(FacadeError, match=message) as refused:
        obj_facade(tmp_path)
    assert str(refused.value).startswith('surface.path: ')
    assert len(str(refused.value)) < MESSAGE_LIMIT


def test_a_quad_facade_refuses_a_hexagon_mesh_and_the_other_way_round(tmp_path):
    hexagon_mesh_obj(tmp_path / 'mesh.obj', 0.68)
    quad = textwrap.dedent("""
        name: quad
        site: {latitude_deg: 48.78, longitude_deg: 9.18}
        facade: {azimuth_deg: 180}
        surface: {type: obj, path: mesh.obj}
        grid: {rows: 3, columns: 4}
        panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03}
    """)
    (tmp_path / 'quad.yaml').write_text(quad)
    with pytest.raises(FacadeError, match='only quad faces make panels, got 6 corners'):
        load_facade(tmp_path / 'quad.yaml')


def analytic_flap_curvature(facade, depth, step=1e-4):
    """Return normal curvatures (N, 3) along each panel's flap axes from the graph's form."""
    u, v = facade.origin_m[:, 0], facade.origin_m[:, 1]
    w_u = (depth(u + step, v) - depth(u - step, v)) / (2 * step)
    w_v = (depth(u, v + step) - depth(u, v - step)) / (2 * step)
    w_uu = (depth(u + step, v) - 2 * depth(u, v) + depth(u - step, v)) / step**2
    w_vv = (depth(u, v + step) - 2 * depth(u, v) + depth(u, v - step)) / step**2
    w_uv = (depth(u + step, v + step) - depth(u + step, v - step) - depth(u - step, v + step)
            + depth(u - step, v - step)) / (4 * step**2)
    scale = np.sqrt(1 + w_u**2 + w_v**2)
    curvature = []
    for azimuth in np.radians([150.0, 270.0, 30.0]):
        tangent = (math.cos(azimuth) * facade.rotation[..., 0]
                   + math.sin(azimuth) * facade.rotation[..., 1])
        du, dv = tangent[:, 0], tangent[:, 1]  # a graph's parameters are x and y
        second = (w_uu * du**2 + 2 * w_uv * du * dv + w_vv * dv**2) / scale
        first = np.sum(tangent**2, axis=-1)
        curvature.append(-second / first)  # convex (curving away from the normal) positive
    return np.stack(curvature, axis=-1)


def expected_prefold(facade, curvature):
    """Compute the documented rule with the panel model's own reflection geometry."""
    radius = np.array([panel.circumradius_m for panel in facade.panels])
    sag = np.array([panel.fold_line_sag_m for panel in facade.panels])
    rise = radius**2 / 2 * curvature.mean(axis=-1)
    batch = HexagonBatch(circumradius_m=radius, fold_line_sag_m=sag,
                         hinge_width_m=np.full_like(radius, 0.03),
                         prefold_rad=np.full_like(radius, 0.1),
                         closed_clearance_m=np.full_like(radius, 0.02))
    fold = np.sign(rise) * SectorGeometry(batch, np.abs(rise)).apex_fold_angle_rad
    tilt = -curvature * (radius - (radius / 2 + sag))[:, None] / 2
    return fold + tilt.min(axis=-1)


def test_a_dome_supplies_prefold_from_its_centre_rise_and_takes_some_back_at_the_flaps():
    facade = build_facade(facade_text('dome'))
    curvature = analytic_flap_curvature(facade, SURFACES['dome'][1])
    np.testing.assert_allclose(curvature, 1 / SPHERE_RADIUS_M, rtol=1e-4)  # a sphere
    assert np.all(facade.gaussian_sign == 1)
    np.testing.assert_allclose(facade.surface_prefold_rad, expected_prefold(facade, curvature),
                               rtol=1e-4)
    radius = facade.panels[0].circumradius_m
    rise_only = SectorGeometry(HexagonBatch.from_panels(facade.panels[:1]), np.array(
        [radius**2 / (2 * SPHERE_RADIUS_M)])).apex_fold_angle_rad[0]
    taken = (radius / 2 - 0.06) / 2 / SPHERE_RADIUS_M
    assert facade.surface_prefold_rad[0] == pytest.approx(rise_only - taken, rel=1e-3)
    assert facade.surface_prefold_rad.min() > math.radians(20)  # far more than a quad's
    np.testing.assert_allclose(facade.moulded_prefold_rad, 0.0)
    prefold = np.array([panel.prefold_rad for panel in facade.panels])
    np.testing.assert_allclose(prefold, facade.surface_prefold_rad)


def test_a_saddle_raises_no_centre_and_its_convex_flaps_fold_back_a_little():
    facade = build_facade(facade_text('saddle'))
    curvature = analytic_flap_curvature(facade, SURFACES['saddle'][1])
    assert np.all(facade.gaussian_sign == -1)
    np.testing.assert_allclose(facade.surface_prefold_rad, expected_prefold(facade, curvature),
                               atol=2e-5)
    middle = int(np.argmin(np.linalg.norm(facade.origin_m, axis=-1)))
    # Near the centre: no rise; the flaps at 150 and 30 degrees look along a direction of
    # curvature 0.08 cos(2 * 30 deg) = +0.04 1/m (convex) and fold back by 0.04 (R - r_a) / 2.
    radius = facade.panels[middle].circumradius_m
    back = 0.04 * (radius - (radius / 2 + 0.06)) / 2
    assert facade.surface_prefold_rad[middle] == pytest.approx(-back, rel=0.3)
    assert facade.surface_prefold_rad[middle] < 0
    np.testing.assert_allclose(facade.moulded_prefold_rad + facade.surface_prefold_rad,
                               math.radians(5))


def test_plane_cells_need_the_whole_prefold_moulded():
    facade = build_facade(facade_text('plane'))
    np.testing.assert_allclose(facade.surface_prefold_rad, 0.0, atol=1e-12)
    np.testing.assert_allclose(facade.moulded_prefold_rad, math.radians(5))
    assert np.all(facade.gaussian_sign == 0)
    assert all(panel.circumradius_m == pytest.approx(0.62, abs=1e-9) for panel in facade.panels)


def test_small_rises_fold_by_about_five_thirds_of_the_rise_over_the_sag():
    from flectofold_model.facade.hexagon_prefold import reflection_fold_rad
    rise = np.array([1e-4, -1e-4, 0.0])
    fold = reflection_fold_rad(np.full(3, 0.62), np.full(3, 0.06), rise)
    np.testing.assert_allclose(fold, 5 * rise / (3 * 0.06), rtol=1e-3, atol=1e-15)


def test_concave_patches_are_moulded_or_left_out_by_the_quad_rule():
    text = facade_text('cylinder', **{'radius_m: 5.0': 'radius_m: -20.0'})
    facade = build_facade(text)
    assert np.all(facade.surface_prefold_rad < 0)  # a concave patch folds the wrong way
    assert np.all(facade.moulded_prefold_rad > math.radians(5))
    ids = facade.panel_ids
    limited = build_facade(text + f'overrides: {{{ids[1]}: {{max_moulded_prefold_rad: 0.1}}}}\n')
    assert len(limited) == len(facade) - 1 and ids[1] not in limited.panel_ids
    assert limited.excluded[0][0] == ids[1] and 'mould can add only 5.7 deg' in \
        limited.excluded[0][1]
    assert any('left out' in line for line in limited.report())
    with pytest.raises(FacadeError, match='no patch can carry a panel'):
        build_facade(facade_text('cylinder', **{'radius_m: 5.0': 'radius_m: -5.0'}))


def test_the_report_prints_hexagon_sizes():
    lines = build_facade(facade_text('plane')).report()
    assert 'hexagon panels built' in lines[0]
    assert 'hexagon R 0.620 m (0.999 m2)' in lines[1] and 'moulded 5.0 deg' in lines[1]


def test_a_quad_panel_type_is_todays_facade_exactly():
    plain = load_facade(DEFAULT_FACADE)
    text = DEFAULT_FACADE.read_text().replace('panel:\n', 'panel:\n  type: quad\n')
    typed = build_facade(text)
    assert typed.panel_kind == plain.panel_kind == 'quad'
    assert typed.panels == plain.panels and typed.panel_ids == plain.panel_ids
    np.testing.assert_array_equal(typed.rotation, plain.rotation)
    np.testing.assert_array_equal(typed.surface_prefold_rad, plain.surface_prefold_rad)


def test_the_embedded_hexagon_facade_matches_the_quad_demonstrator():
    hexagon = load_facade('hexagon_6x6')
    quad = load_facade(DEFAULT_FACADE)
    assert hexagon.panel_kind == 'hexagon' and len(hexagon) == 30 and not hexagon.excluded
    assert hexagon.site == quad.site and hexagon.azimuth_deg == quad.azimuth_deg
    assert hexagon.control == quad.control
    area = np.array([panel.area_m2 for panel in hexagon.panels])
    np.testing.assert_allclose(area, HEXAGON_MODULE.area_m2, rtol=0.01)
    assert 0.75 < area.sum() / sum(p.length_m * p.width_m for p in quad.panels) < 1.0
    assert np.all(np.abs(hexagon.origin_m[:, :2]) < 3.3 - 0.5)
    assert hexagon.panel_ids[0] == 'r00c00' and hexagon.panel_ids[-1] == 'r05c04'
    assert load_facade(DATA_DIRECTORY / 'hexagon_6x6.yaml').panels == hexagon.panels


def test_an_embedded_name_never_shadows_a_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert facade_path('hexagon_6x6') == DATA_DIRECTORY / 'hexagon_6x6.yaml'
    (tmp_path / 'hexagon_6x6').write_text(DEFAULT_FACADE.read_text())
    assert facade_path('hexagon_6x6') == tmp_path / 'hexagon_6x6' or \
        facade_path('hexagon_6x6').resolve() == (tmp_path / 'hexagon_6x6').resolve()
    assert load_facade('hexagon_6x6').panel_kind == 'quad'
    with pytest.raises(FacadeError, match='cannot read.*embedded descriptions: '
                                          'demonstrator_6x6, hexagon_6x6'):
        load_facade('hexagon_7x7')


@pytest.mark.parametrize('replace, message', [
    (('type: hexagon', 'type: triangle'), "panel.type: must be 'quad' or 'hexagon', got"),
    (('type: hexagon', 'type: [hexagon]'), 'panel.type: must be a str'),
    (('circumradius_m: 0.62', 'circumradius_m: big'), 'panel.circumradius_m: must be a number'),
    (('circumradius_m: 0.62', 'circumradius_m: .nan'), 'panel.circumradius_m: must be finite'),
    (('circumradius_m: 0.62', 'circumradius_m: -0.62'), 'panel.circumradius_m: must be positive'),
    (('circumradius_m: 0.62, fold_line_sag_m: 0.06, hinge_width_m: 0.03',
      'circumradius_m: 0.02, fold_line_sag_m: 0.002, hinge_width_m: 0.001'),
     'grid.gap_m: must lie in'),
    (('gap_m: 0.1}', 'gap_m: 0.0}', 'circumradius_m: 0.62, fold_line_sag_m: 0.06, '
      'hinge_width_m: 0.03', 'circumradius_m: 0.01, fold_line_sag_m: 0.001, '
      'hinge_width_m: 0.001'), 'at most 100 of each'),
    (('circumradius_m: 0.62', 'circumradius_m: 5.0'), 'no whole hexagonal cell'),
    (('circumradius_m: 0.62, ', ''), 'panel.circumradius_m: missing'),
    (('fold_line_sag_m: 0.06, ', ''), 'panel.fold_line_sag_m: missing'),
    (('fold_line_sag_m: 0.06', 'fold_line_sag_m: 0.3'), r'panel \(r00c00\): .*leaves no flap'),
    (('hinge_width_m: 0.03', 'hinge_width_m: 0.0001'),
     r'panel \(r00c00\): .*cannot absorb'),
    (('hinge_width_m: 0.03}', 'hinge_width_m: 0.03, fold_radius_m: 1.0}'),
     'panel.fold_radius_m: not used by a hexagon panel'),
    (('hinge_width_m: 0.03}', 'hinge_width_m: 0.03, min_prefold_rad: 0}'),
     r'panel.min_prefold_rad: must lie in \(0, pi/2\)'),
    (('hinge_width_m: 0.03}', 'hinge_width_m: 0.03, max_moulded_prefold_rad: -0.1}'),
     'panel.max_moulded_prefold_rad: must lie in'),
    (('hinge_width_m: 0.03}', 'hinge_width_m: 0.03, colour: red}'), 'panel.colour: unknown key'),
    (('grid: {gap_m: 0.1}', 'grid: {gap_m: 0.1, rows: 6}'),
     'grid.rows: not used by a hexagon facade'),
    (('grid: {gap_m: 0.1}', 'grid: {gap_m: -0.1}'), 'grid.gap_m: must lie in'),
    (('type: hexagon', 'type: ' + 'h' * 1_000_000), 'panel.type: must be'),
])
def test_bad_hexagon_keys_are_refused_with_the_key(replace, message):
    with pytest.raises(FacadeError, match=message) as refused:
        build_facade(facade_text('plane', **dict(zip(replace[::2], replace[1::2]))))
    assert len(str(refused.value)) < MESSAGE_LIMIT


@pytest.mark.parametrize('overrides, message', [
    ('{r00c00: {type: quad}}', 'overrides.r00c00.type: a facade is all quad or all hexagon'),
    ('{r00c00: {circumradius_m: 0.5}}', 'overrides.r00c00.circumradius_m: the lattice sets'),
    ('{r00c00: {fold_radius_m: 1.0}}', 'overrides.r00c00.fold_radius_m: unknown key'),
    ('{r00c00: {hinge_width_m: .inf}}', 'overrides.r00c00.hinge_width_m: must be finite'),
    ('{r00c00: {min_prefold_rad: 2.0}}', 'overrides.r00c00.min_prefold_rad: must lie in'),
    ('{r99c99: {hinge_width_m: 0.02}}', 'overrides.r99c99: no such panel'),
])
def test_bad_hexagon_overrides_are_refused(overrides, message):
    with pytest.raises(FacadeError, match=message):
        build_facade(facade_text('plane') + f'overrides: {overrides}\n')


def test_a_quad_facade_refuses_hexagon_keys_and_a_mix():
    quad = BASE.replace('{SURFACE}', SURFACES['plane'][0]).replace(
        'grid: {gap_m: 0.1}', 'grid: {rows: 3, columns: 4, gap_m: 0.1}').replace(
        'panel: {type: hexagon, circumradius_m: 0.62, fold_line_sag_m: 0.06, ',
        'panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, ')
    assert len(build_facade(quad)) == 12
    with pytest.raises(FacadeError, match='panel.circumradius_m: not used by a quad panel'):
        build_facade(quad.replace('hinge_width_m: 0.03}', 'hinge_width_m: 0.03, '
                                                          'circumradius_m: 0.6}'))
    with pytest.raises(FacadeError, match='overrides.r00c01.type: a facade is all quad'):
        build_facade(quad + 'overrides: {r00c01: {type: hexagon}}\n')
    with pytest.raises(FacadeError, match='grid: missing section'):
        build_facade(quad.replace('grid: {rows: 3, columns: 4, gap_m: 0.1}\n', ''))
    assert len(build_facade(facade_text('plane').replace('grid: {gap_m: 0.1}\n', ''))) > 0


def test_a_too_curved_dome_is_refused_naming_the_panel():
    text = facade_text('plane', **{'{type: plane, width_m: 4.4, height_m: 3.3}':
                                   '{type: dome, width_m: 1.3, height_m: 1.45, semi_axis_u_m: '
                                   '0.7, semi_axis_v_m: 0.75, depth_m: 0.7}',
                                   'gap_m: 0.1': 'gap_m: 0.0'})
    with pytest.raises(FacadeError, match=r'surface: the patch of r00c00 .* too curved'):
        build_facade(text)


def laughs(levels=10):
    items = ['&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]']
    items += [f'&l{i} [' + ', '.join([f'*l{i - 1}'] * 9) + ']' for i in range(1, levels)]
    return '[' + ', '.join(items) + ']'


def test_billion_laughs_in_a_hexagon_key_is_refused_in_bounded_memory():
    child = textwrap.dedent("""
        import resource, sys
        resource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30))
        from flectofold_model.facade.description import build_facade, FacadeError
        try:
            build_facade(sys.stdin.read())
        except FacadeError as error:
            print(error)
        else:
            print('accepted')
    """)
    bomb = facade_text('plane', **{'circumradius_m: 0.62': f'circumradius_m: {laughs()}'})
    run = subprocess.run([sys.executable, '-c', child], input=bomb, text=True,
                         capture_output=True, timeout=60,
                         env=dict(os.environ, OPENBLAS_NUM_THREADS='1'))
    assert run.returncode == 0, run.stderr[-2000:]
    assert 'aliases (*name) are not accepted' in run.stdout
    assert len(run.stdout) < MESSAGE_LIMIT
