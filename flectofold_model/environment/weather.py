"""Hourly weather from EPW and TMY3 files, read with pvlib [1]_ [2]_ [3]_.

Time convention: each file row holds a value for the hour *ending* at its stamp (local
standard time, the file's UTC offset). :class:`Weather` stamps each row at the middle of
its hour, in UTC. Every file is read into one reference year (:data:`REFERENCE_YEAR`,
year column ignored: TMY files mix years by month); :func:`weather_at` maps a requested
time into that year by its offset from the start of its own UTC year (day of year and
time of day kept, year ignored).

References
----------
.. [1] US DOE, "Auxiliary Programs" (EnergyPlus), EnergyPlus Weather File (EPW) Data Dictionary.
.. [2] Wilcox, S. and Marion, W., "Users Manual for TMY3 Data Sets", NREL/TP-581-43156, 2008.
.. [3] pvlib.iotools.read_epw, pvlib.iotools.read_tmy3, pvlib-python 0.16.1.
"""

from dataclasses import dataclass
import os
from typing import Any, Protocol, Union

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, PathLike

REFERENCE_YEAR = 2001
MAX_WIND_SPEED_M_S = 100.0
MAX_IRRADIANCE_W_M2 = 1500.0
_HALF_HOUR = np.timedelta64(30, 'm')
#: A UTC time: a numpy datetime64, or ISO 8601 text without an offset as numpy reads it.
TimeUtc = Union[np.datetime64, str]


class Place(Protocol):
    """Anything with a ``latitude_deg`` and a ``longitude_deg``: a site, a weather station."""

    @property
    def latitude_deg(self) -> float: ...

    @property
    def longitude_deg(self) -> float: ...


class WeatherError(ValueError):
    """A weather file that is missing, of unknown format, malformed or out of range."""


@dataclass(frozen=True)
class Weather:
    """Hourly weather of one site, stamped mid-hour in UTC (numpy datetime64[ns])."""

    time_utc: np.ndarray
    dni_w_m2: np.ndarray
    dhi_w_m2: np.ndarray
    ghi_w_m2: np.ndarray
    wind_speed_m_s: np.ndarray
    wind_direction_rad: np.ndarray
    temperature_c: np.ndarray
    latitude_deg: float
    longitude_deg: float
    altitude_m: float
    utc_offset_h: float
    source: str

    def between(self, start_utc: TimeUtc, end_utc: TimeUtc) -> 'Weather':
        """Return the rows with ``start_utc <= time_utc <= end_utc`` as a new Weather."""
        # numpy's stubs take no unit with a datetime64 (numpy itself does)
        start = np.datetime64(start_utc, 'ns')  # type: ignore[call-overload]
        end = np.datetime64(end_utc, 'ns')  # type: ignore[call-overload]
        if not start <= end:
            raise WeatherError(f'between: start {start} after end {end}')
        keep = (self.time_utc >= start) & (self.time_utc <= end)
        fields = {n: getattr(self, n)[keep] for n in _SERIES}
        return Weather(**fields, **{n: getattr(self, n) for n in _SITE})


_SERIES = ('time_utc', 'dni_w_m2', 'dhi_w_m2', 'ghi_w_m2', 'wind_speed_m_s',
           'wind_direction_rad', 'temperature_c')
_SITE = ('latitude_deg', 'longitude_deg', 'altitude_m', 'utc_offset_h', 'source')
_COLUMNS = {'dni_w_m2': 'dni', 'dhi_w_m2': 'dhi', 'ghi_w_m2': 'ghi',
            'wind_speed_m_s': 'wind_speed', 'wind_direction_rad': 'wind_direction',
            'temperature_c': 'temp_air'}
# EPW missing-value markers [1]; TMY3 files carry -9900 for missing [2].
_MISSING = {'dni': 9999, 'dhi': 9999, 'ghi': 9999, 'wind_speed': 999,
            'wind_direction': 999, 'temp_air': 99.9}
