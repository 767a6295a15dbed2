"""The hexagonal panel's closure map: the cone closes, the map is monotone and invertible."""

import math

import numpy as np
import pytest

from flectofold_model import HEXAGON_MODULE, HexagonBatch, HexagonFoldModel, HexagonPanel
from flectofold_model.kinematics import hexagon_cone as cone
from flectofold_model.kinematics.hexagon_closure import MAX_APEX_FOLD_ANGLE_RAD
from flectofold_model.kinematics.hexagon_panel import SECTOR_RAD
from flectofold_model.kinematics.hexagon_reflection import MID_SECTOR_RAD, SectorGeometry

CLOSURES = np.linspace(0.0, 1.0, 11)


@pytest.fixture(scope='module')
def model():
    panels = [HEXAGON_MODULE,
              HexagonPanel(circumradius_m=0.4, fold_line_sag_m=0.02, hinge_width_m=0.02,
                           prefold_rad=math.radians(3.0)),
              HexagonPanel(circumradius_m=0.9, fold_line_sag_m=0.12, hinge_width_m=0.05,
                           prefold_rad=math.radians(8.0), closed_clearance_m=0.05)]
    return HexagonFoldModel(HexagonBatch.from_panels(panels))


def test_the_cone_is_unit_speed_and_closes_around_the_centre():
    tilt = np.radians([0.5, 5.0, 12.0])
    amplitude = cone.cone_amplitude_rad(tilt)
    np.testing.assert_allclose(cone.sector_turn_rad(tilt, amplitude), SECTOR_RAD, rtol=1e-12)
    phi = np.linspace(0.01, SECTOR_RAD - 0.01, 23)
    step = 1e-6
    rate = (cone.ruling_direction(tilt, amplitude, phi + step)
            - cone.ruling_direction(tilt, amplitude, phi - step)) / (2 * step)
    np.testing.assert_allclose(np.linalg.norm(rate, axis=-1), 1.0, atol=1e-6)
    np.testing.assert_allclose(cone.ruling_direction_rate(tilt, amplitude, phi), rate, atol=1e-6)
    end = cone.ruling_direction(tilt, amplitude, np.array([SECTOR_RAD]))[:, 0]
    np.testing.assert_allclose(np.degrees(np.arctan2(end[:, 1], end[:, 0])), -150.0, atol=1e-9)
    np.testing.assert_allclose(end[:, 2], -np.sin(tilt), atol=1e-12)


