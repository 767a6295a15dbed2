"""The shoebox office in EnergyPlus: the document runs, the facade actuates like a schedule."""

import json

import pytest

from flectofold_model.building.energyplus_model import (DAYS_PER_YEAR, read_figures, Room, run,
                                                        schedule_actuator, shoebox_epjson,
                                                        TIMESTEPS_PER_HOUR)

pytest.importorskip('pyenergyplus.api')
from pyenergyplus import dataset  # noqa: E402, I100

PHOENIX = dataset.weather_files['usa_az_phoenix']
CHICAGO = dataset.weather_files['usa_il_chicago']
STEPS = DAYS_PER_YEAR * 24 * TIMESTEPS_PER_HOUR
#: Three January days (Monday to Wednesday in the model's calendar), 0.1 s per run.
DAYS = ((1, 13), (1, 15))
DETAILED = 'DetailedSkyDiffuseModeling'
#: 0.1 for the time steps ending 10:10 to 14:00, 0.8 otherwise.
MIDDAY_CLOSED = [0.1 if 60 <= i % 144 < 84 else 0.8 for i in range(STEPS)]
FIGURES = ('cooling_kwh', 'heating_kwh', 'lighting_kwh', 'transmitted_solar_kwh',
           'window_absorbed_kwh', 'window_heat_gain_kwh', 'peak_cooling_w')


def relative_gaps(a, b):
    return {name: abs(getattr(a, name) - getattr(b, name)) / max(abs(getattr(b, name)), 1e-9)
            for name in FIGURES if getattr(b, name) != 0.0}


def test_the_document_runs_and_gives_positive_cooling_and_heating(tmp_path):
    # With its internal gains and adiabatic sides the office needs no heating even in a
    # Chicago January; an empty one facing north does.
    empty = Room(people_per_m2=0.0, equipment_w_m2=0.0, lighting_w_m2=0.0, azimuth_deg=0.0)
    winter = run(shoebox_epjson(empty, run_period=DAYS), CHICAGO, str(tmp_path / 'chicago'))
    assert winter.heating_kwh > 1.0
    sunny = run(shoebox_epjson(run_period=DAYS), PHOENIX, str(tmp_path / 'phoenix'))
    assert sunny.cooling_kwh > 1.0 and sunny.peak_cooling_w > 100.0
    assert sunny.transmitted_solar_kwh > 1.0 and sunny.window_absorbed_kwh > 0.0
    assert sunny.lighting_kwh > 0.0
    assert (tmp_path / 'phoenix' / 'eplusout.sql').exists()
    assert read_figures(str(tmp_path / 'phoenix' / 'eplusout.sql')).cooling_kwh == \
        sunny.cooling_kwh


def test_the_document_is_plain_json_with_the_facade_schedule_named():
    document = shoebox_epjson(shade_schedule='Panels')
    assert json.loads(json.dumps(document)) == document
    shade = next(iter(document['Shading:Building:Detailed'].values()))
    assert shade['transmittance_schedule_name'] == 'Panels'
    assert 'Panels' in document['Schedule:Compact']
    assert document['ShadowCalculation']['ShadowCalculation 1'][
        'shading_calculation_update_frequency_method'] == 'Timestep'
    assert 'Shading:Building:Detailed' not in shoebox_epjson(shade=False)


def test_a_facade_left_open_gives_the_same_figures_as_no_facade(tmp_path):
    bare = run(shoebox_epjson(shade=False, run_period=DAYS), PHOENIX, str(tmp_path / 'bare'))
    open_facade = run(shoebox_epjson(run_period=DAYS), PHOENIX, str(tmp_path / 'open'))
    assert all(gap < 1e-9 for gap in relative_gaps(open_facade, bare).values())


def test_a_shaded_facade_lets_less_sun_in(tmp_path):
    bare = run(shoebox_epjson(shade=False, run_period=DAYS), PHOENIX, str(tmp_path / 'bare'))
    shaded = run(shoebox_epjson(run_period=DAYS, static_schedule_values=[0.2] * STEPS),
                 PHOENIX, str(tmp_path / 'shaded'))
    assert shaded.transmitted_solar_kwh < 0.4 * bare.transmitted_solar_kwh
    assert shaded.cooling_kwh < bare.cooling_kwh


