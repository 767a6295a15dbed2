"""EnergyPlus with the facade's controller in its loop: a few days of the room behind it."""

import numpy as np
import pytest

from flectofold_model.building import building_report as report
from flectofold_model.building.energyplus_model import Room, run, shoebox_epjson
from flectofold_model.building.facade_loop import FacadeInTheLoop
from flectofold_model.environment import read_weather, Site
from flectofold_model.environment.weather import weather_at
from flectofold_model.facade.description import build_facade
from flectofold_model.scheduling.day_report import CANDIDATE_CLOSURES
from flectofold_model.scheduling.facade_schedule import representative_panel
from flectofold_model.shading.table import ShadingTable

JULY = ((7, 1), (7, 3))


@pytest.fixture(scope='module')
def epw():
    from pyenergyplus import dataset
    return dataset.weather_files['usa_az_phoenix']


@pytest.fixture(scope='module')
def facade(small_facade_text):
    return build_facade(small_facade_text('default_closure: 1.0'))


@pytest.fixture(scope='module')
def table(facade):
    return ShadingTable(representative_panel(facade), closures=CANDIDATE_CLOSURES,
                        step_deg=10.0, samples=8)


@pytest.fixture(scope='module')
def days(facade, table, epw, tmp_path_factory):
    return report.building_report(facade, read_weather(epw), epw, run_period=JULY, table=table,
                                  workdir=str(tmp_path_factory.mktemp('eplus')))


def test_every_row_runs_and_the_lines_name_the_units(days):
    assert [r.name for r in days.rows] == list(report.ROWS)
    text = '\n'.join(days.lines())
    for unit in ('[kWh/m2]', '[W/m2]', '[kWh]', '[NL]'):
        assert unit in text
    for row in days.rows:
        assert row.cooling_kwh_m2 > 0 and row.peak_cooling_w_m2 > 0


def test_a_flat_facade_keeps_most_of_the_sun_out_and_dims_less(days):
    none, flat = days.figures('no facade'), days.figures('always open')
    # the flat panels pass 1-6 % of the light: >= 80 % less solar gain (the target)
    assert flat.transmitted_solar_kwh <= 0.2 * none.transmitted_solar_kwh
    assert flat.cooling_kwh_m2 < none.cooling_kwh_m2
    assert flat.lighting_kwh_m2 > none.lighting_kwh_m2  # less daylight, more electric light
    closed = days.figures('always closed')
    assert flat.transmitted_solar_kwh < closed.transmitted_solar_kwh \
        < none.transmitted_solar_kwh


def test_the_callback_writes_what_the_facade_decides_at_each_step(days, facade, table, epw):
    """Replay the loop offline on the same clock: the values EnergyPlus got are the loop's."""
    weather = read_weather(epw)
    row = days.figures('scheduled')
    assert row.steps.size == 3 * 144 and np.all(np.diff(row.steps) == 1)
    station = Site(weather.latitude_deg, weather.longitude_deg, weather.altitude_m)
    # step k of the year starts at 1 January 00:00 local standard time + k 10 min
    offset_s = weather.utc_offset_h * 3600.0
    starts = np.datetime64('2001-01-01T00:00', 's').astype(np.int64) - offset_s \
        + 600.0 * row.steps
    loop = FacadeInTheLoop(facade, 'scheduled', station, starts[0], table=table)
    middles = (starts + 300.0).astype('int64').astype('datetime64[s]').astype('datetime64[ns]')
    sampled = weather_at(weather, middles)
    replay = [loop.step(s, 600.0, d, h, w) for s, d, h, w in zip(
        starts, sampled['dni_w_m2'], sampled['dhi_w_m2'], sampled['wind_speed_m_s'])]
    np.testing.assert_allclose(row.transmittance, [r.transmittance for r in replay],
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(row.ground_reflectance, [0.2 * r.diffuse for r in replay],
                               rtol=0, atol=1e-12)
    assert np.ptp(row.transmittance) > 0.1  # the sun and the controller did move it


def test_the_run_time_actuation_equals_a_static_schedule_of_the_same_values(days, epw,
                                                                            tmp_path):
    row = days.figures('threshold')
    values = np.ones(52560)
    ground = np.full(52560, 0.2)
    values[row.steps], ground[row.steps] = row.transmittance, row.ground_reflectance
    static = run(shoebox_epjson(Room(), report.SCHEDULE, run_period=JULY,
                                sky_diffuse='DetailedSkyDiffuseModeling',
                                shade_offset_m=report.SHADE_OFFSET_M,
                                shade_margin_m=report.SHADE_MARGIN_M,
                                static_schedule_values=values, static_ground_values=ground),
                 epw, str(tmp_path / 'static'))
    floor = Room().width_m * Room().depth_m
    assert static.transmitted_solar_kwh == pytest.approx(row.transmitted_solar_kwh, rel=0.01)
    assert static.cooling_kwh / floor == pytest.approx(row.cooling_kwh_m2, rel=0.01)
    assert static.peak_cooling_w / floor == pytest.approx(row.peak_cooling_w_m2, rel=0.01)
    absorbed = days.figures('threshold')
    assert absorbed.window_absorbed_kwh == pytest.approx(static.window_absorbed_kwh, rel=0.01)
    # EnergyPlus's daylighting differs more: 1.8 % measured here (cause not isolated)
    assert static.lighting_kwh / floor == pytest.approx(row.lighting_kwh_m2, rel=0.03)


def test_unknown_rows_and_wrong_inputs_are_refused(facade, table, epw):
    weather = read_weather(epw)
    with pytest.raises(ValueError, match='unknown rows'):
        report.building_report(facade, weather, epw, rows=('sometimes',), table=table)
    with pytest.raises(TypeError, match='Weather'):
        report.building_report(facade, epw, epw, table=table)
    with pytest.raises(TypeError, match='Room'):
        report.building_report(facade, weather, epw, room={'width_m': 6}, table=table)


COARSE_DAYLIGHT = {'states': (0.0, 0.5, 1.0), 'spacing_m': 2.0,
                   'params': ('-ab', '3', '-ad', '2048', '-lw', '1e-4')}


def test_daylight_follows_the_closures_each_row_held(facade, table, epw):
    lit = report.building_report(facade, read_weather(epw), epw, run_period=((1, 15), (1, 16)),
                                 table=table, daylight=COARSE_DAYLIGHT,
                                 rows=('no facade', 'always open', 'always closed',
                                       'room-aware'))
    figures = {row.name: row.daylight for row in lit.rows}
    assert all(f is not None and f.office_hours == 20 for f in figures.values())
    assert figures['no facade'].mean_lx > figures['always closed'].mean_lx \
        > figures['always open'].mean_lx
    assert figures['always open'].glare_hours <= figures['always closed'].glare_hours
    # the hourly closures the daylight used are the ones the loop wrote
    row = lit.figures('room-aware')
    assert row.closure.size == row.steps.size == 2 * 144
    assert np.all((row.closure >= 0.0) & (row.closure <= 1.0))
    text = '\n'.join(lit.lines())
    assert 'sDA300' in text and 'glare' in text
