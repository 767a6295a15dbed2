"""A TMY3 file rewritten as an EPW: the same hours, read back the same, run by EnergyPlus."""

import os

import numpy as np
import pvlib

from flectofold_model.environment import read_weather
from flectofold_model.environment.epw import tmy3_to_epw

TMY3 = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')


def test_the_rewritten_file_reads_back_as_the_same_weather(tmp_path):
    original = read_weather(TMY3)
    rewritten = read_weather(tmy3_to_epw(TMY3, tmp_path / 'gso.epw'))
    for field in ('time_utc', 'dni_w_m2', 'dhi_w_m2', 'ghi_w_m2', 'wind_speed_m_s',
                  'temperature_c'):
        np.testing.assert_array_equal(getattr(rewritten, field), getattr(original, field))
    for field in ('latitude_deg', 'longitude_deg', 'altitude_m', 'utc_offset_h'):
        assert getattr(rewritten, field) == getattr(original, field)


def test_energyplus_runs_on_the_rewritten_file_without_a_warning(tmp_path):
    from flectofold_model.building.energyplus_model import Room, run, shoebox_epjson
    epw = tmy3_to_epw(TMY3, tmp_path / 'gso.epw')
    figures = run(shoebox_epjson(Room(), shade=False, run_period=((7, 1), (7, 2))), str(epw),
                  str(tmp_path / 'run'))
    assert figures.cooling_kwh > 0 and figures.transmitted_solar_kwh > 0
    summary = (tmp_path / 'run' / 'eplusout.err').read_text()
    assert 'Completed Successfully-- 0 Warning; 0 Severe Errors' in summary