@pytest.mark.parametrize('days', [DAYS, ((7, 13), (7, 15))])
def test_actuating_the_schedule_matches_the_same_static_schedule_with_detailed_sky_diffuse(
        tmp_path, days):
    # The recipe: DetailedSkyDiffuseModeling, Timestep shadows, Schedule:Compact at 1.0 in the
    # file, set every zone time step including warm-up. Measured agreement: exact (0.00 %).
    static = run(shoebox_epjson(run_period=days, sky_diffuse=DETAILED,
                                static_schedule_values=MIDDAY_CLOSED),
                 PHOENIX, str(tmp_path / 'static'))
    actuated = run(shoebox_epjson(run_period=days, sky_diffuse=DETAILED), PHOENIX,
                   str(tmp_path / 'actuated'), callback=schedule_actuator(MIDDAY_CLOSED))
    assert all(gap < 0.01 for gap in relative_gaps(actuated, static).values()), \
        relative_gaps(actuated, static)


def test_a_constant_actuated_value_matches_a_static_schedule_that_starts_open(tmp_path):
    # Pinned as measured. A static schedule at 0.2 all year and one at 0.8 from 0 to 1 h
    # (night: no sun) and 0.2 otherwise give the same solar figures but different cooling
    # (+14 % for the first, 13-19 January): EnergyPlus' static path depends on the schedule's
    # early value. The actuated run equals the second exactly, and the first in solar only.
    constant = [0.2] * STEPS
    starts_open = [0.8 if i % 144 < 6 else 0.2 for i in range(STEPS)]
    static = run(shoebox_epjson(run_period=DAYS, sky_diffuse=DETAILED,
                                static_schedule_values=constant),
                 PHOENIX, str(tmp_path / 'static'))
    static_open = run(shoebox_epjson(run_period=DAYS, sky_diffuse=DETAILED,
                                     static_schedule_values=starts_open),
                      PHOENIX, str(tmp_path / 'static_open'))
    actuated = run(shoebox_epjson(run_period=DAYS, sky_diffuse=DETAILED), PHOENIX,
                   str(tmp_path / 'actuated'), callback=schedule_actuator(constant))
    assert all(gap < 0.01 for gap in relative_gaps(actuated, static_open).values())
    gaps = relative_gaps(actuated, static)
    assert gaps['transmitted_solar_kwh'] < 1e-3 and gaps['window_absorbed_kwh'] < 1e-3
    assert 0.02 < gaps['cooling_kwh'] < 0.2


def test_simple_sky_diffuse_lets_too_much_sky_through_an_actuated_facade(tmp_path):
    static = run(shoebox_epjson(run_period=DAYS, static_schedule_values=MIDDAY_CLOSED),
                 PHOENIX, str(tmp_path / 'static'))
    actuated = run(shoebox_epjson(run_period=DAYS), PHOENIX, str(tmp_path / 'actuated'),
                   callback=schedule_actuator(MIDDAY_CLOSED))
    assert actuated.transmitted_solar_kwh > 1.1 * static.transmitted_solar_kwh


@pytest.mark.parametrize('fields, message', [
    ({'width_m': 0.0}, 'width_m must be positive'),
    ({'depth_m': -1.0}, 'depth_m must be positive'),
    ({'height_m': float('nan')}, 'height_m must be positive'),
    ({'window_to_wall': 0.95}, r'window_to_wall must be in \(0, 0.95\)'),
    ({'window_to_wall': 0.0}, r'window_to_wall must be in \(0, 0.95\)'),
    ({'glazing_shgc': 1.2}, r'glazing_shgc must be in \(0, 1\)'),
    ({'glazing_vt': 0.0}, r'glazing_vt must be in \(0, 1\)'),
    ({'glazing_u_w_m2k': 0.0}, 'glazing_u_w_m2k must be positive'),
    ({'lighting_w_m2': -1.0}, 'lighting_w_m2 must not be negative'),
    ({'heating_setpoint_c': 25.0}, 'heating_setpoint_c must be below cooling_setpoint_c'),
    ({'workplane_height_m': 4.0}, r'workplane_height_m must be in \(0, height_m\)'),
])
def test_a_room_out_of_range_is_refused_with_the_field_named(fields, message):
    with pytest.raises(ValueError, match=message):
        Room(**fields)


def test_a_static_schedule_of_the_wrong_length_is_refused():
    with pytest.raises(ValueError, match='8760 hourly or 52560'):
        shoebox_epjson(static_schedule_values=[0.5] * 100)
    with pytest.raises(ValueError, match='shade=True'):
        shoebox_epjson(shade=False, static_schedule_values=[0.5] * 8760)