def test_spokes_keep_their_length_and_vertices_move_in_by_pythagoras(model):
    state = model.state_from_closure(0.7)
    geometry = SectorGeometry(model.batch, state.centre_rise_m)
    vertex = geometry.on_cone(np.array([0.0]), model.batch.circumradius_m[:, None])[:, 0]
    radius = model.batch.circumradius_m
    np.testing.assert_allclose(vertex[:, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.hypot(vertex[:, 0], vertex[:, 1]),
                               radius - state.vertex_displacement_m, rtol=1e-12)
    np.testing.assert_allclose(state.vertex_displacement_m,
                               radius - np.sqrt(radius ** 2 - state.centre_rise_m ** 2))


def test_open_state_holds_only_the_prefold(model):
    state = model.state_from_closure(0.0)
    np.testing.assert_allclose(state.apex_fold_angle_rad, model.batch.prefold_rad, rtol=1e-9)
    np.testing.assert_allclose(state.tip_travel_m, 0.0, atol=1e-9)


def test_closure_is_monotone_and_invertible(model):
    states = [model.state_from_closure(c) for c in CLOSURES]
    rise = np.stack([s.centre_rise_m for s in states])
    fold = np.stack([s.apex_fold_angle_rad for s in states])
    travel = np.stack([s.tip_travel_m for s in states])
    assert np.all(np.diff(rise, axis=0) > 0)
    assert np.all(np.diff(fold, axis=0) > 0)
    assert np.all(np.diff(travel, axis=0) > 0)
    for closure, state in zip(CLOSURES, states):
        np.testing.assert_allclose(model.closure_from_fold_angle(state.apex_fold_angle_rad),
                                   closure, atol=1e-9)
        np.testing.assert_allclose(model.state_from_rise(state.centre_rise_m).closure, closure,
                                   atol=1e-9)


def test_the_fold_amplifies_the_centre_stroke(model):
    state = model.state_from_closure(0.5)
    assert np.all(state.amplification > 3.0)
    assert np.all(state.vertex_displacement_m < state.centre_rise_m / 10)


def test_closed_limit_keeps_the_flaps_apart(model):
    geometry = SectorGeometry(model.batch, model.closed_rise_m)
    tip = geometry.flap_tip
    # Three tips on a circle about the axis: neighbours are sqrt(3) times its radius apart.
    gap = math.sqrt(3.0) * np.hypot(tip[:, 0], tip[:, 1])
    assert np.all(gap >= model.batch.closed_clearance_m)
    np.testing.assert_allclose(np.minimum(model.closed_fold_angle_rad, MAX_APEX_FOLD_ANGLE_RAD),
                               model.closed_fold_angle_rad)
    assert np.all(model.closed_fold_angle_rad > math.radians(60.0))


def test_a_wide_clearance_stops_the_tips_before_the_lean_limit():
    wide = HexagonPanel(circumradius_m=0.62, fold_line_sag_m=0.01, hinge_width_m=0.03,
                        prefold_rad=0.05, closed_clearance_m=0.6)
    model = HexagonFoldModel(HexagonBatch.repeat(wide, 1))
    tip = SectorGeometry(model.batch, model.closed_rise_m).flap_tip
    assert model.closed_fold_angle_rad[0] < MAX_APEX_FOLD_ANGLE_RAD - 0.1
    np.testing.assert_allclose(math.sqrt(3.0) * np.hypot(tip[:, 0], tip[:, 1]), 0.6, atol=1e-6)


def test_crease_passes_through_the_ends_and_the_apex_and_the_hinge_absorbs_the_rest(model):
    for closure in (0.0, 0.5, 1.0):
        geometry = SectorGeometry(model.batch, model.state_from_closure(closure).centre_rise_m)
        radius = geometry.crease_radius_m(np.array([0.0, MID_SECTOR_RAD, SECTOR_RAD]))
        np.testing.assert_allclose(radius[:, 0], model.batch.circumradius_m, rtol=1e-9)
        np.testing.assert_allclose(radius[:, 1], model.batch.apex_radius_m, rtol=1e-9)
        np.testing.assert_allclose(radius[:, 2], model.batch.circumradius_m, rtol=1e-9)
    assert np.all(model.crease_mismatch_m <= model.batch.hinge_width_m)


def test_a_hinge_narrower_than_the_crease_mismatch_is_refused():
    narrow = HexagonPanel(circumradius_m=0.62, fold_line_sag_m=0.06, hinge_width_m=0.005,
                          prefold_rad=0.09)
    with pytest.raises(ValueError, match='cannot absorb the .* mm'):
        HexagonFoldModel(HexagonBatch.repeat(narrow, 1))


def test_prefold_beyond_the_closed_limit_is_refused():
    # A clearance this wide stops the tips long before the flaps reach the pre-fold.
    crowded = HexagonPanel(circumradius_m=0.62, fold_line_sag_m=0.002, hinge_width_m=0.03,
                           prefold_rad=1.5, closed_clearance_m=0.6)
    with pytest.raises(ValueError, match='beyond the closed limit'):
        HexagonFoldModel(HexagonBatch.repeat(crowded, 1))


def test_batch_equals_panels_one_at_a_time(model):
    closure = np.array([0.2, 0.6, 0.9])
    together = model.state_from_closure(closure)
    for index in range(3):
        alone = HexagonFoldModel(model.batch.take([index])).state_from_closure(closure[index])
        np.testing.assert_allclose(alone.centre_rise_m, together.centre_rise_m[index],
                                   rtol=1e-12)


@pytest.mark.parametrize('closure, message', [
    (1.2, r'closure must lie in \[0, 1\]'),
    (float('nan'), 'closure must be finite'),
    ('half', 'closure must be a real number'),
    (np.ones(5), 'expected a scalar or'),
])
def test_bad_closure_is_refused(model, closure, message):
    with pytest.raises((ValueError, TypeError), match=message):
        model.state_from_closure(closure)


def test_rise_outside_the_stroke_is_refused(model):
    with pytest.raises(ValueError, match='its closed value'):
        model.state_from_rise(model.closed_rise_m + 0.01)
    with pytest.raises(ValueError, match='its open value'):
        model.state_from_rise(0.0)
    with pytest.raises(TypeError, match='needs a HexagonBatch'):
        HexagonFoldModel([HEXAGON_MODULE])


def test_shape_table_agrees_with_the_exact_map(model):
    table = model.shape_table(samples=129)
    closures = np.linspace(0.0, 1.0, 129)
    for index in (0, 64, 128):
        exact = model.state_from_closure(closures[index]).centre_rise_m
        np.testing.assert_allclose(table[:, index], exact, rtol=1e-12)
    assert np.all(np.diff(table, axis=1) > 0)
    with pytest.raises(ValueError, match='at least 2'):
        model.shape_table(samples=1)
