"""The closure map and the reflection construction's published trends."""

import math

import numpy as np
import pytest

from flectofold_model import DEMONSTRATOR_MODULE, FoldModel, PanelBatch, PanelGeometry, PROTOTYPE
from flectofold_model.kinematics import reflection


def study_panel(radius_m, prefold_rad=0.0):
    """Build the paper's study panel: 520 x 420 mm, only the fold radius changing."""
    return PanelGeometry.with_lens_midrib(0.52, 0.42, radius_m, 0.02, 0.02,
                                          prefold_rad=prefold_rad)


@pytest.fixture
def model():
    panels = [PROTOTYPE, DEMONSTRATOR_MODULE, study_panel(0.5), study_panel(1.0, 0.1)]
    return FoldModel(PanelBatch.from_panels(panels))


@pytest.mark.parametrize('radius_m, fold_deg, displacement_mm, sag_mm, local_deg, mismatch_mm', [
    (0.50, 90, 26.0, 72.9, 107.6, 5.9),
    (0.75, 30, 0.74, 12.5, 37.7, 3.0),
    (0.75, 60, 3.4, 26.9, 72.8, 3.0),
    (0.75, 90, 10.4, 46.5, 104.3, 3.1),
    (1.00, 90, 5.7, 34.4, 103.2, 2.1),
])
def test_reproduces_the_derived_table(radius_m, fold_deg, displacement_mm, sag_mm, local_deg,
                                      mismatch_mm):
    """``docs/references.md`` section 4, derived table: three-point plane, L = 0.52 m."""
    fold_model = FoldModel(PanelBatch.from_panels([study_panel(radius_m)]))
    closure = fold_model.closure_from_fold_angle(math.radians(fold_deg))
    state = fold_model.state_from_closure(closure)
    assert state.support_displacement_m[0] * 1e3 == pytest.approx(displacement_mm, abs=0.1)
    assert state.midrib_sag_m[0] * 1e3 == pytest.approx(sag_mm, abs=0.1)
    local = reflection.local_law_apex_fold_angle(fold_model.batch, state.elastica_k)
    assert math.degrees(local[0]) == pytest.approx(local_deg, abs=0.15)
    mismatch = reflection.crease_mismatch_m(fold_model.batch, state.elastica_k)
    assert mismatch[0] * 1e3 == pytest.approx(mismatch_mm, abs=0.15)


def test_zero_displacement_gives_only_the_prefold(model):
    state = model.state_from_displacement(0.0)
    np.testing.assert_allclose(state.apex_fold_angle_rad, model.batch.prefold_rad, atol=1e-12)
    np.testing.assert_allclose(state.closure, 0.0, atol=1e-12)
    np.testing.assert_allclose(state.tip_travel_m, 0.0, atol=1e-12)
    assert np.all(np.isnan(state.amplification))


def test_closure_is_monotone_and_invertible_in_displacement(model):
    fractions = np.linspace(0.0, 1.0, 101)[:, None]
    closures = np.array([model.state_from_displacement(f * model.max_support_displacement_m)
                         .closure for f in fractions])
    assert np.all(np.diff(closures, axis=0) > 0)
    np.testing.assert_allclose(closures[-1], 1.0, atol=1e-9)
    targets = np.array([0.0, 0.37, 0.81, 1.0])
    state = model.state_from_closure(targets)
    back = model.state_from_displacement(state.support_displacement_m)
    np.testing.assert_allclose(back.closure, targets, atol=1e-9)
    np.testing.assert_allclose(back.elastica_k, state.elastica_k, atol=1e-12)


def test_fold_angle_closure_maps_are_inverse(model):
    closure = np.array([0.0, 0.25, 0.5, 1.0])
    fold = model.fold_angle_from_closure(closure)
    np.testing.assert_allclose(model.closure_from_fold_angle(fold), closure, atol=1e-15)
    np.testing.assert_allclose(model.state_from_closure(closure).apex_fold_angle_rad, fold,
                               atol=1e-12)


@pytest.mark.parametrize('closure', [0.3, 0.6, 1.0])
def test_smaller_fold_radius_needs_more_displacement_and_a_wider_midrib(closure):
    """The paper's trend for fold radii 500, 750 and 1000 mm at the same closure."""
    panels = [study_panel(radius) for radius in (0.5, 0.75, 1.0)]
    fold_model = FoldModel(PanelBatch.from_panels(panels))
    state = fold_model.state_from_closure(closure)
    np.testing.assert_allclose(state.apex_fold_angle_rad, state.apex_fold_angle_rad[0])
    assert np.all(np.diff(state.support_displacement_m) < 0)
    assert np.all(np.diff(fold_model.batch.midrib_width_m) < 0)


