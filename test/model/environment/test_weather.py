"""Weather files: values against the raw text, the mid-hour UTC convention, and the errors."""

import csv
import os

import numpy as np
import pvlib
import pytest

from flectofold_model.environment import read_weather, uncovered, weather_at, WeatherError

TMY3 = os.path.join(os.path.dirname(pvlib.__file__), 'data', '723170TYA.CSV')

EPW_HEADER = [
    'LOCATION,Stuttgart,BW,DEU,TEST,107380,48.83,9.20,1.0,318.0',
    'DESIGN CONDITIONS,0', 'TYPICAL/EXTREME PERIODS,0', 'GROUND TEMPERATURES,0',
    'HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0', 'COMMENTS 1,test', 'COMMENTS 2,test',
    'DATA PERIODS,1,1,Data,Sunday, 6/20,6/22',
]


def _epw_row(year, month, day, hour, temp_c=20.0, ghi=0, dni=0, dhi=0, wdir=180, wspd=3.0):
    fields = [year, month, day, hour, 60, 'A7A7', temp_c, 10.0, 70, 98000, 0, 1400, 350,
              ghi, dni, dhi, 0, 0, 0, 0, wdir, wspd, 5, 5, 20.0, 77777, 9, '999999999',
              10, 0.1, 0, 88, 0.2, 0, 1.0]
    return ','.join(str(f) for f in fields)


def _write_epw(path, days=2, override=None):
    rows = []
    for d in range(days):
        for h in range(1, 25):
            kw = {'ghi': max(0, 100 * (12 - abs(h - 13))), 'dni': max(0, 80 * (12 - abs(h - 13))),
                  'dhi': max(0, 20 * (12 - abs(h - 13))), 'wspd': 1.0 + h / 10.0,
                  'wdir': 10 * h, 'temp_c': 10.0 + h / 2.0}
            kw.update((override or {}).get((d, h), {}))
            rows.append(_epw_row(1995, 6, 20 + d, h, **kw))
    path.write_text('\n'.join(EPW_HEADER + rows) + '\n')
    return rows


def test_tmy3_values_match_raw_text():
    w = read_weather(TMY3)
    with open(TMY3, newline='') as f:
        reader = csv.reader(f)
        next(reader)
        header = next(reader)
        raw = list(reader)
    names = ('DNI (W/m^2)', 'DHI (W/m^2)', 'Wspd (m/s)', 'Wdir (degrees)', 'Dry-bulb (C)')
    col = {n: header.index(n) for n in names}
    assert len(w.time_utc) == len(raw) == 8760
    # Row i ends at hour i+1 local (UTC-5): mid-hour UTC is 05:30 + i hours after Jan 1 00:00.
    for i in (0, 13, 4000, 8759):
        expected = (np.datetime64('2001-01-01T00:00', 'ns') + np.timedelta64(5 * 60 + 30, 'm')
                    + np.timedelta64(i, 'h'))
        if expected >= np.datetime64('2002-01-01', 'ns'):
            expected -= np.timedelta64(365, 'D')
        j = int(np.searchsorted(w.time_utc, expected))
        assert w.time_utc[j] == expected
        assert w.dni_w_m2[j] == float(raw[i][col['DNI (W/m^2)']])
        assert w.dhi_w_m2[j] == float(raw[i][col['DHI (W/m^2)']])
        assert w.wind_speed_m_s[j] == float(raw[i][col['Wspd (m/s)']])
        assert w.wind_direction_rad[j] == pytest.approx(
            np.radians(float(raw[i][col['Wdir (degrees)']])))
        assert w.temperature_c[j] == float(raw[i][col['Dry-bulb (C)']])
    assert w.utc_offset_h == -5.0 and w.latitude_deg == pytest.approx(36.1)
    assert np.all(np.diff(w.time_utc) > np.timedelta64(0, 'ns'))


def test_epw_mid_hour_utc_and_interpolation(tmp_path):
    path = tmp_path / 's.epw'
    rows = _write_epw(path)
    w = read_weather(path)
    assert len(w.time_utc) == len(rows) == 48
    # EPW hour 1 of 20 June at UTC+1 covers 00:00-01:00 local = 23:00-24:00 UTC on 19 June.
    assert w.time_utc[0] == np.datetime64('2001-06-19T23:30', 'ns')
    raw = list(csv.reader(rows))
    assert np.array_equal(w.dni_w_m2, [float(r[14]) for r in raw])
    assert np.array_equal(w.wind_speed_m_s, [float(r[21]) for r in raw])
    assert w.latitude_deg == pytest.approx(48.83) and w.altitude_m == 318.0
    # Year ignored: 2026-06-20 11:00 UTC lies halfway between rows 11 and 12 (mid-hour stamps).
    at = weather_at(w, np.array(['2026-06-20T11:00'], dtype='datetime64[ns]'))
    assert at['dni_w_m2'][0] == pytest.approx((w.dni_w_m2[11] + w.dni_w_m2[12]) / 2)
    assert at['wind_speed_m_s'][0] == w.wind_speed_m_s[11]
    part = w.between('2001-06-20T00:00', '2001-06-20T05:00')
    assert list(part.time_utc) == list(w.time_utc[1:6])


@pytest.mark.parametrize('override, message', [
    ({(0, 5): {'dni': 9999}}, 'missing'),
    ({(0, 5): {'wspd': 150.0}}, 'outside'),
    ({(1, 3): {'ghi': -5}}, 'outside'),
])
def test_epw_bad_values(tmp_path, override, message):
    path = tmp_path / 'bad.epw'
    _write_epw(path, override=override)
    with pytest.raises(WeatherError, match=message):
        read_weather(path)


def test_file_errors(tmp_path):
    with pytest.raises(WeatherError, match='not found'):
        read_weather(tmp_path / 'nope.epw')
    other = tmp_path / 'x.txt'
    other.write_text('hello world\n1,2\n')
    with pytest.raises(WeatherError, match='neither'):
        read_weather(other)
    truncated = tmp_path / 't.epw'
    truncated.write_text('\n'.join(EPW_HEADER) + '\n1995,6,20\n')
    with pytest.raises(WeatherError):
        read_weather(truncated)


def test_a_span_outside_the_file_is_named_and_one_inside_is_not(tmp_path):
    path = tmp_path / 's.epw'
    _write_epw(path)  # 20 and 21 June: stamps 2001-06-19T23:30 .. 2001-06-21T22:30 UTC
    w = read_weather(path)

    def t(text):
        return np.datetime64(text, 'ns')

    assert uncovered(w, t('2026-06-20T10:00'), t('2026-06-20T16:00')) == ''
    # within COVERAGE_MARGIN_S of the first and the last stamp: covered
    assert uncovered(w, t('2026-06-19T22:30'), t('2026-06-21T23:30')) == ''
    # just beyond the margin: not
    assert uncovered(w, t('2026-06-19T22:29'), t('2026-06-20T12:00')).startswith(
        '2026-06-19T22:29:00 UTC lie(s) outside')
    assert uncovered(w, t('2026-06-20T12:00'), t('2026-06-21T23:31')).startswith(
        '2026-06-21T23:31:00 UTC lie(s) outside')
    reason = uncovered(w, t('2026-01-15T11:00'), t('2026-01-15T12:00'))
    assert reason == (f'2026-01-15T11:00:00 and 2026-01-15T12:00:00 UTC lie(s) outside the '
                      f'weather file {w.source}, which covers 2001-06-19T23:30 .. '
                      f'2001-06-21T22:30 UTC (in the reference year 2001)')
