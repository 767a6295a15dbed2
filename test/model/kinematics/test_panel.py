"""Panel descriptions: what they derive, and what they refuse."""

import math

import numpy as np
import pytest

from flectofold_model import DEMONSTRATOR_MODULE, PanelBatch, PanelGeometry, PROTOTYPE

GOOD = {'length_m': 0.52, 'width_m': 0.42, 'fold_radius_m': 0.75, 'midrib_width_m': 0.12,
        'hinge_width_m': 0.015, 'prefold_rad': 0.05}


def test_derived_dimensions():
    panel = PanelGeometry(**GOOD)
    assert panel.fold_line_sag_m == pytest.approx(0.75 - math.sqrt(0.75**2 - 0.26**2))
    assert panel.midrib_end_width_m == pytest.approx(0.12 - 2 * panel.fold_line_sag_m)
    assert panel.flap_width_m == pytest.approx((0.42 - 0.12) / 2)


def test_lens_midrib_gets_wider_as_the_radius_shrinks():
    widths = [PanelGeometry.with_lens_midrib(0.52, 0.42, radius, 0.02, 0.015).midrib_width_m
              for radius in (0.5, 0.75, 1.0)]
    assert widths[0] > widths[1] > widths[2]
    assert widths[1] == pytest.approx(0.02 + 2 * 0.0465, abs=1e-4)


def test_presets_are_valid_and_about_their_published_size():
    assert (PROTOTYPE.length_m, PROTOTYPE.width_m) == (0.52, 0.42)
    area = DEMONSTRATOR_MODULE.length_m * DEMONSTRATOR_MODULE.width_m
    assert area == pytest.approx(1.0, rel=0.2)


@pytest.mark.parametrize('name, value, error, message', [
    ('length_m', float('nan'), ValueError, 'length_m must be finite'),
    ('width_m', float('inf'), ValueError, 'width_m must be finite'),
    ('length_m', -0.5, ValueError, 'length_m must be positive'),
    ('hinge_width_m', 0.0, ValueError, 'hinge_width_m must be positive'),
    ('fold_radius_m', '0.75', TypeError, 'fold_radius_m must be a real number'),
    ('midrib_width_m', True, TypeError, 'midrib_width_m must be a real number'),
    ('fold_radius_m', 0.25, ValueError, 'cannot span the mid-rib'),
    ('midrib_width_m', 0.08, ValueError, 'would cross before the supports'),
    ('width_m', 0.14, ValueError, 'leaves no flap'),
    ('prefold_rad', -0.1, ValueError, 'prefold_rad must lie in'),
    ('prefold_rad', math.pi / 2, ValueError, 'prefold_rad must lie in'),
    ('closed_clearance_m', -0.01, ValueError, 'closed_clearance_m must not be negative'),
    ('closed_clearance_m', 0.35, ValueError, 'wider than the flaps can close'),
])
def test_bad_geometry_is_refused_with_the_reason(name, value, error, message):
    with pytest.raises(error, match=message):
        PanelGeometry(**{**GOOD, name: value})


def test_batch_stacks_and_indexes():
    batch = PanelBatch.from_panels([PROTOTYPE, DEMONSTRATOR_MODULE, PROTOTYPE])
    assert len(batch) == 3
    np.testing.assert_array_equal(batch.length_m, [0.52, 1.0, 0.52])
    np.testing.assert_allclose(batch.fold_line_sag_m[1], DEMONSTRATOR_MODULE.fold_line_sag_m)
    assert len(PanelBatch.repeat(PROTOTYPE, 5)) == 5
    assert batch.take([1]).width_m.tolist() == [1.0]


def test_batch_refuses_bad_members():
    with pytest.raises(ValueError, match='at least one panel'):
        PanelBatch.from_panels([])
    with pytest.raises(TypeError, match='panel 1 is a dict'):
        PanelBatch.from_panels([PROTOTYPE, GOOD])
    with pytest.raises(ValueError, match='positive integer'):
        PanelBatch.repeat(PROTOTYPE, 0)
