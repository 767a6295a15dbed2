"""Facade descriptions: tessellation per surface type, pre-fold, OBJ import and bad YAML."""

import math
import textwrap

import numpy as np
import pytest

from flectofold_model.facade import surfaces
from flectofold_model.facade.description import (build_facade, DEFAULT_FACADE, FacadeError,
                                                 load_facade)

BASE = """
name: test
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {SURFACE}
grid: {rows: 3, columns: 4, gap_m: 0.1, midrib_along: v}
panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03}
"""

SURFACES = {
    'plane': '{type: plane, width_m: 4.4, height_m: 3.3}',
    'cylinder': '{type: cylinder, width_m: 4.4, height_m: 3.3, radius_m: 10.0}',
    'dome': ('{type: dome, width_m: 4.4, height_m: 3.3, semi_axis_u_m: 8, semi_axis_v_m: 8, '
             'depth_m: 3}'),
    'saddle': ('{type: saddle, width_m: 4.4, height_m: 3.3, curvature_u_per_m: -0.08, '
               'curvature_v_per_m: 0.08}'),
}


def facade_text(kind, **replace):
    text = BASE.replace('{SURFACE}', SURFACES[kind])
    for old, new in replace.items():
        text = text.replace(old, new)
    return text


@pytest.mark.parametrize('kind', sorted(SURFACES))
def test_every_surface_tessellates_into_framed_outward_panels(kind):
    facade = build_facade(facade_text(kind))
    assert len(facade) == 12 and len(set(facade.panel_ids)) == 12
    rotation = facade.rotation
    np.testing.assert_allclose(np.einsum('nji,njk->nik', rotation, rotation),
                               np.broadcast_to(np.eye(3), rotation.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(rotation), 1.0, atol=1e-12)
    assert np.all(rotation[:, 2, 2] > 0.8)  # normals point out of the facade
    assert np.all(rotation[:, 1, 0] > 0.9)  # mid-ribs run up the facade (midrib_along: v)
    for panel in facade.panels:
        assert 0.9 < panel.length_m < 1.1 and 0.9 < panel.width_m < 1.1


def test_saddle_is_anticlastic_and_supplies_the_prefold():
    facade = build_facade(facade_text('saddle'))
    assert np.all(facade.gaussian_sign == -1)
    assert np.all(facade.surface_prefold_rad > math.radians(5))
    np.testing.assert_allclose(facade.moulded_prefold_rad, 0.0)
    prefold = np.array([panel.prefold_rad for panel in facade.panels])
    np.testing.assert_allclose(prefold, facade.surface_prefold_rad)


def test_plane_needs_the_whole_prefold_moulded():
    facade = build_facade(facade_text('plane'))
    np.testing.assert_allclose(facade.surface_prefold_rad, 0.0, atol=1e-9)
    np.testing.assert_allclose(facade.moulded_prefold_rad, math.radians(5))


def test_dome_is_synclastic_and_its_cross_curvature_takes_prefold_back():
    facade = build_facade(facade_text('dome'))
    assert np.all(facade.gaussian_sign == 1)
    sag_only = build_facade(facade_text('saddle'))  # same convexity along the mid-rib
    assert np.all(facade.surface_prefold_rad < sag_only.surface_prefold_rad)
    assert np.all(facade.surface_prefold_rad > 0)  # still folds toward closing


def test_a_saddle_turned_the_wrong_way_is_reported_and_fixed_by_turning_the_midribs():
    text = facade_text('saddle', **{'curvature_u_per_m: -0.08': 'curvature_u_per_m: 0.3',
                                    'curvature_v_per_m: 0.08': 'curvature_v_per_m: -0.3'})
    with pytest.raises(FacadeError, match='r00c00: the surface folds it -2'):
        build_facade(text)
    auto = build_facade(text.replace('midrib_along: v', 'midrib_along: auto'))
    assert len(auto) == 12  # turning the mid-ribs to the convex direction fixes it
    assert np.all(np.abs(auto.rotation[:, 0, 0]) > 0.85)  # mid-ribs now run across


def test_patches_that_cannot_fold_the_right_way_are_reported_and_left_out():
    text = facade_text('plane') + 'overrides: {r01c02: {max_moulded_prefold_rad: 0.0}}\n'
    facade = build_facade(text)
    assert len(facade) == 11 and 'r01c02' not in facade.panel_ids
    assert facade.excluded[0][0] == 'r01c02'
    assert 'mould can add only 0.0 deg' in facade.excluded[0][1]
    assert any('left out' in line for line in facade.report())


def test_default_demonstrator_is_the_6x6_anticlastic_array():
    facade = load_facade(DEFAULT_FACADE)
    assert len(facade) == 36 and not facade.excluded
    assert np.all(facade.gaussian_sign == -1)
    area = np.mean([panel.length_m * panel.width_m for panel in facade.panels])
    assert area == pytest.approx(1.0, rel=0.15)
    assert facade.panel_ids[0] == 'r00c00' and facade.panel_ids[-1] == 'r05c05'


def test_south_facade_frames_in_enu():
    facade = build_facade(facade_text('plane'))
    np.testing.assert_allclose(facade.facade_to_enu @ [0, 0, 1], [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(facade.facade_to_enu @ [1, 0, 0], [1, 0, 0], atol=1e-12)
    sun_south_30 = np.array([0, -math.cos(math.radians(30)), math.sin(math.radians(30))])
    in_panels = facade.sun_in_panel_frames(sun_south_30)
    np.testing.assert_allclose(in_panels[:, 2], math.cos(math.radians(30)), atol=1e-12)
    np.testing.assert_allclose(in_panels[:, 0], math.sin(math.radians(30)), atol=1e-12)


def test_obj_quad_mesh_matches_the_parametric_saddle(tmp_path):
    saddle = surfaces.saddle(4.4, 3.3, -0.08, 0.08)
    u, v = np.meshgrid(np.linspace(-2.2, 2.2, 5), np.linspace(-1.65, 1.65, 4))
    points = saddle.point(u, v).reshape(-1, 3)
    lines = [f'v {x:.9f} {y:.9f} {z:.9f}' for x, y, z in points]
    for row in range(3):
        for column in range(4):
            a = row * 5 + column + 1
            lines.append(f'f {a}/1 {a + 1}/1 {a + 6} {a + 5}')
    (tmp_path / 'saddle.obj').write_text('\n'.join(lines) + '\n')
    text = BASE.replace('{SURFACE}', '{type: obj, path: saddle.obj}')
    (tmp_path / 'facade.yaml').write_text(text)
    facade = load_facade(tmp_path / 'facade.yaml')
    parametric = build_facade(facade_text('saddle'))
    assert len(facade) == 12
    inner = [i for i, pid in enumerate(facade.panel_ids) if pid in ('r01c01', 'r01c02')]
    assert np.all(facade.gaussian_sign[inner] == -1)
    np.testing.assert_allclose(facade.origin_m[:, :2], parametric.origin_m[:, :2], atol=0.02)


@pytest.mark.parametrize('text, message', [
    ('site: [1, 2', 'malformed YAML'),
    ('- just\n- a list', 'mapping of sections'),
    (BASE.replace('{SURFACE}', SURFACES['plane']) + 'colour: red\n', 'colour: unknown key'),
    (facade_text('plane', **{'rows: 3': 'rows: three'}), 'grid.rows: must be a whole number'),
    (facade_text('plane', **{'rows: 3': 'rows: 0'}), 'grid.rows: must lie in'),
    (facade_text('plane', **{'azimuth_deg: 180': 'azimuth_deg: .nan'}), 'must be finite'),
    (facade_text('plane', **{'azimuth_deg: 180': 'azimuth_deg: 400'}), 'facade.azimuth_deg'),
    (facade_text('plane', **{'latitude_deg: 48.78': 'latitude_deg: 95'}), 'latitude'),
    (facade_text('plane', **{'width_m: 4.4': 'width_m: -4.4'}), 'surface.width_m'),
    (facade_text('plane', **{'gap_m: 0.1': 'gap_m: 1.05'}), 'leaves no flap'),
    (facade_text('plane', **{'fold_radius_m: 1.0': 'fold_radius_m: 0.3'}), 'cannot span'),
    (facade_text('cylinder', **{'radius_m: 10.0': 'radius_m: 1.0'}), 'radius_m'),
    (facade_text('plane', **{'type: plane': 'type: blob'}), 'surface.type: must be one of'),
    (facade_text('plane', **{'height_m: 3.3}': 'height_m: 3.3, radius_m: 4}'}),
     'not used by a plane'),
    (facade_text('plane') + 'overrides: {r09c09: {hinge_width_m: 0.05}}\n', 'no such panel'),
    (facade_text('plane') + 'control: {shading_target: 1.5}\n', 'shading_target'),
    (facade_text('plane') + 'control: {wind_on_m_s: 5, wind_off_m_s: 9}\n', 'control'),
    (facade_text('plane') + 'control: {speed: 3}\n', 'control.speed: unknown key'),
    (BASE.replace('{SURFACE}', '{type: obj, path: missing.obj}'), 'surface.path'),
])
def test_bad_descriptions_are_refused_with_the_key(text, message):
    with pytest.raises(FacadeError, match=message):
        build_facade(textwrap.dedent(text))


def test_obj_with_triangles_is_refused(tmp_path):
    (tmp_path / 'tri.obj').write_text('v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n')
    (tmp_path / 'facade.yaml').write_text(BASE.replace('{SURFACE}',
                                                       '{type: obj, path: tri.obj}'))
    with pytest.raises(FacadeError, match='only quad faces'):
        load_facade(tmp_path / 'facade.yaml')


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(FacadeError, match='cannot read'):
        load_facade(tmp_path / 'nope.yaml')
