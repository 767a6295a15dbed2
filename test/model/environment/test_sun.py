"""Solar position: the NREL SPA test case, sun vectors, the day's course and bad input."""

import math

import numpy as np
import pvlib
import pytest

from flectofold_model.environment.sun import (angle_of_incidence_rad, day_epochs,
                                              enu_from_azimuth_elevation, epoch_from_iso, Site,
                                              solar_position, SolarPosition, STUTTGART,
                                              sun_vector_enu)

# NREL/TP-560-34302, table A4.1: Golden, Colorado, 2003-10-17 12:30:30 local time (UTC-7).
NREL_TIME = '2003-10-17T12:30:30-07:00'
NREL_SITE = Site(latitude_deg=39.742476, longitude_deg=-105.1786, elevation_m=1830.14,
                 pressure_pa=82000.0, temperature_c=11.0)
NREL_APPARENT_ZENITH_DEG = 50.111622
NREL_GEOMETRIC_ZENITH_DEG = 50.127954
NREL_AZIMUTH_DEG = 194.340241
NREL_INCIDENCE_DEG = 25.187000
NREL_SLOPE_DEG = 30.0
NREL_SURFACE_AZIMUTH_DEG = 170.0


def surface_normal(tilt_deg, azimuth_deg):
    """ENU normal of a surface tilted by ``tilt_deg`` toward the compass ``azimuth_deg``."""
    tilt, azimuth = math.radians(tilt_deg), math.radians(azimuth_deg)
    return np.array([math.sin(tilt) * math.sin(azimuth), math.sin(tilt) * math.cos(azimuth),
                     math.cos(tilt)])


@pytest.fixture(scope='module')
def nrel():
    return solar_position(epoch_from_iso(NREL_TIME), NREL_SITE, delta_t_s=67.0)


def test_nrel_test_case_position(nrel):
    assert isinstance(nrel, SolarPosition)
    assert len(nrel) == 1
    assert nrel.epoch_s[0] == 1066419030.0  # 19:30:30 UTC
    assert math.degrees(nrel.apparent_zenith_rad[0]) == pytest.approx(
        NREL_APPARENT_ZENITH_DEG, abs=1e-5)
    assert math.degrees(nrel.azimuth_rad[0]) == pytest.approx(NREL_AZIMUTH_DEG, abs=1e-5)
    assert math.degrees(nrel.apparent_elevation_rad[0]) == pytest.approx(
        90.0 - NREL_APPARENT_ZENITH_DEG, abs=1e-5)


def test_nrel_test_case_geometric_elevation_is_below_the_apparent_one(nrel):
    geometric_deg = math.degrees(nrel.geometric_elevation_rad[0])
    assert geometric_deg == pytest.approx(90.0 - NREL_GEOMETRIC_ZENITH_DEG, abs=1e-5)
    refraction_deg = math.degrees(nrel.apparent_elevation_rad[0]) - geometric_deg
    assert refraction_deg == pytest.approx(NREL_GEOMETRIC_ZENITH_DEG - NREL_APPARENT_ZENITH_DEG,
                                           abs=1e-5)
    assert 0.01 < refraction_deg < 0.03
    np.testing.assert_allclose(nrel.apparent_zenith_rad + nrel.apparent_elevation_rad,
                               math.pi / 2, rtol=0, atol=1e-12)


def test_nrel_test_case_incidence_angle(nrel):
    normal = surface_normal(NREL_SLOPE_DEG, NREL_SURFACE_AZIMUTH_DEG)
    incidence_deg = np.degrees(angle_of_incidence_rad(nrel.enu, normal))
    assert incidence_deg.shape == (1,)
    assert incidence_deg[0] == pytest.approx(NREL_INCIDENCE_DEG, abs=1e-4)
    pvlib_deg = pvlib.irradiance.aoi(NREL_SLOPE_DEG, NREL_SURFACE_AZIMUTH_DEG,
                                     math.degrees(nrel.apparent_zenith_rad[0]),
                                     math.degrees(nrel.azimuth_rad[0]))
    assert incidence_deg[0] == pytest.approx(pvlib_deg, abs=1e-9)


