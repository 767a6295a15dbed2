"""The sun ephemeris gives the SPA's own vectors, computes ahead on its grid, stays bounded."""

import numpy as np
import pytest

from flectofold_model.environment import STUTTGART, sun_vector_enu, SunEphemeris

NOON_S = 1782036000.0  # 2026-06-21 10:00 UTC


def test_the_vectors_are_the_spa_vectors_at_the_same_times():
    ephemeris = SunEphemeris(STUTTGART, 60.0, batch=10)
    times = NOON_S + np.array([0.0, 60.0, 3600.0, 7.5, -86400.0])
    np.testing.assert_array_equal(ephemeris.enu(times), sun_vector_enu(times, STUTTGART))
    assert ephemeris.enu(NOON_S).shape == (1, 3)


def test_a_miss_computes_the_grid_ahead_and_later_hits_compute_nothing():
    ephemeris = SunEphemeris(STUTTGART, 60.0, batch=30)
    ephemeris.enu(NOON_S)
    assert ephemeris.computed == 31
    ephemeris.enu(NOON_S + 60.0 * np.arange(31))
    assert ephemeris.computed == 31
    ephemeris.enu(NOON_S + 60.0 * 31)
    assert ephemeris.computed == 62


def test_times_within_a_millisecond_share_the_value_at_the_millisecond():
    ephemeris = SunEphemeris(STUTTGART, 60.0, batch=0, keep=10)
    np.testing.assert_array_equal(ephemeris.enu(NOON_S + 0.0004),
                                  sun_vector_enu(NOON_S, STUTTGART))


def test_it_keeps_at_most_keep_instants():
    ephemeris = SunEphemeris(STUTTGART, 60.0, batch=5, keep=20)
    for k in range(10):
        ephemeris.enu(NOON_S + 3600.0 * k)
    assert len(ephemeris._vectors) <= 20
    np.testing.assert_array_equal(ephemeris.enu(NOON_S), sun_vector_enu(NOON_S, STUTTGART))


@pytest.mark.parametrize('arguments, message', [
    ((STUTTGART, 0.0), 'step_s must be positive'),
    ((STUTTGART, 60.0, -1), 'batch must be a non-negative integer'),
    ((STUTTGART, 60.0, 10, 10), 'keep=10 must exceed batch=10'),
    (('Stuttgart', 60.0), 'site must be a Site'),
])
def test_bad_settings_are_refused(arguments, message):
    with pytest.raises((TypeError, ValueError), match=message):
        SunEphemeris(*arguments)


def test_a_non_finite_time_is_refused():
    with pytest.raises(ValueError, match='finite'):
        SunEphemeris(STUTTGART, 60.0).enu([NOON_S, float('nan')])