_RANGES = {'dni': (0, MAX_IRRADIANCE_W_M2), 'dhi': (0, MAX_IRRADIANCE_W_M2),
           'ghi': (0, MAX_IRRADIANCE_W_M2), 'wind_speed': (0, MAX_WIND_SPEED_M_S),
           'wind_direction': (0, 360), 'temp_air': (-90, 70)}


def _detect_format(path: str) -> str:
    if not os.path.isfile(path):
        raise WeatherError(f'weather file not found: {path}')
    with open(path, 'r', encoding='latin-1') as f:
        first = f.readline()
    if first.upper().startswith('LOCATION'):
        return 'epw'
    if len(first.split(',')) == 7:
        return 'tmy3'
    raise WeatherError(f'{path}: neither EPW (LOCATION header) nor TMY3 (7-field header)')


def _read_frame(path: str, kind: str) -> tuple[Any, Any, np.timedelta64]:
    from pvlib import iotools
    try:
        if kind == 'epw':
            data, meta = iotools.read_epw(path, coerce_year=REFERENCE_YEAR)
            stamp_shift = _HALF_HOUR  # pvlib stamps EPW rows at the hour's start
        else:
            data, meta = iotools.read_tmy3(path, coerce_year=REFERENCE_YEAR)
            stamp_shift = -_HALF_HOUR  # pvlib keeps TMY3 hour-ending stamps
    except Exception as exc:  # pvlib/pandas raise many kinds on a malformed file
        raise WeatherError(f'{path}: malformed {kind.upper()} file: {exc}') from exc
    if len(data) == 0:
        raise WeatherError(f'{path}: no data rows')
    return data, meta, stamp_shift


def _column(data: Any, name: str, path: str) -> FloatArray:
    try:
        values = np.asarray(data[name], dtype=float)
    except (KeyError, ValueError, TypeError) as exc:
        raise WeatherError(f'{path}: column {name} missing or not numeric') from exc
    bad = ~np.isfinite(values) | (values == _MISSING[name]) | (values <= -9900)
    if bad.any():
        raise WeatherError(f'{path}: {name} missing (NaN or marker) in {int(bad.sum())} rows, '
                           f'first at row {int(np.argmax(bad))}')
    lo, hi = _RANGES[name]
    out = (values < lo) | (values > hi)
    if out.any():
        i = int(np.argmax(out))
        raise WeatherError(f'{path}: {name} = {values[i]} at row {i} outside [{lo}, {hi}]')
    return values


def _times_utc(data: Any, stamp_shift: np.timedelta64) -> npt.NDArray[np.datetime64]:
    t = data.index.tz_convert('UTC').tz_localize(None).to_numpy().astype('datetime64[ns]')
    t = t + stamp_shift
    year0 = np.datetime64(f'{REFERENCE_YEAR}-01-01', 'ns')
    year1 = np.datetime64(f'{REFERENCE_YEAR + 1}-01-01', 'ns')
    span = year1 - year0
    # Wrap rows the UTC shift pushed outside the reference year back into it.
    return np.where(t < year0, t + span, np.where(t >= year1, t - span, t))


def read_weather(path: PathLike) -> Weather:
    """Read an EPW or TMY3 file (chosen by its first line) into a :class:`Weather`.

    Raises :class:`WeatherError` for a missing file, an unknown format, a malformed file,
    missing values (NaN or the format's markers) or values out of range.
    """
    path = os.fspath(path)
    kind = _detect_format(path)
    data, meta, shift = _read_frame(path, kind)
    times = _times_utc(data, shift)
    order = np.argsort(times, kind='stable')
    series: dict[str, npt.NDArray[Any]] = {'time_utc': times[order]}
    for field, name in _COLUMNS.items():
        series[field] = _column(data, name, path)[order]
    if np.any(np.diff(series['time_utc']) <= np.timedelta64(0, 'ns')):
        raise WeatherError(f'{path}: duplicate timestamps')
    series['wind_direction_rad'] = np.radians(series['wind_direction_rad'])
    return Weather(**series, latitude_deg=float(meta['latitude']),
                   longitude_deg=float(meta['longitude']), altitude_m=float(meta['altitude']),
                   utc_offset_h=float(meta['TZ']),
                   source=_source(path, meta))


