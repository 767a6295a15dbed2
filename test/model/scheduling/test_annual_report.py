"""The annual report on real weather: energy against pvlib, baselines, night, storms, errors."""

import dataclasses
import os

import numpy as np
import pandas as pd
import pvlib
import pytest

from flectofold_model.environment import read_weather, Site, solar_position
from flectofold_model.facade import load_facade
from flectofold_model.facade.description import build_facade
from flectofold_model.kinematics.kinds import fold_model_of
from flectofold_model.scheduling.annual_report import (_threshold_desired, annual_report,
                                                       AnnualReportError, plot)
from flectofold_model.scheduling.day_report import CANDIDATE_CLOSURES
from flectofold_model.scheduling.facade_schedule import representative_panel
from flectofold_model.shading.ray_casting import blocked_fraction
from flectofold_model.shading.table import ShadingTable

TMY3 = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')
WEEK = ('02-06', '02-12')  # low winter sun on a south facade, and five hours of gale

EPW_HEADER = [
    'LOCATION,Stuttgart,BW,DEU,TEST,107380,48.83,9.20,1.0,318.0',
    'DESIGN CONDITIONS,0', 'TYPICAL/EXTREME PERIODS,0', 'GROUND TEMPERATURES,0',
    'HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0', 'COMMENTS 1,test', 'COMMENTS 2,test',
    'DATA PERIODS,1,1,Data,Sunday, 3/20,3/22',
]


def write_epw(path, gale_hours=(), days=3):
    """Three March days at Stuttgart: a clear-ish sky, 3 m/s wind, 15 m/s in ``gale_hours``.

    ``gale_hours`` are (day, hour-ending) pairs, local standard time.
    """
    rows = []
    for day in range(days):
        for hour in range(1, 25):
            sun = max(0, 6 - abs(hour - 12.5))
            wind = 15.0 if (day, hour) in gale_hours else 3.0
            fields = [1995, 3, 20 + day, hour, 60, 'A7A7', 8.0, 2.0, 70, 98000, 0, 1400, 350,
                      int(120 * sun), int(140 * sun), int(30 * sun), 0, 0, 0, 0, 200, wind,
                      5, 5, 20.0, 77777, 9, '999999999', 10, 0.1, 0, 88, 0.2, 0, 1.0]
            rows.append(','.join(str(f) for f in fields))
    path.write_text('\n'.join(EPW_HEADER + rows) + '\n')
    return path


@pytest.fixture(scope='module')
def facade(small_facade_text):
    return build_facade(small_facade_text('shading_target: 0.9, default_closure: 1.0, '
                                          'min_dwell_s: 600'))


@pytest.fixture(scope='module')
def table(facade):
    # A coarse table keeps the test fast; the documented run uses the full one.
    return ShadingTable(representative_panel(facade), closures=CANDIDATE_CLOSURES,
                        step_deg=10.0, samples=8)


@pytest.fixture(scope='module')
def tmy3():
    return read_weather(TMY3)


@pytest.fixture(scope='module')
def week(facade, table, tmy3):
    return annual_report(facade, tmy3, *WEEK, table=table)


def _raw_tmy3(first, last):
    """Return the TMY3 rows of local dates first..last (MM-DD) by pvlib, mid-hour UTC times."""
    data, meta = pvlib.iotools.read_tmy3(TMY3, coerce_year=2001)
    local = data.index - pd.Timedelta(minutes=30)
    days = local.strftime('%m-%d')
    keep = (days >= first) & (days <= last)
    return data[keep], local[keep].tz_convert('UTC'), meta


def test_incident_direct_energy_matches_pvlib(facade, week):
    data, times, meta = _raw_tmy3(*WEEK)
    solar = pvlib.solarposition.get_solarposition(times, meta['latitude'], meta['longitude'],
                                                  altitude=meta['altitude'],
                                                  method='nrel_numpy', delta_t=67.0)
    normals = facade.panel_to_enu[:, :, 2]
    total = 0.0
    for normal in normals:
        tilt = np.degrees(np.arccos(normal[2]))
        azimuth = np.degrees(np.arctan2(normal[0], normal[1])) % 360
        aoi = pvlib.irradiance.aoi(tilt, azimuth, solar['apparent_zenith'], solar['azimuth'])
        beam = data['dni'].to_numpy() * np.clip(np.cos(np.radians(aoi.to_numpy())), 0, None)
        up = solar['apparent_elevation'].to_numpy() > 0
        total += float(np.sum(beam[up])) / 1000.0  # 1 h steps
    expected = total / len(normals)
    assert expected > 5.0  # a week of winter sun on a south facade
    assert week.incident_direct_kwh_m2 == pytest.approx(expected, rel=2e-3)
    assert week.range_days == 7 and week.step_s == 3600