def test_incidence_matches_pvlib_over_a_day_and_many_surfaces():
    position = solar_position(day_epochs('2026-03-20', 1.0, 1800.0), STUTTGART)
    rng = np.random.default_rng(7)
    tilts = rng.uniform(0.0, 180.0, 5)
    azimuths = rng.uniform(0.0, 360.0, 5)
    normals = np.stack([surface_normal(t, a) for t, a in zip(tilts, azimuths)])
    ours = np.degrees(angle_of_incidence_rad(position.enu, normals))
    assert ours.shape == (48, 5)
    theirs = pvlib.irradiance.aoi(tilts[None, :], azimuths[None, :],
                                  np.degrees(position.apparent_zenith_rad)[:, None],
                                  np.degrees(position.azimuth_rad)[:, None])
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-6)


def test_incidence_broadcasting_and_scaling():
    up = np.array([0.0, 0.0, 1.0])
    suns = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, -2.0]])
    np.testing.assert_allclose(angle_of_incidence_rad(suns, up), [0.0, math.pi / 2, math.pi])
    assert angle_of_incidence_rad(up, up * 5.0) == 0.0
    assert angle_of_incidence_rad([1.0, 0.0, 1.0], [0.0, 0.0, 3.0]) == pytest.approx(
        math.pi / 4)  # lengths do not matter
    normals = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    assert angle_of_incidence_rad(up, normals).shape == (2,)
    table = angle_of_incidence_rad(suns, normals)
    assert table.shape == (3, 2)
    assert table[1, 1] == pytest.approx(math.pi / 2)
    with pytest.raises(ValueError, match='normal_enu contains a zero vector'):
        angle_of_incidence_rad(up, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r'sun_enu must have shape \(3,\) or \(K, 3\)'):
        angle_of_incidence_rad([[1.0, 0.0]], up)


def test_sun_vectors_have_unit_length():
    vectors = sun_vector_enu(day_epochs('2026-06-21', 2.0, 900.0), STUTTGART)
    assert vectors.shape == (96, 3)
    np.testing.assert_allclose(np.linalg.norm(vectors, axis=1), 1.0, rtol=0, atol=1e-12)