def _source(path: str, meta: Any) -> str:
    station = str(meta.get('city', meta.get('Name', ''))).strip('"').strip()
    return f'{os.path.basename(path)} ({station})' if station else os.path.basename(path)


def site_distance_deg(site: Place, other: Place) -> float:
    """Great-circle angle between two places with ``latitude_deg``/``longitude_deg`` [deg].

    E.g. a facade's :class:`~flectofold_model.environment.Site` and a :class:`Weather`'s
    station.
    """
    a, b = np.radians([site.latitude_deg, other.latitude_deg])
    d = np.radians(other.longitude_deg - site.longitude_deg)
    cosine = np.sin(a) * np.sin(b) + np.cos(a) * np.cos(b) * np.cos(d)
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def into_reference_year(times_utc: npt.ArrayLike) -> npt.NDArray[np.datetime64]:
    """Map UTC times into :data:`REFERENCE_YEAR` keeping their offset from their year's start.

    Dates after 28 February of a leap year land one day later in the reference year.
    """
    t = np.atleast_1d(np.asarray(times_utc, dtype='datetime64[ns]'))
    year_start = t.astype('datetime64[Y]').astype('datetime64[ns]')
    return np.datetime64(f'{REFERENCE_YEAR}-01-01', 'ns') + (t - year_start)


#: How far outside a weather file's first and last stamps a time may lie and still count as
#: covered [s]: hourly readings are stamped at mid-hour or hour end, so a whole year's file
#: starts up to an hour after its first midnight.
COVERAGE_MARGIN_S = 3600.0


def uncovered(weather: Weather, start_utc: TimeUtc, end_utc: TimeUtc) -> str:
    """Say where ``[start_utc, end_utc]`` leaves the stamps of ``weather``; '' if it does not.

    Both ends are mapped into the reference year (:func:`into_reference_year`), as
    :func:`weather_at` maps them; a time more than :data:`COVERAGE_MARGIN_S` before the
    first stamp or after the last is uncovered, where :func:`weather_at` would only hold the
    nearest reading. A span crossing the new year is checked end by end.
    """
    first, last = weather.time_utc[0], weather.time_utc[-1]
    margin = np.timedelta64(int(COVERAGE_MARGIN_S * 1e9), 'ns')
    outside = []
    for moment in (start_utc, end_utc):
        t = into_reference_year(moment)[0]
        if t < first - margin or t > last + margin:
            second = np.datetime64(moment, 's')  # type: ignore[call-overload]  # numpy's stubs
            outside.append(str(np.datetime_as_string(second)))
    if not outside:
        return ''
    covered = (f'{np.datetime_as_string(first, "m")} .. {np.datetime_as_string(last, "m")} '
               f'UTC (in the reference year {REFERENCE_YEAR})')
    return (f'{" and ".join(outside)} UTC lie(s) outside the weather file {weather.source}, '
            f'which covers {covered}')


def weather_at(weather: Weather, times_utc: npt.ArrayLike) -> dict[str, FloatArray]:
    """Weather at arbitrary UTC times, each mapped by :func:`into_reference_year`.

    Irradiance and temperature are linear between mid-hour stamps; wind speed and
    direction are held from the latest stamp (a step per hour, as measured hourly). Outside
    the file's stamps the first/last values are held. Returns a dict of arrays by field.
    """
    t = into_reference_year(times_utc)
    x = weather.time_utc.astype('int64').astype(float)
    q = t.astype('int64').astype(float)
    out = {}
    for name in ('dni_w_m2', 'dhi_w_m2', 'ghi_w_m2', 'temperature_c'):
        out[name] = np.interp(q, x, getattr(weather, name))
    held = np.clip(np.searchsorted(weather.time_utc, t, side='right') - 1, 0, len(x) - 1)
    out['wind_speed_m_s'] = weather.wind_speed_m_s[held]
    out['wind_direction_rad'] = weather.wind_direction_rad[held]
    return out