def test_blocked_energy_of_the_folded_baseline_matches_ray_casting(facade, tmy3, week):
    data, times, meta = _raw_tmy3(*WEEK)
    solar = pvlib.solarposition.get_solarposition(times, meta['latitude'], meta['longitude'],
                                                  altitude=meta['altitude'],
                                                  method='nrel_numpy', delta_t=67.0)
    zenith, azimuth = np.radians(solar['apparent_zenith']), np.radians(solar['azimuth'])
    sun_enu = np.stack([np.sin(zenith) * np.sin(azimuth), np.sin(zenith) * np.cos(azimuth),
                        np.cos(zenith)], axis=-1)
    sun_panel = facade.sun_in_panel_frames(sun_enu)
    lit = (sun_panel[..., 2] > 0) & (solar['apparent_elevation'].to_numpy() > 0)[:, None]
    t, n = np.nonzero(lit)
    fold = fold_model_of(facade.panels)
    closed = fold.state_from_closure(1.0).shape_parameter
    shading = blocked_fraction(fold.batch.take(n), closed[n], sun_panel[t, n], samples=16)
    beam = data['dni'].to_numpy()[t] * sun_panel[t, n, 2]
    expected = float(np.sum(beam * shading.blocked_fraction)) / 1000.0 / len(facade)
    closed_figures = week.figures('always closed')
    assert closed_figures.blocked_direct_kwh_m2 == pytest.approx(
        expected, abs=0.03 * week.incident_direct_kwh_m2)


def test_flat_panels_block_nearly_all_and_folded_ones_least(week):
    by_name = {s.name: s for s in week.strategies}
    flat, folded = by_name['always open'], by_name['always closed']
    assert flat.blocked_direct_fraction > 0.97
    assert flat.view_hours_h == 0 and flat.actuations_per_panel == 0
    for strategy in week.strategies:
        assert folded.blocked_direct_kwh_m2 <= strategy.blocked_direct_kwh_m2 + 1e-9
        assert strategy.blocked_direct_kwh_m2 <= flat.blocked_direct_kwh_m2 + 1e-9
        assert 0 <= strategy.view_weighted_hours_h <= strategy.view_hours_h + week.daylight_h
    assert folded.blocked_direct_fraction < 0.9
    scheduled = by_name['scheduled']
    # The schedule shades toward its target and keeps view where the flaps alone suffice.
    assert scheduled.blocked_direct_fraction > folded.blocked_direct_fraction + 0.05
    assert scheduled.view_hours_h > 0.2 * week.daylight_h
    assert np.sum(scheduled.monthly_blocked_kwh_m2) == pytest.approx(
        scheduled.blocked_direct_kwh_m2)
    assert week.months.tolist() == [False, True] + [False] * 10


def test_moves_stay_under_the_daily_cap_and_cost_air(week):
    for name in ('scheduled', 'threshold'):
        figures = week.figures(name)
        assert 0 < figures.actuations_per_panel <= week.daily_move_cap * week.range_days
        assert figures.air_nl > 0
        assert figures.actuations_per_panel_year == pytest.approx(
            figures.actuations_per_panel * 365 / 7)
    assert week.cycle_budget_per_year == 20 * 365


def test_night_hours_contribute_nothing(facade, table, tmy3, week):
    middles = np.datetime64('2001-02-06T05:30', 'ns') + np.arange(7 * 24) * np.timedelta64(
        1, 'h')
    epochs = middles.astype(np.int64) / 1e9
    site = Site(tmy3.latitude_deg, tmy3.longitude_deg, tmy3.altitude_m)
    night_times = middles[~solar_position(epochs, site).above_horizon]
    night = np.isin(tmy3.time_utc, night_times)
    assert night.sum() > 80
    # A file with strong direct sun at night: the figures must not change.
    glare = dataclasses.replace(tmy3, dni_w_m2=np.where(night, 900.0, tmy3.dni_w_m2))
    report = annual_report(facade, glare, *WEEK, table=table)
    assert report.incident_direct_kwh_m2 == pytest.approx(week.incident_direct_kwh_m2)
    for name in ('always open', 'always closed'):
        assert report.figures(name).blocked_direct_kwh_m2 == pytest.approx(
            week.figures(name).blocked_direct_kwh_m2)