def test_enu_hand_cases():
    south = enu_from_azimuth_elevation(math.pi, math.radians(30.0))
    np.testing.assert_allclose(south, [0.0, -math.cos(math.radians(30.0)), 0.5], atol=1e-15)
    east = enu_from_azimuth_elevation(math.pi / 2, 0.0)
    np.testing.assert_allclose(east, [1.0, 0.0, 0.0], atol=1e-15)
    north_zenith = enu_from_azimuth_elevation([0.0, 1.0], [0.0, math.pi / 2])
    np.testing.assert_allclose(north_zenith, [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-15)
    with pytest.raises(ValueError, match='elevation_rad must lie in'):
        enu_from_azimuth_elevation(0.0, 2.0)


def test_position_vectors_follow_the_angles(nrel):
    expected = enu_from_azimuth_elevation(nrel.azimuth_rad, nrel.apparent_elevation_rad)
    np.testing.assert_array_equal(nrel.enu, expected)
    assert nrel.enu[0, 0] < 0.0 and nrel.enu[0, 1] < 0.0  # 194 deg: south, a little west


def test_morning_east_noon_south_evening_west_in_stuttgart():
    times = [epoch_from_iso(text) for text in (
        '2026-06-21T05:00:00Z', '2026-06-21T11:25:00Z', '2026-06-21T17:00:00Z')]
    position = solar_position(times, STUTTGART)
    morning, noon, evening = position.enu
    assert position.above_horizon.all()
    assert morning[0] > 0.0
    assert evening[0] < 0.0
    assert noon[1] < 0.0
    assert abs(noon[0]) < 0.05  # close to the meridian at solar noon
    assert 0.0 < position.azimuth_rad[0] < math.pi / 2
    assert math.pi < position.azimuth_rad[2] < 2 * math.pi


def test_array_of_times_equals_one_time_at_a_time():
    times = day_epochs('2026-06-21', 2.0, 3600.0) + 0.5
    together = solar_position(times, STUTTGART)
    for index, time in enumerate(times):
        alone = solar_position(time, STUTTGART)
        for name in ('epoch_s', 'azimuth_rad', 'apparent_elevation_rad', 'apparent_zenith_rad',
                     'geometric_elevation_rad', 'enu'):
            np.testing.assert_array_equal(getattr(alone, name)[0], getattr(together, name)[index],
                                          err_msg=f'{name} at {index}')


@pytest.mark.parametrize('date, offset_h, expected_deg', [
    ('2026-06-21', 2.0, 90.0 - 48.7784 + 23.44),  # summer solstice, CEST: 64.66 deg
    ('2026-12-21', 1.0, 90.0 - 48.7784 - 23.44),  # winter solstice, CET: 17.78 deg
])
def test_noon_elevation_and_midnight_in_stuttgart(date, offset_h, expected_deg):
    position = solar_position(day_epochs(date, offset_h, 60.0), STUTTGART)
    assert math.degrees(position.apparent_elevation_rad.max()) == pytest.approx(
        expected_deg, abs=0.3)
    noon = np.argmax(position.apparent_elevation_rad)
    assert math.degrees(position.azimuth_rad[noon]) == pytest.approx(180.0, abs=0.5)
    assert not position.above_horizon[0]  # local midnight
    assert position.enu[0, 2] < 0.0
    assert position.above_horizon.any() and not position.above_horizon.all()


def test_winter_days_are_shorter_than_summer_days():
    summer = solar_position(day_epochs('2026-06-21', 2.0, 300.0), STUTTGART)
    winter = solar_position(day_epochs('2026-12-21', 1.0, 300.0), STUTTGART)
    summer_h = summer.above_horizon.sum() * 300.0 / 3600.0
    winter_h = winter.above_horizon.sum() * 300.0 / 3600.0
    assert summer_h == pytest.approx(16.1, abs=0.3)
    assert winter_h == pytest.approx(8.3, abs=0.3)


def test_day_epochs():
    epochs = day_epochs('2026-06-21', 2.0, 600.0)
    assert epochs.shape == (86400 // 600,)
    assert epochs[0] == epoch_from_iso('2026-06-21T00:00:00+02:00')
    np.testing.assert_array_equal(np.diff(epochs), 600.0)
    assert epochs[-1] + 600.0 == epoch_from_iso('2026-06-22T00:00:00+02:00')
    assert day_epochs('2026-06-21', -5.5, 86400.0).tolist() == [
        epoch_from_iso('2026-06-21T00:00:00-05:30')]
    assert len(day_epochs('2026-06-21', 0.0, 7000.0)) == 13  # 12 * 7000 < 86400 <= 13 * 7000
    assert len(day_epochs('2026-06-21', 0.0, 0.1)) == 864000
    # 86400 / (86400 / 61) rounds to 61.00000000000001: the next midnight must stay out.
    odd = day_epochs('2026-06-21', 0.0, 86400.0 / 61)
    assert len(odd) == 61
    assert odd[-1] < epoch_from_iso('2026-06-22T00:00:00Z')


def test_epoch_from_iso():
    assert epoch_from_iso('1970-01-01T00:00:00Z') == 0.0
    assert epoch_from_iso('1970-01-01T02:00:00+02:00') == 0.0
    assert epoch_from_iso(NREL_TIME) == epoch_from_iso('2003-10-17T19:30:30+00:00')
    assert epoch_from_iso('2026-06-21T05:00:00.25Z') % 1.0 == 0.25


def test_site_is_validated_and_frozen():
    assert STUTTGART.latitude_deg == 48.7784
    assert STUTTGART.pressure_pa == 101325.0
    with pytest.raises(AttributeError):
        STUTTGART.latitude_deg = 0.0
    assert Site(-90, 180, 0).longitude_deg == 180.0


@pytest.mark.parametrize('change, error, message', [
    ({'latitude_deg': 91.0}, ValueError, r'latitude_deg must lie in \[-90, 90\] deg, got 91'),
    ({'latitude_deg': float('nan')}, ValueError, 'latitude_deg must be finite'),
    ({'longitude_deg': 'x'}, TypeError, 'longitude_deg must be a real number'),
    ({'longitude_deg': -180.5}, ValueError, 'longitude_deg must lie in'),
    ({'elevation_m': 9000.1}, ValueError, 'elevation_m must lie in'),
    ({'elevation_m': True}, TypeError, 'elevation_m must be a real number'),
    ({'pressure_pa': 1013.25}, ValueError, 'pressure_pa must lie in .* not hPa'),
    ({'pressure_pa': None}, TypeError, 'pressure_pa must be a real number'),
    ({'temperature_c': float('inf')}, ValueError, 'temperature_c must be finite'),
    ({'temperature_c': 300.0}, ValueError, 'temperature_c must lie in'),
])
def test_bad_site_is_refused_naming_the_field(change, error, message):
    good = {'latitude_deg': 48.7784, 'longitude_deg': 9.18, 'elevation_m': 245.0}
    with pytest.raises(error, match=message):
        Site(**{**good, **change})


@pytest.mark.parametrize('epoch, error, message', [
    (float('nan'), ValueError, 'epoch_s must be finite'),
    ([0.0, float('inf')], ValueError, r'epoch_s must be finite, got inf at index \(1,\)'),
    ('2026-06-21', TypeError, 'epoch_s must be a real number'),
    ([[0.0, 1.0]], ValueError, 'epoch_s must be a scalar or a 1-D array'),
    (1e12, ValueError, 'years -2000 to 6000'),
])
def test_bad_epoch_is_refused(epoch, error, message):
    with pytest.raises(error, match=message):
        solar_position(epoch, STUTTGART)


def test_bad_site_or_delta_t_is_refused():
    with pytest.raises(TypeError, match='site must be a Site, got tuple'):
        solar_position(0.0, (48.7784, 9.18, 245.0))
    with pytest.raises(TypeError, match='delta_t_s must be a real number'):
        solar_position(0.0, STUTTGART, delta_t_s='67')


@pytest.mark.parametrize('text, error, message', [
    ('2003-10-17T12:30:30', ValueError, 'no UTC offset.*ambiguous'),
    ('2003-10-17', ValueError, 'no UTC offset'),
    ('yesterday at noon', ValueError, 'not an ISO 8601 timestamp'),
    ('2003-13-17T12:30:30Z', ValueError, 'not an ISO 8601 timestamp'),
    (1066419030.0, TypeError, 'text must be an ISO 8601 string'),
])
def test_bad_iso_timestamp_is_refused(text, error, message):
    with pytest.raises(error, match=message):
        epoch_from_iso(text)


@pytest.mark.parametrize('args, error, message', [
    (('21.06.2026', 2.0, 60.0), ValueError, "date_iso must be a date as 'YYYY-MM-DD'"),
    (('2026-02-30', 2.0, 60.0), ValueError, 'is not a calendar date'),
    ((20260621, 2.0, 60.0), TypeError, 'date_iso must be'),
    (('2026-06-21', 15.0, 60.0), ValueError, 'site_utc_offset_h must lie in'),
    (('2026-06-21', 'CEST', 60.0), TypeError, 'site_utc_offset_h must be a real number'),
    (('2026-06-21', 2.0, 0.0), ValueError, r'step_s must lie in \(0, 86400\] s'),
    (('2026-06-21', 2.0, 86401.0), ValueError, 'step_s must lie in'),
    (('2026-06-21', 2.0, float('nan')), ValueError, 'step_s must be finite'),
])
def test_bad_day_is_refused(args, error, message):
    with pytest.raises(error, match=message):
        day_epochs(*args)


def test_solar_position_checks_its_arrays():
    with pytest.raises(ValueError, match='azimuth_rad has 2 times, epoch_s has 1'):
        SolarPosition(epoch_s=[0.0], azimuth_rad=[0.0, 1.0], apparent_elevation_rad=[0.0],
                      apparent_zenith_rad=[0.0], geometric_elevation_rad=[0.0],
                      enu=[[0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match=r'enu must have shape \(T, 3\)'):
        SolarPosition(epoch_s=[0.0], azimuth_rad=[0.0], apparent_elevation_rad=[0.0],
                      apparent_zenith_rad=[0.0], geometric_elevation_rad=[0.0],
                      enu=[0.0, 0.0, 1.0])
