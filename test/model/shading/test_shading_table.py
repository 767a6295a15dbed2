"""The shading table against direct ray casting, and its choice of closures."""

import numpy as np
import pytest

from flectofold_model.kinematics.closure import FoldModel
from flectofold_model.kinematics.panel import DEMONSTRATOR_MODULE, PanelBatch
from flectofold_model.shading.ray_casting import blocked_fraction, closure_for_shading
from flectofold_model.shading.table import ShadingTable

SAMPLES = 12


@pytest.fixture(scope='module')
def table():
    return ShadingTable(DEMONSTRATOR_MODULE, step_deg=10.0, max_profile_deg=80.0,
                        samples=SAMPLES)


def suns(alpha_deg, beta_deg):
    alpha, beta = np.radians(alpha_deg), np.radians(beta_deg)
    vectors = np.stack([np.tan(alpha), np.tan(beta), np.ones_like(alpha)], axis=-1)
    return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)


def exact(closure, sun):
    model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, len(sun)))
    return blocked_fraction(model.batch, model.state_from_closure(closure).elastica_k, sun,
                            samples=SAMPLES).blocked_fraction


def test_grid_nodes_reproduce_ray_casting_exactly(table):
    sun = suns(np.array([-80.0, -30.0, 0.0, 40.0, 70.0]),
               np.array([0.0, 50.0, -20.0, 10.0, -80.0]))
    for index in (0, 4, 10):
        np.testing.assert_allclose(table.blocked_fractions(sun)[:, index],
                                   exact(table.closures[index], sun), atol=1e-12)


def test_interpolation_between_nodes_stays_close_to_ray_casting(table):
    rng = np.random.default_rng(5)
    sun = suns(rng.uniform(-75, 75, 200), rng.uniform(-75, 75, 200))
    for index in (0, 5, 10):
        error = np.abs(table.blocked_fractions(sun)[:, index] - exact(table.closures[index], sun))
        assert np.mean(error) < 0.03 and np.max(error) < 0.15


def test_sun_behind_the_facade_blocks_nothing_and_the_panel_folds_for_view(table):
    behind = np.array([[0.0, 0.6, -0.8], [0.3, 0.0, 0.0]])
    np.testing.assert_array_equal(table.blocked_fractions(behind), 0.0)
    np.testing.assert_array_equal(table.choose(behind, 0.9), 1.0)


def test_choice_at_nodes_matches_closure_for_shading(table):
    sun = suns(np.array([0.0, 40.0, -60.0, 20.0]), np.array([0.0, -10.0, 30.0, 70.0]))
    model = FoldModel(PanelBatch.repeat(DEMONSTRATOR_MODULE, len(sun)))
    for target in (0.5, 0.9, 1.0):
        direct = closure_for_shading(model, sun, target, closures=table.closures,
                                     samples=SAMPLES).closure
        np.testing.assert_array_equal(table.choose(sun, target), direct)


def test_look_ahead_meets_the_target_at_every_instant(table):
    now, later = suns(np.array([0.0]), np.array([70.0])), suns(np.array([0.0]), np.array([0.0]))
    window = np.stack([now, later])
    chosen = table.choose(window, 0.9)
    index = np.flatnonzero(table.closures == chosen[0])[0]
    assert table.blocked_fractions(now)[0, index] >= 0.9
    assert table.blocked_fractions(later)[0, index] >= 0.9
    assert chosen[0] <= min(table.choose(now, 0.9)[0], table.choose(later, 0.9)[0])


def test_many_panels_at_once(table):
    sun = np.repeat(suns(np.array([30.0]), np.array([20.0])), 5000, axis=0)
    chosen = table.choose(sun, 0.8)
    assert chosen.shape == (5000,) and np.all(chosen == chosen[0])


@pytest.mark.parametrize('arguments, error', [
    ({'panel': 'demonstrator'}, TypeError),
    ({'closures': [0.0, 0.5, 0.4]}, ValueError),
    ({'step_deg': 0.0}, ValueError),
    ({'max_profile_deg': 90.0}, ValueError),
])
def test_bad_tables_are_refused(arguments, error):
    options = {'panel': DEMONSTRATOR_MODULE, **arguments}
    with pytest.raises(error):
        ShadingTable(**options)


def test_bad_target_is_refused(table):
    with pytest.raises(ValueError, match='target_blocked'):
        table.choose(suns(np.array([0.0]), np.array([0.0])), 1.5)