def test_storm_hours_come_from_the_file_and_the_panels_vent(facade, table, week, tmp_path):
    data, _, _ = _raw_tmy3(*WEEK)
    assert week.storm_wind_h == float(np.sum(data['wind_speed'] > 10.0)) == 5.0
    assert week.storm_latched_h >= 5.0
    assert week.figures('scheduled').storm_closure == 0.0
    gale = [(1, hour) for hour in (10, 11, 12)]
    weather = read_weather(write_epw(tmp_path / 'gale.epw', gale))
    report = annual_report(facade, weather, table=table)
    assert report.storm_wind_h == 3.0
    # Latched from 5 s into the first gale hour until 900 s of calm after the last.
    assert report.storm_latched_h == pytest.approx(3.0 + 0.25 - 5 / 3600, abs=1e-6)
    assert report.figures('scheduled').storm_closure == 0.0
    assert report.figures('threshold').storm_closure == 0.0
    assert report.figures('always closed').storm_closure == 1.0  # a static one does not move
    assert (report.first_date, report.last_date, report.range_days) == ('03-20', '03-22', 3)


def test_threshold_rule_has_hysteresis():
    direct = np.array([[0.0], [300.0], [200.0], [100.0], [200.0], [260.0]])
    np.testing.assert_array_equal(_threshold_desired(direct, 250.0, 150.0)[:, 0],
                                  [1.0, 0.0, 0.0, 1.0, 1.0, 0.0])


def test_bad_inputs_are_refused_clearly(facade, table, tmy3, tmp_path):
    epw = read_weather(write_epw(tmp_path / 'short.epw'))
    with pytest.raises(AnnualReportError, match='covers local dates 03-20 to 03-22'):
        annual_report(facade, epw, '03-21', '04-02', table=table)
    with pytest.raises(AnnualReportError, match='step must be one of'):
        annual_report(facade, tmy3, *WEEK, step_min=7, table=table)
    with pytest.raises(AnnualReportError, match='step must be a number'):
        annual_report(facade, tmy3, *WEEK, step_min='60', table=table)
    with pytest.raises(AnnualReportError, match='YYYY-MM-DD or MM-DD'):
        annual_report(facade, tmy3, 'June', '06-30', table=table)
    with pytest.raises(AnnualReportError, match='not a date'):
        annual_report(facade, tmy3, '02-29', '03-01', table=table)
    with pytest.raises(AnnualReportError, match='before the first'):
        annual_report(facade, tmy3, '06-30', '06-01', table=table)
    with pytest.raises(AnnualReportError, match='gust_factor'):
        annual_report(facade, tmy3, *WEEK, gust_factor=float('nan'), table=table)
    with pytest.raises(TypeError, match='Weather'):
        annual_report(facade, TMY3, *WEEK, table=table)


def test_finer_step_and_hexagonal_facade_and_plot(tmp_path):
    facade = load_facade('hexagon_6x6')
    table = ShadingTable(representative_panel(facade), closures=CANDIDATE_CLOSURES,
                         step_deg=20.0, samples=6)
    weather = read_weather(write_epw(tmp_path / 'w.epw'))
    hourly = annual_report(facade, weather, '03-21', '03-21', table=table)
    fine = annual_report(facade, weather, '03-21', '03-21', step_min=15, table=table)
    assert fine.step_s == 900 and hourly.range_days == fine.range_days == 1
    # Linear interpolation between the hourly rows: the same energy within a few per cent.
    assert fine.incident_direct_kwh_m2 == pytest.approx(hourly.incident_direct_kwh_m2,
                                                        rel=0.05)
    path = plot(fine, tmp_path / 'annual.png')
    assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('station', ['usa_az_phoenix', 'usa_il_chicago'])
def test_other_climates_from_the_energyplus_wheel_stay_under_their_limit(facade, table,
                                                                         station):
    from pyenergyplus import dataset
    weather = read_weather(dataset.weather_files[station])
    report = annual_report(facade, weather, '07-01', '07-03', table=table, families=False)
    for name in ('scheduled', 'target rule', 'threshold'):
        within, free = report.gaps[name]
        # no strategy that obeys the scheduler beats the limit at its own blocking
        assert within >= -1e-6 and free >= within - 1e-6, (name, within, free)
    limit = report.limit
    assert limit.view_weighted_lower_h <= limit.view_weighted_upper_h
    assert report.figures('limit').blocked_direct_kwh_m2 >= \
        report.figures('scheduled').blocked_direct_kwh_m2 - 1e-9