def test_small_support_translation_closes_with_large_amplification():
    """Koerner et al.: a small B->B', C->C' translation closes the panel completely."""
    fold_model = FoldModel(PanelBatch.from_panels([PROTOTYPE]))
    state = fold_model.state_from_closure(1.0)
    assert state.support_displacement_m[0] < 0.02
    assert state.tip_travel_m[0] > 10 * state.support_displacement_m[0]
    assert state.amplification[0] == pytest.approx(
        state.tip_travel_m[0] / state.support_displacement_m[0])


def test_tips_are_symmetric_and_travel_along_the_fold(model):
    state = model.state_from_closure(0.7)
    sag = state.midrib_sag_m
    tip_a = reflection.flap_tip(model.batch, sag, +1)
    tip_d = reflection.flap_tip(model.batch, sag, -1)
    np.testing.assert_allclose(tip_d, tip_a * [1, -1, 1], atol=1e-15)
    distance_to_crease_apex = np.hypot(tip_a[:, 1] - model.batch.apex_y_m, tip_a[:, 2] - sag)
    np.testing.assert_allclose(distance_to_crease_apex,
                               model.batch.width_m / 2 - model.batch.apex_y_m, atol=1e-12)


def test_fold_angle_grows_from_apex_toward_the_supports(model):
    state = model.state_from_closure(0.8)
    stations = reflection.crease_stations(model.batch, 41)
    fold = reflection.fold_angle_along_crease(model.batch, state.elastica_k, state.midrib_sag_m,
                                              stations)
    np.testing.assert_allclose(fold[:, 20], state.apex_fold_angle_rad, atol=1e-12)
    assert np.all(np.diff(fold[:, 20:], axis=1) > 0)
    np.testing.assert_allclose(fold, fold[:, ::-1], atol=1e-12)


def test_hinge_absorbs_the_crease_mismatch(model):
    for closure in (0.0, 1.0):
        state = model.state_from_closure(closure)
        mismatch = reflection.crease_mismatch_m(model.batch, state.elastica_k)
        assert np.all(mismatch < model.batch.hinge_width_m)


def test_batch_equals_panels_one_at_a_time(model):
    closures = np.array([0.1, 0.5, 0.9, 1.0])
    together = model.state_from_closure(closures)
    for index, closure in enumerate(closures):
        alone = FoldModel(model.batch.take([index])).state_from_closure(closure)
        for name, value in vars(alone).items():
            np.testing.assert_allclose(getattr(together, name)[index], value[0], rtol=1e-12,
                                       equal_nan=True)


@pytest.mark.parametrize('closure, message', [
    (float('nan'), 'closure must be finite'),
    (1.2, 'closure must lie in'),
    (-0.01, 'closure must lie in'),
    ([0.1, 0.2], 'expected a scalar or'),
    ('closed', 'closure must be a real number'),
])
def test_bad_closure_is_refused(model, closure, message):
    with pytest.raises((ValueError, TypeError), match=message):
        model.state_from_closure(closure)


@pytest.mark.parametrize('displacement, message', [
    (-1e-4, 'must lie in'),
    (1.0, 'must lie in'),
    (float('inf'), 'must be finite'),
])
def test_bad_displacement_is_refused(model, displacement, message):
    with pytest.raises(ValueError, match=message):
        model.state_from_displacement(displacement)


def test_prefold_beyond_closed_limit_is_refused():
    panel = PanelGeometry.with_lens_midrib(0.52, 0.42, 0.75, 0.02, 0.015,
                                           prefold_rad=math.radians(85), closed_clearance_m=0.08)
    with pytest.raises(ValueError, match='beyond the closed limit'):
        FoldModel(PanelBatch.from_panels([PROTOTYPE, panel]))


def test_hinge_narrower_than_the_crease_mismatch_is_refused():
    panel = PanelGeometry.with_lens_midrib(0.52, 0.42, 0.75, 0.02, 0.002)
    with pytest.raises(ValueError, match='hinge_width_m=0.002 m cannot absorb'):
        FoldModel(PanelBatch.from_panels([panel]))
