"""Hexagonal panel descriptions, their fold lines, and the generic panel-kind interface."""

import math

import numpy as np
import pytest

from flectofold_model import (batch_of, DEMONSTRATOR_MODULE, fold_mesh, fold_model_of,
                              FoldModel, HEXAGON_MODULE, HexagonBatch, HexagonFoldModel,
                              HexagonPanel, panel_kind, PanelBatch)
from flectofold_model.kinematics.hexagon_fold_lines import (control_points_m, drawn_radius_m,
                                                            fold_line_points_m)
from flectofold_model.kinematics.hexagon_panel import hexagon_radius_m, SECTOR_RAD


def test_the_module_is_a_square_metre_hexagon():
    assert HEXAGON_MODULE.area_m2 == pytest.approx(1.0, abs=0.01)
    assert HEXAGON_MODULE.across_flats_m == pytest.approx(math.sqrt(3) * 0.62)


def test_fold_line_runs_from_vertex_to_vertex_through_its_apex():
    batch = HexagonBatch.repeat(HEXAGON_MODULE, 1)
    points = fold_line_points_m(batch, [0.0, 0.5, 1.0])[0]
    radius = HEXAGON_MODULE.circumradius_m
    np.testing.assert_allclose(points[0], [0.0, radius], atol=1e-15)
    np.testing.assert_allclose(points[2], radius * np.array([math.cos(7 * math.pi / 6),
                                                             math.sin(7 * math.pi / 6)]))
    apex = np.hypot(*points[1])
    assert apex == pytest.approx(radius / 2 + HEXAGON_MODULE.fold_line_sag_m)
    # The extra control point sits on the centre-to-tip axis (150 degrees).
    control = control_points_m(batch)[0, 1]
    assert math.degrees(math.atan2(control[1], control[0])) == pytest.approx(150.0)


def test_drawn_fold_line_bulges_toward_the_flap_and_stays_inside_the_hexagon():
    batch = HexagonBatch.repeat(HEXAGON_MODULE, 1)
    phi = np.linspace(0.0, SECTOR_RAD, 41)
    drawn = drawn_radius_m(batch, phi)[0]
    straight = (HEXAGON_MODULE.circumradius_m / 2) / np.cos(phi - SECTOR_RAD / 2)
    edge = hexagon_radius_m(HEXAGON_MODULE.circumradius_m, phi)
    assert np.all(drawn[1:-1] > straight[1:-1])
    assert np.all(drawn[1:-1] < edge[1:-1])
    # At mid-span the flap is R / 2 - sag wide, apex to tip.
    assert edge[20] - drawn[20] == pytest.approx(HEXAGON_MODULE.circumradius_m / 2
                                                 - HEXAGON_MODULE.fold_line_sag_m)


def test_hexagon_outline_radius():
    radius = hexagon_radius_m(1.0, np.array([0.0, math.pi / 6, math.pi / 3, SECTOR_RAD]))
    np.testing.assert_allclose(radius, [1.0, math.sqrt(3) / 2, 1.0, 1.0])


@pytest.mark.parametrize('name, value, error, message', [
    ('circumradius_m', -0.5, ValueError, 'circumradius_m must be positive'),
    ('circumradius_m', float('nan'), ValueError, 'must be finite'),
    ('circumradius_m', '0.6', TypeError, 'must be a real number'),
    ('fold_line_sag_m', 0.0, ValueError, 'fold_line_sag_m must be positive'),
    ('fold_line_sag_m', 0.3, ValueError, 'leaves no flap'),
    ('hinge_width_m', 0.28, ValueError, 'leaves no flap'),
    ('prefold_rad', 0.0, ValueError, 'prefold_rad must lie in (0, pi/2)'),
    ('prefold_rad', 2.0, ValueError, 'prefold_rad must lie in (0, pi/2)'),
    ('closed_clearance_m', -0.01, ValueError, 'must not be negative'),
    ('closed_clearance_m', True, TypeError, 'must be a real number'),
])
def test_bad_hexagon_is_refused_with_the_reason(name, value, error, message):
    values = {'circumradius_m': 0.62, 'fold_line_sag_m': 0.06, 'hinge_width_m': 0.03,
              'prefold_rad': 0.09, name: value}
    with pytest.raises(error, match=message.replace('(', r'\(').replace(')', r'\)')):
        HexagonPanel(**values)


def test_batch_of_builds_the_kind_and_refuses_a_mix():
    assert isinstance(batch_of([HEXAGON_MODULE] * 2), HexagonBatch)
    assert isinstance(batch_of([DEMONSTRATOR_MODULE]), PanelBatch)
    assert panel_kind(HEXAGON_MODULE) == 'hexagon'
    assert panel_kind(PanelBatch.from_panels([DEMONSTRATOR_MODULE])) == 'quad'
    with pytest.raises(ValueError, match='different kinds'):
        batch_of([HEXAGON_MODULE, DEMONSTRATOR_MODULE])
    with pytest.raises(TypeError, match='not a panel of a known kind'):
        panel_kind('hexagon')
    with pytest.raises(TypeError, match='not a HexagonPanel'):
        HexagonBatch.from_panels([DEMONSTRATOR_MODULE])


def test_both_kinds_answer_the_generic_interface():
    quad = fold_model_of([DEMONSTRATOR_MODULE])
    hexagon = fold_model_of([HEXAGON_MODULE])
    assert isinstance(quad, FoldModel) and isinstance(hexagon, HexagonFoldModel)
    state = quad.state_from_closure(0.4)
    np.testing.assert_array_equal(state.shape_parameter, state.elastica_k)
    np.testing.assert_array_equal(quad.mesh(state.shape_parameter).vertices,
                                  fold_mesh(quad.batch, state.elastica_k).vertices)
    np.testing.assert_allclose(quad.shape_from_fold_angle(state.apex_fold_angle_rad),
                               state.elastica_k, rtol=1e-9)
    hex_state = hexagon.state_from_closure(0.4)
    np.testing.assert_array_equal(hex_state.shape_parameter, hex_state.centre_rise_m)
    np.testing.assert_allclose(hexagon.state_from_shape(hex_state.shape_parameter).closure, 0.4,
                               atol=1e-9)
    np.testing.assert_allclose(hexagon.shape_from_fold_angle(hex_state.apex_fold_angle_rad),
                               hex_state.centre_rise_m, rtol=1e-9)
    for model in (quad, hexagon):
        np.testing.assert_allclose(model.state_from_shape(model.open_shape).closure, 0.0,
                                   atol=1e-9)
        np.testing.assert_allclose(model.state_from_shape(model.closed_shape).closure, 1.0,
                                   atol=1e-9)
